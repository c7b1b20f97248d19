//! `qcshape experiment approx`: the cost and the error of approximate similarity matrices
//! against the exact one, measured in one run on the same prepared data.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use qcshape::cluster::ClusterOptions;
use qcshape::dataset::Dataset;
use qcshape::eval::encode_labels;
use qcshape::similarity::{Approx, PipelineOptions};
use qcshape::synth::{genus0_benchmark, perturbed_benchmark, DeformationKind, InitialShape, SynthOptions};
use qcshape_studies::experiment::approx::{compare_modes, Mode};
use qcshape_studies::experiment::robustness::Scenario;

use crate::args::{in_pool, MetricArgs, SolverArgs};

/// How much accuracy a cheaper similarity matrix costs.
///
/// Prepares the data set once (interpolation, alignment, transfer: always exact), then computes
/// the similarity matrix (eq. 13) with the reference mode (geodesics with --steps segments) and
/// with every mode of --modes: `straight-N` (the straight-path length with N segments, no
/// optimization), `exact-N` (geodesics with N segments) or `tangent` (the metric linearized at
/// the common base, O(N) linearizations; for quasi-conformal each pair weighs them by its own
/// curvature-change weights). For each: the time of the
/// similarity step and the speed-up, the Spearman correlation and the largest and median
/// relative error of the pair distances, the agreement of the leave-one-out 1-NN labels, and the
/// ARI between kernel k-means clusterings of the two matrices (same seed). Without INPUT, the
/// synthetic benchmark at --level. Writes DIR/approx.csv and DIR/approx.md and prints the
/// Markdown.
#[derive(Debug, clap::Args)]
#[command(
    about = "Speed-up and error of approximate similarity matrices against the exact one",
    long_about
)]
pub struct Args {
    /// A labelled data set (manifest CSV or folder); default: the synthetic benchmark.
    input: Option<PathBuf>,
    /// Icosphere level of the synthetic benchmark (1 = 42, 2 = 162, 3 = 642 vertices).
    /// At most 8.
    #[arg(long, default_value_t = 2, value_parser = crate::bounds::count::<u32>(0, qcshape::limits::MAX_ICOSPHERE_LEVEL as u64), allow_negative_numbers = true)]
    level: u32,
    /// Instead of the paper's benchmark, the robustness benchmark (6 shapes x 10 kinds, 4 poses)
    /// under this scenario of `qcshape experiment robustness` (clean, rigid, noise-var-1, ...,
    /// noise-diag-2, amplitude, time-warp, combined).
    #[arg(long, conflicts_with = "input")]
    scenario: Option<String>,
    #[command(flatten)]
    metric: MetricArgs,
    #[command(flatten)]
    solver: SolverArgs,
    /// Modes compared with the reference exact-STEPS (comma-separated): straight-N, exact-N,
    /// tangent; `straight` alone means straight-STEPS.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "straight,straight-1,exact-2,exact-4"
    )]
    modes: Vec<String>,
    #[command(flatten)]
    smooth: crate::args::SmoothArgs,
    /// Clustering restarts of the k-means whose agreement (ARI) is measured.
    /// At most 10,000.
    #[arg(long, default_value_t = qcshape::defaults::RESTARTS, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_RESTARTS as u64), allow_negative_numbers = true)]
    restarts: usize,
    /// Seed of the clusterings.
    #[arg(long, default_value_t = qcshape::defaults::SEED)]
    seed: u64,
    /// Worker threads (default: all cores).
    /// At most 1,024.
    #[arg(long, value_parser = crate::bounds::count::<usize>(1, qcshape::limits::MAX_THREADS as u64), allow_negative_numbers = true)]
    threads: Option<usize>,
    /// Output folder.
    #[arg(long)]
    out: PathBuf,
}

/// Runs the command.
pub fn run(args: &Args) -> Result<()> {
    in_pool(args.threads, || run_in_pool(args))
}

fn run_in_pool(args: &Args) -> Result<()> {
    if let Some(input) = &args.input {
        crate::input::refuse_out_folder(&[input], &args.out, "--out")?;
    }
    let defs = match (&args.input, &args.scenario) {
        (Some(path), _) => Dataset::load(path)?.deformations,
        (None, Some(name)) => {
            let sc = Scenario::named(name).context("--scenario")?;
            perturbed_benchmark(
                args.level,
                &InitialShape::all(),
                &DeformationKind::extended(),
                4,
                &sc.perturbation,
                args.seed,
            )?
        }
        (None, None) => genus0_benchmark(&SynthOptions {
            level: args.level,
            ..Default::default()
        })?,
    };
    let labels: Option<Vec<String>> = defs.iter().map(|d| d.label.clone()).collect();
    let classes = labels.as_ref().map(|l| encode_labels(l));
    let k = classes.as_ref().map_or(2, |(_, names)| names.len());
    if k < 2 {
        bail!("the data set needs at least two labels (or none) to score the clusterings");
    }
    let geodesic = args.solver.options()?;
    let steps = geodesic.steps;
    let opts = PipelineOptions {
        metric: args.metric.spec()?,
        geodesic,
        transport: qcshape::defaults::TRANSPORT,
        align: qcshape::defaults::ALIGN,
        smoothing: args.smooth.smoothing(),
        ..Default::default()
    };
    let mut modes = vec![Mode {
        approx: Approx::Exact,
        steps,
    }];
    for m in &args.modes {
        let mut mode: Mode = m.parse().map_err(|e: String| anyhow::anyhow!("--modes: {e}"))?;
        if mode.steps == 0 {
            mode.steps = steps;
        }
        modes.push(mode);
    }
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let cluster = ClusterOptions {
        k,
        restarts: args.restarts,
        seed: args.seed,
        ..Default::default()
    };
    let report = compare_modes(
        &defs,
        &opts,
        &modes,
        classes.as_ref().map(|(c, _)| c.as_slice()),
        &cluster,
        &|name| {
            if !crate::progress::is_quiet() {
                eprintln!("mode {name} ...");
            }
        },
    )?;
    let md = format!(
        "# Approximate similarity against exact-{steps}\n\n{}: {}, seed {}.\n\n{}",
        match (&args.input, &args.scenario) {
            (Some(p), _) => p.display().to_string(),
            (None, Some(s)) => format!("robustness benchmark, level {}, scenario {s}", args.level),
            (None, None) => format!("synthetic benchmark, level {}", args.level),
        },
        opts.metric.label(),
        args.seed,
        report.markdown()
    );
    for (name, text) in [("approx.csv", report.csv()), ("approx.md", md.clone())] {
        let path = args.out.join(name);
        qcshape::io::write_atomically(&path, |w| w.write_all(text.as_bytes()))
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    outln!("{md}");
    Ok(())
}
