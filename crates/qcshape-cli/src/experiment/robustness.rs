//! `qcshape experiment robustness`: classification of the synthetic benchmark under rigid
//! placement, noise, amplitude spread and time warps, every metric against baselines measured
//! in the same run.

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use qcshape::align::Alignment;
use qcshape::metric::{MetricKind, MetricSpec, TermKind};
use qcshape::similarity::{PipelineOptions, Smoothing};
use qcshape::synth::InitialShape;
use qcshape_studies::experiment::robustness::{run, Baseline, Method, RobustnessOptions, Scenario};

use crate::args::SolverArgs;

/// Robustness of the similarity to what real data does (rigid placement, noise, amplitude,
/// timing).
///
/// Generates the synthetic benchmark (6 shapes x 10 deformation kinds: the paper's eight and two
/// with curved vertex trajectories, swing and wring; 4 poses) under each scenario: clean, a
/// random rigid placement of every deformation (up to 35 degrees), vertex noise at the paper's
/// Table 3 variances (1, 5, 20 % of lbar^2) and at 1 and 2 % of the bounding-box diagonal,
/// amplitudes spread by +-50 %, monotone time warps of the pose schedule, and all combined. Every
/// metric (the pipeline's defaults: rigid alignment, Euclidean transfer, eq. 13) and three
/// baselines (concatenated displacement fields, the same after rigid alignment, edge strain) give
/// a distance matrix, scored by leave-one-out 1-NN, kernel k-means and k-medoids accuracy
/// (Hungarian matching), eq. 15 and ARI. The clusterings are stable: the best objective over
/// restarts doubled from --restarts (up to --max-restarts) until the seeds --seed and --seed + 1
/// keep the same partition twice in a row; the restarts used are reported. Several --level
/// values run the same benchmark at each resolution, one column group per level. Writes
/// DIR/robustness.csv and DIR/robustness.md and prints the Markdown.
#[derive(Debug, clap::Args)]
#[command(
    about = "Similarity under rigid motion, noise, amplitude and timing, against baselines",
    long_about
)]
pub struct Args {
    /// Icosphere levels (comma-separated: 2 = 162 vertices, 3 = 642, 4 = 2,562; each a column
    /// group of the tables).
    /// At most 8.
    #[arg(long, value_delimiter = ',', default_value = "2", value_parser = crate::bounds::count::<u32>(0, qcshape::limits::MAX_ICOSPHERE_LEVEL as u64), allow_negative_numbers = true)]
    level: Vec<u32>,
    /// Metrics compared (comma-separated; default: every metric).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = crate::args::metric_list(&MetricKind::ALL),
        value_parser = crate::args::choice::<MetricKind>()
    )]
    metrics: Vec<MetricKind>,
    /// Taubin smoothing iterations of the pipeline's poses (comma-separated: every metric is run
    /// with each value, and with each --smooth-length; 0 = none).
    /// At most 1,000.
    #[arg(long, value_delimiter = ',', value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_SWEEPS as u64), allow_negative_numbers = true)]
    smooth: Vec<usize>,
    /// Smoothing lengths of the pipeline's poses, relative to each data set's area radius
    /// (comma-separated: every metric is run with each value, and with each --smooth; the
    /// library's default, 0.18, when neither is given; 0 = none).
    /// At most 10.
    #[arg(long, value_delimiter = ',', value_parser = crate::bounds::real(qcshape::limits::MAX_SMOOTH_LENGTH), allow_negative_numbers = true)]
    smooth_length: Vec<f64>,
    /// Shapes of the benchmark (comma-separated; default all six).
    #[arg(long, value_delimiter = ',')]
    shapes: Vec<InitialShape>,
    /// Also run the paper's pipeline (no alignment) with the quasi-conformal metric.
    #[arg(long)]
    paper: bool,
    /// Scenarios (comma-separated; default all but combined-noiseless): clean, rigid, noise-var-1,
    /// noise-var-5, noise-var-20, noise-diag-1, noise-diag-2, amplitude, time-warp, combined,
    /// combined-noiseless (the combined scenario without its noise).
    #[arg(long, value_delimiter = ',')]
    scenarios: Vec<String>,
    #[arg(long, help = qcshape::settings::LAMBDA.help(), default_value = qcshape::settings::LAMBDA.default_text(), value_parser = crate::args::real(&qcshape::settings::LAMBDA), allow_negative_numbers = true)]
    lambda: f64,
    /// Weights of the bending term to compare (comma-separated; each metric runs once per
    /// value; default the library's).
    /// At most 1e6.
    #[arg(long, value_delimiter = ',', value_parser = crate::args::real(&qcshape::settings::BENDING), allow_negative_numbers = true)]
    bending: Vec<f64>,
    /// Also run each metric at the calibrated releases' form (`--scale calibrated --stretch 0`,
    /// no bending term), as a baseline in the same run.
    #[arg(long)]
    calibrated: bool,
    #[command(flatten)]
    solver: SolverArgs,
    /// Poses per deformation.
    /// At most 10,000.
    #[arg(long, default_value_t = 4, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_POSES as u64), allow_negative_numbers = true)]
    poses: usize,
    /// Clustering restarts per seed in the stable protocol's first round.
    /// At most 10,000.
    #[arg(long, default_value_t = qcshape::defaults::RESTARTS, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_RESTARTS as u64), allow_negative_numbers = true)]
    restarts: usize,
    /// Most clustering restarts per seed the stable protocol grows to (at least --restarts).
    /// At most 10,000.
    #[arg(long, default_value_t = qcshape::cluster::stable::MAX_STABLE_RESTARTS, value_parser = crate::bounds::count::<usize>(1, qcshape::limits::MAX_RESTARTS as u64), allow_negative_numbers = true)]
    max_restarts: usize,
    /// Seed of the data and the clusterings.
    #[arg(long, default_value_t = qcshape::defaults::SEED)]
    seed: u64,
    /// Output folder.
    #[arg(long)]
    out: PathBuf,
}

/// Runs the command.
pub fn run_command(args: &Args) -> Result<()> {
    if !(args.lambda >= 0.0 && args.lambda.is_finite()) {
        bail!("--lambda must be a non-negative number");
    }
    if args.max_restarts < args.restarts {
        bail!(
            "--max-restarts ({}) must be at least --restarts ({})",
            args.max_restarts,
            args.restarts
        );
    }
    let scenarios: Vec<Scenario> = if args.scenarios.is_empty() {
        Scenario::defaults()
    } else {
        args.scenarios
            .iter()
            .map(|n| Scenario::named(n).context("--scenarios"))
            .collect::<Result<_>>()?
    };
    let geodesic = args.solver.options()?;
    let mut smooth: Vec<Smoothing> = args.smooth.iter().map(|&n| Smoothing::Iterations(n)).collect();
    smooth.extend(args.smooth_length.iter().map(|&l| Smoothing::Length(l)));
    if smooth.is_empty() {
        smooth.push(PipelineOptions::default().smoothing);
    }
    let bendings = if args.bending.is_empty() {
        vec![qcshape::defaults::BENDING]
    } else {
        args.bending.clone()
    };
    let spec = |kind: MetricKind, bending: f64| MetricSpec {
        lambda: args.lambda,
        bending,
        ..MetricSpec::new(kind)
    };
    let pipeline_with = |metric: MetricSpec, align: Alignment, smoothing: Smoothing| PipelineOptions {
        metric,
        geodesic: geodesic.clone(),
        align,
        smoothing,
        ..Default::default()
    };
    let pipeline = |kind: MetricKind, align: Alignment, smoothing: Smoothing| {
        pipeline_with(spec(kind, bendings[0]), align, smoothing)
    };
    let mut methods: Vec<Method> = Baseline::all().into_iter().map(Method::Baseline).collect();
    // Metrics without a bending term (registry: L2 and rigid) run once, at the first value.
    let bends = |kind: MetricKind| !kind.has_term(TermKind::Bending);
    for kind in &args.metrics {
        for &s in &smooth {
            let name = if smooth.len() > 1 {
                format!("{} ({s})", kind.label())
            } else {
                kind.label().to_string()
            };
            let values = if bends(*kind) {
                &bendings[..1]
            } else {
                &bendings[..]
            };
            for &b in values {
                let name = if values.len() > 1 {
                    format!("{name} (bending {})", qcshape::numfmt::plain(b))
                } else {
                    name.clone()
                };
                methods.push(Method::Pipeline {
                    name,
                    options: Box::new(pipeline_with(spec(*kind, b), Alignment::Rigid, s)),
                });
            }
            if args.calibrated && !bends(*kind) {
                methods.push(Method::Pipeline {
                    name: format!("{name} (calibrated)"),
                    options: Box::new(pipeline_with(
                        MetricSpec {
                            lambda: args.lambda,
                            ..MetricSpec::calibrated(*kind)
                        },
                        Alignment::Rigid,
                        s,
                    )),
                });
            }
        }
    }
    if args.paper {
        methods.push(Method::Pipeline {
            name: "quasi-conformal (paper: no alignment, no smoothing)".into(),
            options: Box::new(pipeline(
                MetricKind::QuasiConformal,
                Alignment::None,
                Smoothing::Iterations(0),
            )),
        });
    }
    let mut opts = RobustnessOptions {
        levels: args.level.clone(),
        poses: args.poses,
        scenarios,
        methods,
        seed: args.seed,
        restarts: args.restarts,
        max_restarts: args.max_restarts,
        ..Default::default()
    };
    if !args.shapes.is_empty() {
        opts.shapes = args.shapes.clone();
    }
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let total = opts.levels.len() * opts.scenarios.len() * opts.methods.len();
    let done = AtomicUsize::new(0);
    let t0 = Instant::now();
    let report = run(&opts, &|level, scenario, method| {
        let k = done.fetch_add(1, Ordering::Relaxed) + 1;
        eprintln!(
            "[{k}/{total}, {:.0} s] level {level}, {scenario}: {method}",
            t0.elapsed().as_secs_f64()
        );
    })?;
    let md = report.to_markdown();
    for (name, text) in [("robustness.csv", report.to_csv()), ("robustness.md", md.clone())] {
        let path = args.out.join(name);
        qcshape::io::write_atomically(&path, |w| w.write_all(text.as_bytes()))
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    outln!("{md}");
    Ok(())
}
