//! `qcshape embed`: project deformations to 2-D or 3-D by MDS (eq. 16) and plot them.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use qcshape::embed::{smacof, MdsOptions};
use qcshape::eval::encode_labels;
use qcshape::io::write_atomically;
use qcshape_studies::plot::{heatmap, scatter_map};

use crate::input::{load_labels, load_matrix};

/// Project deformations onto 2 or 3 dimensions from their distance matrix (eq. 16).
///
/// SMACOF minimizes the raw stress sum_{i<j} (|x_i - x_j| - d_ij)^2 starting from classical
/// MDS. Writes the coordinates (name,x,y[,z][,label]) and, on request, a map of the
/// deformations coloured by class and a heat map of the matrix ordered by class (.svg or
/// .png, chosen by extension). Prints the raw and normalized (stress-1) stress.
#[derive(Debug, clap::Args)]
#[command(
    about = "MDS projection of deformations from a distance matrix, with plots",
    long_about
)]
pub struct Args {
    /// Distance matrix CSV (name,<name_1>,...,<name_n>).
    matrix: PathBuf,
    /// Embedding dimension: 2 or 3. At most 3.
    #[arg(long, default_value_t = 2, value_parser = crate::bounds::count::<u8>(2, 3), allow_negative_numbers = true)]
    dims: u8,
    /// Class labels: a data set manifest (deformation,label,pose,path) or a name,label CSV.
    #[arg(long)]
    labels: Option<PathBuf>,
    /// Write name,x,y[,z][,label] to this CSV.
    #[arg(short, long)]
    out: Option<PathBuf>,
    /// Draw the map of the first two coordinates (.svg or .png).
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Draw a heat map of the matrix, ordered by class when labels are given (.svg or .png).
    #[arg(long)]
    heatmap: Option<PathBuf>,
    /// Title of the map.
    #[arg(long, default_value = "Deformations (MDS)")]
    title: String,
    /// Seed of the jitter used only when the classical start puts distinct items together.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Maximum SMACOF iterations.
    /// At most 1,000,000.
    #[arg(long, default_value_t = 1000, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_ITERATIONS as u64), allow_negative_numbers = true)]
    max_iterations: usize,
    /// Stop when the stress decreases by less than this fraction in one iteration.
    /// At most 1.
    #[arg(long, default_value_t = 1e-10, value_parser = crate::bounds::real(qcshape::limits::MAX_TOLERANCE), allow_negative_numbers = true)]
    tolerance: f64,
    /// Print the result as JSON.
    #[arg(long)]
    json: bool,
}

/// Runs the command.
pub fn run(args: &Args) -> Result<()> {
    let given: Vec<&std::path::Path> = std::iter::once(args.matrix.as_path())
        .chain(args.labels.as_deref())
        .collect();
    crate::input::refuse_outputs(
        &given,
        &[
            (args.out.as_deref(), "-o"),
            (args.plot.as_deref(), "--plot"),
            (args.heatmap.as_deref(), "--heatmap"),
        ],
    )?;
    if args.tolerance.is_nan() || args.tolerance < 0.0 {
        bail!("--tolerance must be non-negative");
    }
    let d = load_matrix(&args.matrix)?;
    let labels = match &args.labels {
        Some(p) => Some(load_labels(p, &d)?),
        None => None,
    };
    let opts = MdsOptions {
        dims: args.dims as usize,
        max_iterations: args.max_iterations,
        tolerance: args.tolerance,
        seed: args.seed,
    };
    let e = smacof(&d, &opts).with_context(|| format!("{}: cannot embed", args.matrix.display()))?;
    if let Some(out) = &args.out {
        let mut w = csv::Writer::from_writer(Vec::new());
        let mut header = vec!["name", "x", "y", "z"][..=opts.dims].to_vec();
        if labels.is_some() {
            header.push("label");
        }
        w.write_record(&header)?;
        for (i, name) in d.names().iter().enumerate() {
            let mut rec = vec![name.clone()];
            rec.extend(e.coords[i].iter().map(|v| format!("{v:?}")));
            if let Some(l) = &labels {
                rec.push(l[i].clone());
            }
            w.write_record(&rec)?;
        }
        let bytes = w.into_inner()?;
        write_atomically(out, |o| o.write_all(&bytes))?;
    }
    if let Some(p) = &args.plot {
        scatter_map(
            p,
            &e.coords,
            d.names(),
            labels.as_deref(),
            &args.title,
            Some(e.normalized_stress),
        )?;
    }
    if let Some(p) = &args.heatmap {
        let order: Vec<usize> = match &labels {
            Some(l) => {
                let (class_of, _) = encode_labels(l);
                let mut order: Vec<usize> = (0..d.len()).collect();
                order.sort_by_key(|&i| class_of[i]);
                order
            }
            None => (0..d.len()).collect(),
        };
        let name = args
            .matrix
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        heatmap(
            p,
            &d,
            &order,
            labels.as_deref(),
            &format!("Distance matrix {name} ({} deformations)", d.len()),
            "distance",
        )?;
    }
    if args.json {
        let v = serde_json::json!({
            "n": d.len(),
            "dims": opts.dims,
            "raw_stress": e.raw_stress,
            "normalized_stress": e.normalized_stress,
            "initial_raw_stress": e.history[0],
            "iterations": e.iterations,
            "converged": e.converged,
            "eigenvalues": e.eigenvalues,
            "coords": d.names().iter().zip(&e.coords)
                .map(|(n, c)| serde_json::json!({"name": n, "coords": c})).collect::<Vec<_>>(),
        });
        outln!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        outln!("deformations {}", d.len());
        outln!("dimensions   {}", opts.dims);
        let num = |x: f64| qcshape::numfmt::significant(x, 7);
        outln!(
            "stress       {} (raw), {} normalized (stress-1); classical start {}",
            num(e.raw_stress),
            num(e.normalized_stress),
            num(e.history[0])
        );
        outln!(
            "iterations   {} ({})",
            e.iterations,
            if e.converged { "converged" } else { "not converged" }
        );
    }
    Ok(())
}
