//! `qcshape experiment transfer`: the deformation-transfer experiment (paper section 3.2, Fig. 5).

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use qcshape::metric::{ConformalForm, MetricKind, MetricSpec, QcWeights};
use qcshape::synth::{DeformationKind, InitialShape, MAX_LEVEL};
use qcshape::transport::{SchildOptions, Transport};
use qcshape_studies::experiment::transfer::TransferExperiment;

use crate::args::SolverArgs;

/// Transfer analytic deformations from a sphere to other shapes and measure the error.
///
/// Each deformation kind is applied to the source shape (poses at t = 0 .. 1) and transferred
/// to each base with every metric and transport; the result is compared, vertex by vertex, with
/// the same deformation applied to the base directly. The error of a pose is the mean over
/// vertices of |N_k - N*_k| divided by the mean edge length of the ideal pose N*_k. Writes
/// DIR/transfer.csv (every transferred pose), DIR/transfer.md (printed too), the figures
/// DIR/transfer.svg/.png (per metric) and DIR/transfer-kinds.svg/.png (per kind), and the
/// Fig. 5 meshes DIR/fig5/*.ply (per-vertex error as scalar and heat colours).
#[derive(Debug, clap::Args)]
#[command(about = "Deformation-transfer experiment (paper Fig. 5)", long_about)]
pub struct Args {
    /// Icosphere level of the shapes (10 * 4^level + 2 vertices).
    /// At most 8.
    #[arg(long, default_value_t = 2, value_parser = crate::bounds::count::<u32>(0, qcshape::limits::MAX_ICOSPHERE_LEVEL as u64), allow_negative_numbers = true)]
    level: u32,
    /// Metrics, comma-separated (default: Fig. 5's).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = crate::args::metric_list(&qcshape_studies::experiment::transfer::FIG5_METRICS),
        value_parser = crate::args::choice::<MetricKind>()
    )]
    metrics: Vec<MetricKind>,
    /// Transports, comma-separated: parallel, schild, euclidean.
    #[arg(long, value_delimiter = ',', default_value = "parallel,schild,euclidean")]
    transports: Vec<Transport>,
    /// Deformation kinds, comma-separated (default: all eight).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "twist,bend,taper,stretch,bulge,shear,dent,ripple"
    )]
    kinds: Vec<DeformationKind>,
    /// The shape the deformations are applied to first.
    #[arg(long, default_value = "sphere")]
    source: InitialShape,
    /// Bases, comma-separated: sphere, ellipsoid, oblate-ellipsoid, rounded-box, pear, peanut.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "ellipsoid,oblate-ellipsoid,pear"
    )]
    bases: Vec<InitialShape>,
    /// Poses per deformation (t = k / (poses - 1)).
    /// At most 10,000.
    #[arg(long, default_value_t = 3, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_POSES as u64), allow_negative_numbers = true)]
    poses: usize,
    #[arg(long, help = qcshape::settings::LAMBDA.help(), default_value = qcshape::settings::LAMBDA.default_text(), value_parser = crate::args::real(&qcshape::settings::LAMBDA), allow_negative_numbers = true)]
    lambda: f64,
    #[arg(long, help = qcshape::settings::FORM.help(), default_value = qcshape::settings::FORM.default_text(), value_parser = crate::args::choice::<qcshape::metric::ConformalForm>())]
    form: ConformalForm,
    /// Fixed-point corrections of each Schild rung's doubling.
    /// At most 1,000,000.
    #[arg(long, default_value_t = SchildOptions::default().doubling_iterations, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_ITERATIONS as u64), allow_negative_numbers = true)]
    doubling_iterations: usize,
    /// Geodesics (N = number of transport steps per segment).
    #[command(flatten)]
    solver: SolverArgs,
    /// Output folder.
    #[arg(long)]
    out: PathBuf,
}

/// Runs the command.
pub fn run(args: &Args) -> Result<()> {
    if args.level > MAX_LEVEL {
        bail!("--level must be at most {MAX_LEVEL}");
    }
    if args.lambda.is_nan() || args.lambda < 0.0 {
        bail!("--lambda must be non-negative");
    }
    let metrics = args
        .metrics
        .iter()
        .map(|&kind| MetricSpec {
            lambda: args.lambda,
            form: args.form,
            weights: QcWeights::Endpoints,
            ..MetricSpec::new(kind)
        })
        .collect();
    let experiment = TransferExperiment {
        metrics,
        transports: args.transports.clone(),
        kinds: args.kinds.clone(),
        source: args.source,
        bases: args.bases.clone(),
        level: args.level,
        poses: args.poses,
        geodesic: args.solver.options()?,
        schild: SchildOptions {
            doubling_iterations: args.doubling_iterations,
            ..Default::default()
        },
    };
    let n = experiment.n_transfers();
    eprintln!(
        "{} transfers ({} kinds x {} bases; lambda = {}, N = {}) ...",
        n,
        args.kinds.len(),
        args.bases.len(),
        args.lambda,
        args.solver.steps
    );
    let pb = crate::progress::new_bar(n);
    if let Some(style) = crate::progress::style("{bar:40} {pos}/{len} [{elapsed}<{eta}{solver}]") {
        pb.set_style(style);
    }
    crate::progress::start(&pb);
    let report = experiment.run(&|| pb.inc(1));
    pb.finish_and_clear();
    let report = report?;
    let files = report
        .write(&args.out)
        .with_context(|| format!("writing the report to {}", args.out.display()))?;
    out!("{}", report.to_markdown());
    eprintln!("wrote {} files to {}", files.len(), args.out.display());
    Ok(())
}
