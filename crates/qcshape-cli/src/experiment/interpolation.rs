//! `qcshape experiment interpolation`: interpolation accuracy per metric (paper section 3.1,
//! Fig. 4).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use indicatif::ProgressBar;
use qcshape::dataset::{load_sequence, mesh_files, Dataset, Deformation};
use qcshape::geodesic::{GeodesicOptions, Solver};
use qcshape::metric::MetricKind;
use qcshape::synth::{genus0_benchmark, SynthOptions};
use qcshape_studies::experiment::interpolation::{pick_frames, InterpolationExperiment};

use crate::args::{choice, count, flag_error, in_pool, real, VariantArgs};
use qcshape::settings as S;

/// Interpolation accuracy per metric (paper section 3.1, Fig. 4).
///
/// The middle pose of each deformation is interpolated from its first and last pose along each
/// metric's discrete geodesic and compared with the true middle pose; the error of a vertex is
/// its distance to the true position divided by the mean edge length of the true pose. Per
/// deformation type and metric, the mean and SD over the deformations of that type are
/// reported, with the linear interpolation (average of first and last) as the baseline.
/// Without INPUT the built-in genus-0 benchmark (6 shapes x 8 deformations, 3 poses) is used.
///
/// With --real, each interior frame k of a real sequence is also interpolated from frames
/// k - 1 and k + 1 (leave-one-frame-out). A biv-me patient (the biv-me example data, Apache-2.0,
/// not shipped with qcshape: 1572 vertices, 25 frames) is run only when given, as it is slow:
/// `--real DIR --real-pattern LV_ENDO --real-frames 8`, DIR the patient's folder of frames.
///
/// Writes DIR/interpolation.{csv,md,svg,png}, DIR/interpolation_cases.csv, error-map PLYs of
/// one deformation (Fig. 4a-b: predicted middle pose with the error as scalar `error` and as
/// colours on one shared scale), and with --real DIR/leave_one_out{,_frames}.csv and .md.
/// The Markdown tables are printed.
#[derive(Debug, clap::Args)]
#[command(
    about = "Interpolation error of each metric (paper section 3.1, Fig. 4)",
    long_about
)]
pub struct Args {
    /// A data set (manifest CSV or folder); default: the built-in genus-0 benchmark.
    input: Option<PathBuf>,
    /// Icosphere level of the built-in benchmark (10 * 4^level + 2 vertices: 2 gives 162).
    /// At most 8.
    #[arg(long, default_value_t = 2, value_parser = crate::bounds::count::<u32>(0, qcshape::limits::MAX_ICOSPHERE_LEVEL as u64), allow_negative_numbers = true)]
    level: u32,
    /// Seed of the built-in benchmark's amplitude jitter.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Relative amplitude jitter of the built-in benchmark.
    #[arg(long, default_value_t = 0.1, allow_negative_numbers = true)]
    jitter: f64,
    /// Metrics compared (comma-separated; default: Fig. 4's).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = crate::args::metric_list(&qcshape_studies::experiment::interpolation::FIG4_METRICS),
        value_parser = crate::args::choice::<MetricKind>()
    )]
    metrics: Vec<MetricKind>,
    #[command(flatten)]
    variants: VariantArgs,
    /// Poses inserted between the two known poses (odd; the middle one is compared).
    /// At most 1,000.
    #[arg(long, default_value_t = 1, value_parser = count(&S::INSERT), allow_negative_numbers = true)]
    insert: usize,
    #[arg(long, help = S::LEVELS.help(), default_value = S::LEVELS.default_text(), value_parser = count(&S::LEVELS), allow_negative_numbers = true)]
    levels: usize,
    #[arg(long, help = S::SOLVER.help(), default_value = S::SOLVER.default_text(), value_parser = choice::<Solver>())]
    solver: Solver,
    #[arg(long, help = S::TOLERANCE.help(), default_value = S::TOLERANCE.default_text(), value_parser = real(&S::TOLERANCE), allow_negative_numbers = true)]
    tolerance: f64,
    #[arg(long, help = S::ENERGY_TOLERANCE.help(), default_value = S::ENERGY_TOLERANCE.default_text(), value_parser = real(&S::ENERGY_TOLERANCE), allow_negative_numbers = true)]
    energy_tolerance: f64,
    /// Iteration limit of each geodesic solve (default: the solver's own: 1,000 for the
    /// preconditioned L-BFGS, 100 for the Gauss-Newton family, 5,000 for plain L-BFGS).
    /// At most 1,000,000.
    #[arg(long, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_ITERATIONS as u64), allow_negative_numbers = true)]
    max_iterations: Option<usize>,
    /// Deformation whose predicted poses are written as error maps (default: the first `bend`).
    #[arg(long)]
    showcase: Option<String>,
    /// A folder of mesh files of one real sequence (or the files' common folder): also run
    /// leave-one-frame-out on it.
    #[arg(long)]
    real: Option<PathBuf>,
    /// Use only the files of --real whose names contain this text (e.g. LV_ENDO); empty: all.
    #[arg(long, default_value = "ENDO")]
    real_pattern: String,
    /// Predict at most this many interior frames of --real, evenly spaced (0 = all).
    /// At most 10,000.
    #[arg(long, default_value_t = 8, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_POSES as u64), allow_negative_numbers = true)]
    real_frames: usize,
    /// Output folder.
    #[arg(long)]
    out: PathBuf,
    /// Worker threads (default: all cores).
    /// At most 1,024.
    #[arg(long, value_parser = crate::bounds::count::<usize>(1, qcshape::limits::MAX_THREADS as u64), allow_negative_numbers = true)]
    threads: Option<usize>,
}

fn progress_bar(n: usize, what: &str) -> ProgressBar {
    let bar = crate::progress::new_bar(n);
    if let Some(style) = crate::progress::style(&format!(
        "{{bar:40}} {{pos}}/{{len}} {what}, {{elapsed}} (eta {{eta}}{{solver}})"
    )) {
        bar.set_style(style);
    }
    crate::progress::start(&bar);
    bar
}

fn load_real(dir: &Path, pattern: &str) -> Result<Deformation> {
    let files = if dir.is_dir() {
        mesh_files(dir)?
    } else {
        bail!("--real {}: not a folder", dir.display());
    };
    let chosen: Vec<PathBuf> = files
        .into_iter()
        .filter(|f| {
            f.file_name()
                .is_some_and(|n| n.to_string_lossy().contains(pattern))
        })
        .collect();
    if chosen.len() < 3 {
        bail!(
            "--real {}: {} mesh file(s) match --real-pattern {pattern:?}; leave-one-out needs 3 or more",
            dir.display(),
            chosen.len()
        );
    }
    load_sequence(&chosen).with_context(|| {
        format!(
            "--real {}: the files matching {pattern:?} must be one sequence on one mesh (narrow --real-pattern)",
            dir.display()
        )
    })
}

/// Runs the command.
pub fn run(args: &Args) -> Result<()> {
    in_pool(args.threads, || run_in_pool(args))
}

fn run_in_pool(args: &Args) -> Result<()> {
    let given: Vec<&std::path::Path> = args.input.iter().chain(&args.real).map(|p| p.as_path()).collect();
    crate::input::refuse_out_folder(&given, &args.out, "--out")?;
    let t0 = Instant::now();
    let metrics = args
        .metrics
        .iter()
        .map(|&kind| args.variants.spec(kind))
        .collect::<Result<Vec<_>>>()?;
    if metrics.is_empty() {
        bail!("--metrics must name at least one metric");
    }
    let geodesic = GeodesicOptions {
        solver: args.solver,
        gradient_tolerance: args.tolerance,
        energy_tolerance: args.energy_tolerance,
        max_iterations: args.max_iterations,
        monitor: Some(crate::progress::monitor()),
        ..Default::default()
    };
    geodesic.validate().map_err(flag_error)?;
    let exp = InterpolationExperiment {
        metrics,
        insert: args.insert,
        levels: args.levels,
        geodesic,
        showcase: args.showcase.clone(),
    };
    let defs = match &args.input {
        Some(p) => Dataset::load(p)?.deformations,
        None => genus0_benchmark(&SynthOptions {
            level: args.level,
            seed: args.seed,
            poses: 3,
            jitter: args.jitter,
        })?,
    };
    // Read the real sequence before the long synthetic run, so that a bad path fails fast.
    let real = match &args.real {
        Some(dir) => Some(load_real(dir, &args.real_pattern)?),
        None => None,
    };
    let n = exp.synthetic_cases(&defs);
    eprintln!(
        "interpolating the middle pose of {} deformation(s) with {} metric(s) ({n} geodesics) ...",
        n / exp.metrics.len().max(1),
        exp.metrics.len()
    );
    let bar = progress_bar(n, "interpolations");
    let report = exp.run_synthetic(&defs, &|| bar.inc(1));
    bar.finish_and_clear();
    let report = report?;
    for s in &report.skipped {
        eprintln!("note: skipped {s}");
    }
    report.write(&args.out)?;
    outln!("{}", report.to_markdown());
    eprintln!("synthetic experiment: {:.1} s", t0.elapsed().as_secs_f64());

    if let Some(seq) = real {
        let t1 = Instant::now();
        let frames = pick_frames(seq.n_poses(), args.real_frames);
        eprintln!(
            "leave-one-frame-out on {:?} ({} vertices, {} poses): frames {frames:?} ...",
            seq.name,
            seq.topology.n_vertices(),
            seq.n_poses()
        );
        let bar = progress_bar(frames.len() * exp.metrics.len(), "interpolations");
        let loo = exp.run_leave_one_out(&seq, Some(&frames), &|| bar.inc(1));
        bar.finish_and_clear();
        let loo = loo?;
        loo.write(&args.out)?;
        outln!("{}", loo.to_markdown());
        eprintln!("leave-one-out: {:.1} s", t1.elapsed().as_secs_f64());
    }
    eprintln!("wrote {}", args.out.display());
    Ok(())
}
