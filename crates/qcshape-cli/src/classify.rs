//! `qcshape classify`: cluster deformations from their distance matrix and, given class
//! labels, score the clustering (eq. 15, 1-NN, ARI).

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use qcshape::cluster::{kernel_kmeans, kmedoids, ClusterOptions};
use qcshape::dataset::Dataset;
use qcshape_studies::experiment::analysis::dataset_labels;
use qcshape_studies::experiment::classification::{classify_set, score, write_assignments, write_confusion};

use crate::args::PipelineArgs;
use crate::input::{is_matrix, load_labels, load_matrix};
use crate::progress::PipelineBars;

/// Cluster deformations into K classes from a distance matrix or a data set (eq. 14).
///
/// INPUT is a distance matrix CSV with the header name,<name_1>,...,<name_n> and one row per
/// deformation (`qcshape similarity`), or a data set (manifest CSV or folder): then its
/// similarity matrix is computed first (interpolation, transfer, eq. 13, with the metric and
/// solver options below), k-means uses intrinsic means (eq. 14, started from the best kernel
/// k-means run), and the data set's labels are used unless --labels is given. k-means runs on squared distances (kernel k-means: the distance to a cluster's
/// implicit centroid); k-medoids is PAM (BUILD + SWAP). Both keep the best of --restarts
/// seeded runs. With --labels (a data set manifest or a name,label CSV) the clusters are
/// matched to the classes by the Hungarian algorithm and the matched confusion matrix, the
/// mean sensitivity and specificity of eq. 15 (one-vs-rest matrices averaged), the
/// leave-one-out 1-nearest-neighbour accuracy and the adjusted Rand index are reported.
#[derive(Debug, clap::Args)]
#[command(
    about = "Cluster deformations from a distance matrix and score against labels",
    long_about
)]
pub struct Args {
    /// Distance matrix CSV (name,<name_1>,...,<name_n>), or a data set (manifest CSV or folder).
    #[arg(value_name = "INPUT")]
    matrix: PathBuf,
    /// Data set input only: the settings of its similarity matrix.
    #[command(flatten)]
    pipeline: PipelineArgs,
    /// Number of clusters.
    /// At most 10,000.
    #[arg(long, value_parser = crate::bounds::count::<usize>(1, qcshape::limits::MAX_CLUSTERS as u64), allow_negative_numbers = true)]
    k: usize,
    /// Clustering method.
    #[arg(long, default_value = "kmeans", value_parser = ["kmeans", "kmedoids"])]
    method: String,
    /// Number of seeded runs; the best objective is kept.
    /// At most 10,000.
    #[arg(long, default_value_t = qcshape::defaults::RESTARTS, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_RESTARTS as u64), allow_negative_numbers = true)]
    restarts: usize,
    /// Seed of the random choices.
    #[arg(long, default_value_t = qcshape::defaults::SEED)]
    seed: u64,
    /// Maximum Lloyd iterations (k-means) or swaps (k-medoids) per run.
    /// At most 1,000,000.
    #[arg(long, default_value_t = 100, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_ITERATIONS as u64), allow_negative_numbers = true)]
    max_iterations: usize,
    /// Class labels: a data set manifest (deformation,label,pose,path) or a name,label CSV.
    #[arg(long)]
    labels: Option<PathBuf>,
    /// Write name,cluster[,label,matched_label] to this CSV.
    #[arg(short, long)]
    out: Option<PathBuf>,
    /// Write the matched confusion matrix (rows: actual class) to this CSV (needs --labels).
    #[arg(long)]
    confusion: Option<PathBuf>,
    /// Print the result as JSON.
    #[arg(long)]
    json: bool,
}

/// Runs the command.
pub fn run(args: &Args) -> Result<()> {
    let given: Vec<&std::path::Path> = std::iter::once(args.matrix.as_path())
        .chain(args.labels.as_deref())
        .collect();
    let outputs = [
        (args.out.as_deref(), "-o"),
        (args.confusion.as_deref(), "--confusion"),
    ];
    crate::input::refuse_outputs(&given, &outputs)?;
    let opts = ClusterOptions {
        k: args.k,
        restarts: args.restarts,
        seed: args.seed,
        max_iterations: args.max_iterations,
    };
    let from_matrix = is_matrix(&args.matrix)?;
    let (d, c, data_labels) = if from_matrix {
        let d = load_matrix(&args.matrix)?;
        let c = match args.method.as_str() {
            "kmedoids" => kmedoids(&d, &opts),
            _ => kernel_kmeans(&d, &opts),
        }
        .with_context(|| format!("{}: cannot cluster", args.matrix.display()))?;
        (d, c, None)
    } else {
        let data = Dataset::load(&args.matrix)?;
        let mut inputs = data.input_paths(&args.matrix);
        inputs.extend(args.labels.as_deref());
        crate::input::refuse_outputs(&inputs, &outputs)?;
        if args.labels.is_none() {
            // Scoring needs a label on every deformation once any has one.
            data.refuse_partial_labels(&args.matrix, "classify")?;
        }
        let popts = args.pipeline.options(&data)?;
        let bars = PipelineBars::new(data.deformations.len());
        let r = classify_set(
            &data.deformations,
            &popts,
            args.k,
            args.restarts,
            args.seed,
            &|s| bars.tick("pairs", s),
        );
        bars.finish();
        let r = r?;
        let c = match args.method.as_str() {
            "kmedoids" => kmedoids(&r.matrix, &opts)?,
            _ => r.clustering,
        };
        (r.matrix, c, dataset_labels(&data.deformations))
    };
    let labels = match (&args.labels, data_labels) {
        (Some(p), _) => Some(load_labels(p, &d)?),
        (None, l) => l,
    };
    if args.confusion.is_some() && labels.is_none() {
        bail!("--confusion needs labels (--labels, or a data set with labels)");
    }
    let scores = labels.as_deref().map(|l| score(&d, &c, l)).transpose()?;
    if let Some(out) = &args.out {
        write_assignments(out, &d, &c, scores.as_ref())?;
    }
    if let (Some(path), Some(s)) = (&args.confusion, &scores) {
        write_confusion(path, s)?;
    }
    let sizes: Vec<usize> = c.members().iter().map(Vec::len).collect();
    if args.json {
        let mut v = serde_json::json!({
            "method": args.method,
            "k": c.k,
            "n": d.len(),
            "restarts": args.restarts,
            "seed": args.seed,
            "objective": c.objective,
            "best_restart": c.restart,
            "restart_objectives": c.restart_objectives,
            "iterations": c.iterations,
            "converged": c.converged,
            "cluster_sizes": sizes,
            "assignments": d.names().iter().zip(&c.assignments)
                .map(|(n, a)| serde_json::json!({"name": n, "cluster": a})).collect::<Vec<_>>(),
            "medoids": c.medoids.as_ref().map(|m| m.iter().map(|&i| d.names()[i].clone()).collect::<Vec<_>>()),
        });
        if let Some(s) = &scores {
            v["classes"] = serde_json::json!(s.classes);
            v["cluster_class"] = serde_json::json!(s
                .matching
                .cluster_class
                .iter()
                .map(|k| k.map(|k| s.classes[k].clone()))
                .collect::<Vec<_>>());
            v["confusion"] = serde_json::json!(s.confusion.counts);
            v["sensitivity"] = serde_json::json!(s.eq15.sensitivity);
            v["specificity"] = serde_json::json!(s.eq15.specificity);
            v["macro_sensitivity"] = serde_json::json!(s.eq15.macro_sensitivity);
            v["macro_specificity"] = serde_json::json!(s.eq15.macro_specificity);
            v["accuracy"] = serde_json::json!(s.confusion.accuracy());
            v["nn_accuracy"] = serde_json::json!(s.nn_accuracy);
            v["ari"] = serde_json::json!(s.ari);
        }
        outln!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(());
    }
    let method = match (args.method.as_str(), from_matrix) {
        ("kmedoids", _) => "k-medoids (PAM)",
        (_, true) => "k-means (kernel, squared distances)",
        // classify_set's assignment step uses intrinsic means (eq. 14), seeded by kernel k-means.
        (_, false) => "k-means (intrinsic means, eq. 14; seeded by kernel k-means)",
    };
    outln!(
        "method       {method}, k = {}, {} deformations, {} restarts, seed {}",
        c.k,
        d.len(),
        args.restarts,
        args.seed
    );
    outln!(
        "objective    {}  (restart {}, {} iterations, {})",
        qcshape::numfmt::significant(c.objective, 7),
        c.restart,
        c.iterations,
        if c.converged { "converged" } else { "not converged" }
    );
    outln!("sizes        {sizes:?}");
    if let Some(s) = &scores {
        outln!("confusion    rows: actual class; columns: class matched to the cluster");
        let width = s.classes.iter().map(|c| c.len()).max().unwrap_or(0).max(9);
        out!("  {:width$}", "");
        for name in &s.classes {
            out!(" {name:>width$}");
        }
        outln!(" {:>width$}", "unmatched");
        for (k, row) in s.confusion.counts.iter().enumerate() {
            out!("  {:width$}", s.classes[k]);
            for v in row {
                out!(" {v:>width$}");
            }
            outln!();
        }
        outln!(
            "sensitivity  {:.4}  (eq. 15 on the mean one-vs-rest matrix; mean per class {:.4})",
            s.eq15.sensitivity,
            s.eq15.macro_sensitivity
        );
        outln!(
            "specificity  {:.4}  (eq. 15 on the mean one-vs-rest matrix; mean per class {:.4})",
            s.eq15.specificity,
            s.eq15.macro_specificity
        );
        outln!("accuracy     {:.4}  (matched)", s.confusion.accuracy());
        outln!(
            "1-NN         {:.4}  (leave-one-out accuracy on the matrix)",
            s.nn_accuracy
        );
        outln!("ARI          {:.4}", s.ari);
    }
    Ok(())
}
