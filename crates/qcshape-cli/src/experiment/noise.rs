//! `qcshape experiment noise`: noise resistance of the classification (paper section 3.5,
//! Table 3, eq. 17).

use std::collections::HashSet;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use qcshape::align::Alignment;
use qcshape::dataset::{Dataset, Deformation};
use qcshape::similarity::PipelineOptions;
use qcshape::synth::{genus0_benchmark, NoiseKind, SynthOptions};
use qcshape::transport::Transport;
use qcshape_studies::experiment::noise::NoiseExperiment;

use crate::args::{choice, count, MetricArgs, SolverArgs};
use crate::progress::PipelineBars;
use qcshape::settings as S;

/// `--steps`' default here: [`qcshape_studies::study_defaults::NOISE_STEPS`] (a named exception).
const NOISE_STEPS: &str = "4";

/// Noise resistance of the classification (Table 3, eq. 17).
///
/// Classifies the data set (interpolation, transfer, similarity, k-means with intrinsic means
/// started from seeded kernel k-means), then adds noise to every pose (per-coordinate variance
/// `level/100 * lbar^2`, lbar the pose's mean edge length; Gaussian or uniform with the same
/// variance; docs/method.md), classifies again, and reports tau (eq. 17): the share of deformations
/// whose cluster is unchanged, after Hungarian matching of the clusters. Writes DIR/noise.csv
/// and DIR/noise.md.
#[derive(Debug, clap::Args)]
#[command(
    about = "Noise resistance of the classification (Table 3, eq. 17)",
    long_about,
    mut_arg("steps", |a| a
        .default_value(NOISE_STEPS)
        .long_help("Segments N of every geodesic. Default 4, not the other commands' 8: the setting \
the README's Table 3 was measured with (the experiment classifies the set twice per level).\nAt most 10,000."))
)]
pub struct Args {
    /// A data set (manifest CSV or folder); default: the built-in synthetic set at --level.
    input: Option<PathBuf>,
    /// Icosphere level of the built-in synthetic set.
    /// At most 8.
    #[arg(long, default_value_t = 1, value_parser = crate::bounds::count::<u32>(0, qcshape::limits::MAX_ICOSPHERE_LEVEL as u64), allow_negative_numbers = true)]
    level: u32,
    /// Noise variances in percent.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "1,2.5,5,10,20",
        allow_negative_numbers = true
    )]
    levels: Vec<f64>,
    /// Noise distributions.
    #[arg(long, value_delimiter = ',', default_value = "uniform,gaussian")]
    kinds: Vec<NoiseKind>,
    #[command(flatten)]
    metric: MetricArgs,
    #[command(flatten)]
    solver: SolverArgs,
    #[arg(long, help = S::INSERT.help(), default_value = S::INSERT.default_text(), value_parser = count(&S::INSERT), allow_negative_numbers = true)]
    insert: usize,
    #[arg(long, help = S::TRANSPORT.help(), default_value = S::TRANSPORT.default_text(), value_parser = choice::<Transport>())]
    transport: Transport,
    #[arg(long, help = S::ALIGN.help(), default_value = S::ALIGN.default_text(), value_parser = choice::<Alignment>())]
    align: Alignment,
    #[command(flatten)]
    smooth: crate::args::SmoothArgs,
    /// Number of classes (default: the number of distinct labels).
    /// At most 10,000.
    #[arg(long, value_parser = crate::bounds::count::<usize>(1, qcshape::limits::MAX_CLUSTERS as u64), allow_negative_numbers = true)]
    k: Option<usize>,
    /// Kernel k-means restarts. Default 10, not the other commands' 20: the setting the README's
    /// Table 3 was measured with.
    /// At most 10,000.
    #[arg(long, default_value_t = qcshape_studies::study_defaults::NOISE_RESTARTS, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_RESTARTS as u64), allow_negative_numbers = true)]
    restarts: usize,
    /// Seed of the noise and the clustering.
    #[arg(long, default_value_t = qcshape::defaults::SEED)]
    seed: u64,
    /// Output folder.
    #[arg(long)]
    out: PathBuf,
}

/// Runs the command.
pub fn run(args: &Args) -> Result<()> {
    if let Some(input) = &args.input {
        crate::input::refuse_out_folder(&[input], &args.out, "--out")?;
    }
    let defs: Vec<Deformation> = match &args.input {
        Some(p) => Dataset::load(p)?.deformations,
        None => genus0_benchmark(&SynthOptions {
            level: args.level,
            seed: args.seed,
            ..Default::default()
        })?,
    };
    if defs.len() < 2 {
        bail!("the noise experiment needs at least two deformations");
    }
    if args.levels.iter().any(|l| !(l.is_finite() && *l >= 0.0)) {
        bail!("--levels must be non-negative percentages");
    }
    let classes: HashSet<&str> = defs.iter().filter_map(|d| d.label.as_deref()).collect();
    let k = match args.k {
        Some(k) => k,
        None if classes.len() >= 2 => classes.len(),
        None => bail!("the data set has no labels: give the number of classes with --k"),
    };
    if k == 0 || k > defs.len() {
        bail!(
            "--k must be between 1 and the number of deformations ({})",
            defs.len()
        );
    }
    if args.restarts == 0 {
        bail!("--restarts must be at least 1");
    }
    let opts = PipelineOptions {
        metric: args.metric.spec()?,
        geodesic: args.solver.options()?,
        insert: args.insert,
        levels: qcshape::defaults::LEVELS,
        transport: args.transport,
        align: args.align,
        smoothing: args.smooth.smoothing(),
        base: 0,
        approx: Default::default(),
    };
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let experiment = NoiseExperiment {
        pipeline: opts,
        k,
        restarts: args.restarts,
        seed: args.seed,
        levels: args.levels.clone(),
        kinds: args.kinds.clone(),
    };
    let bars = PipelineBars::new(defs.len());
    let report = experiment.run(&defs, &|run, s| bars.tick(run, s));
    bars.finish();
    let report = report?;
    report
        .write(&args.out)
        .with_context(|| format!("writing the report to {}", args.out.display()))?;
    out!("{}", report.to_markdown());
    Ok(())
}
