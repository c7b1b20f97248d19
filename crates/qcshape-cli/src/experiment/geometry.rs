//! `qcshape experiment geometry`: whether each metric's geometry counts (the bent tube) and
//! whether its distances converge under mesh refinement (the twisted sphere).

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use qcshape::metric::{MetricKind, MetricSpec};
use qcshape_studies::experiment::geometry::{resolution_rows, tube_rows, GeometryReport};

use crate::args::{in_pool, SolverArgs, VariantArgs};

/// Two measurements with known answers, for every metric and every --lambdas value.
///
/// Bent tube: a tube (length 10, radius 0.6, 1,440 vertices) bent from straight to a half
/// circle; the centre line of the geodesic's middle pose is 10 when the metric keeps lengths
/// and 6.37 for the linear midpoint. Resolution: the unit sphere twisted and stretched by one
/// smooth field, at the icosphere --levels; a metric whose meaning does not depend on the mesh
/// gives converging distances. Every row has the L2 regularizer's share of the energy. Writes
/// DIR/geometry.csv and DIR/geometry.md and prints the Markdown (docs/geometry.md).
#[derive(Debug, clap::Args)]
#[command(
    about = "Does each metric's geometry count? Bent tube and mesh refinement",
    long_about
)]
pub struct Args {
    /// Metrics (comma-separated; default: every metric).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = crate::args::metric_list(&MetricKind::ALL),
        value_parser = crate::args::choice::<MetricKind>()
    )]
    metrics: Vec<MetricKind>,
    /// Values of --lambda, each run with every metric (comma-separated; default: --lambda).
    /// At most 1e6.
    #[arg(long, value_delimiter = ',', value_parser = crate::bounds::real(qcshape::limits::MAX_LAMBDA), allow_negative_numbers = true)]
    lambdas: Vec<f64>,
    /// Icosphere levels of the resolution study (2 = 162, 3 = 642, 4 = 2,562, 5 = 10,242
    /// vertices; at most 6).
    /// At most 8.
    #[arg(long, value_delimiter = ',', default_value = "2,3,4", value_parser = crate::bounds::count::<u32>(0, qcshape::limits::MAX_ICOSPHERE_LEVEL as u64), allow_negative_numbers = true)]
    levels: Vec<u32>,
    /// Skip the bent tube.
    #[arg(long)]
    no_tube: bool,
    #[command(flatten)]
    variants: VariantArgs,
    #[command(flatten)]
    solver: SolverArgs,
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
    if let Some(l) = args.levels.iter().find(|&&l| l > 6) {
        bail!("--levels: {l} is above 6 (40,962 vertices)");
    }
    if args.metrics.is_empty() {
        bail!("--metrics must name at least one metric");
    }
    let lambdas = if args.lambdas.is_empty() {
        vec![args.variants.lambda]
    } else {
        args.lambdas.clone()
    };
    let mut specs: Vec<MetricSpec> = Vec::new();
    for &kind in &args.metrics {
        for &lambda in &lambdas {
            let mut v = args.variants.clone();
            v.lambda = lambda;
            let spec = v.spec(kind).context("--lambdas")?;
            if !specs.contains(&spec) {
                specs.push(spec);
            }
        }
    }
    let options = args.solver.options()?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let rows = in_pool(args.threads, || -> Result<_> {
        let mut rows = if args.no_tube {
            Vec::new()
        } else {
            tube_rows(&specs, &options)?
        };
        rows.extend(resolution_rows(&specs, &args.levels, &options)?);
        Ok(rows)
    })?;
    let report = GeometryReport { rows };
    let md = format!(
        "# Does the geometry count?\n\nN = {} segments per geodesic, solver {}.\n\n{}",
        options.steps,
        options.solver.label(),
        report.markdown()
    );
    for (name, text) in [("geometry.csv", report.csv()), ("geometry.md", md.clone())] {
        let path = args.out.join(name);
        qcshape::io::write_atomically(&path, |w| w.write_all(text.as_bytes()))
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    outln!("{md}");
    Ok(())
}
