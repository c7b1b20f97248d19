//! `qcshape reproduce`: the paper's synthetic experiments (section 3) from one command.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use qcshape::align::Alignment;
use qcshape::metric::MetricKind;
use qcshape::synth::write_benchmark;
use qcshape::transport::Transport;
use qcshape_studies::experiment::provenance::Provenance;
use qcshape_studies::experiment::reproduce::{ReproduceReport, Reproduction, Table3Row};

use crate::args::{choice, count, in_pool, real};
use crate::progress::{bar, PipelineBars};
use qcshape::settings as S;

/// Reproduce the paper's synthetic experiments and write a report beside the paper's figures.
///
/// Generates the 48 synthetic deformations (6 shapes x 8 deformations x 3 poses, `qcshape
/// synth`), then for each metric: interpolation (--insert poses between key poses), transfer to
/// the first pose of the first deformation (--transport), the similarity matrix (eq. 13),
/// k-means into 8 classes (Table 1: eq. 15 sensitivity and specificity, plus leave-one-out 1-NN
/// accuracy and the adjusted Rand index), the MDS map (Fig. 6) and a heat map; the time of each
/// step (Table 2); and the noise resistance of each --noise-metrics classification (Table 3,
/// eq. 17: every metric by default, each a Table 1 run per noise level and kind). Writes DIR/report.md with every table beside the paper's numbers, the figures
/// (SVG and PNG, the PNGs embedded) and the CSVs. report.md is rewritten after every step (each
/// metric, Fig. 4, Fig. 5, each noise level), marked "Partial report: still running" until the
/// last one, so an interrupted run leaves the tables done so far.
/// --quick: coarse meshes (42 vertices), one inserted pose, N = 2, fewer restarts, one noise level.
#[derive(Debug, clap::Args)]
#[command(about = "Reproduce the paper's synthetic tables and figures", long_about)]
pub struct Args {
    /// Output folder (created).
    #[arg(long)]
    out: PathBuf,
    /// Small and fast: icosphere level 1, --insert 1, --steps 2, 5 restarts, noise level 1 %.
    #[arg(long)]
    quick: bool,
    /// Icosphere level of the synthetic meshes (default 2 = 162 vertices; 1 with --quick).
    /// At most 8.
    #[arg(long, value_parser = crate::bounds::count::<u32>(0, qcshape::limits::MAX_ICOSPHERE_LEVEL as u64), allow_negative_numbers = true)]
    level: Option<u32>,
    /// Poses inserted between key poses (default 3 as in section 3.3, not 0; 1 with --quick).
    /// At most 1,000.
    #[arg(long, value_parser = count(&S::INSERT), allow_negative_numbers = true)]
    insert: Option<usize>,
    /// Segments N of every geodesic (default 4 as in Table 1, not 8; 2 with --quick).
    /// At most 10,000.
    #[arg(long, value_parser = count(&S::STEPS), allow_negative_numbers = true)]
    steps: Option<usize>,
    /// k-means restarts (default 20; 5 with --quick).
    /// At most 10,000.
    #[arg(long, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_RESTARTS as u64), allow_negative_numbers = true)]
    restarts: Option<usize>,
    /// Noise variances in percent for Table 3 (default 1,2.5,5,10,20; 1 with --quick).
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
    noise_levels: Option<Vec<f64>>,
    /// Skip Table 3.
    #[arg(long)]
    skip_noise: bool,
    /// Metrics of Table 1 (default: every metric; l2, a baseline the paper does not report,
    /// last).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = crate::args::metric_list(&qcshape_studies::experiment::reproduce::table1_metrics()),
        value_parser = crate::args::choice::<MetricKind>()
    )]
    metrics: Vec<MetricKind>,
    /// Metrics of Table 3 (comma-separated), each one of --metrics (default: every metric of
    /// --metrics; each costs a Table 1 run per noise level and kind).
    #[arg(long, alias = "noise-metric", value_delimiter = ',', value_parser = crate::args::choice::<MetricKind>())]
    noise_metrics: Vec<MetricKind>,
    #[arg(long, help = S::LAMBDA.help(), default_value = S::LAMBDA.default_text(), value_parser = real(&S::LAMBDA), allow_negative_numbers = true)]
    lambda: f64,
    #[arg(long, help = S::SCALE.help(), default_value = S::SCALE.default_text(), value_parser = choice::<qcshape::metric::MetricScale>())]
    scale: qcshape::metric::MetricScale,
    #[arg(long, help = S::TRANSPORT.help(), default_value = S::TRANSPORT.default_text(), value_parser = choice::<Transport>())]
    transport: Transport,
    #[arg(long, help = S::ALIGN.help(), default_value = S::ALIGN.default_text(), value_parser = choice::<Alignment>())]
    align: Alignment,
    #[command(flatten)]
    smooth: crate::args::SmoothArgs,
    /// Seed of the synthetic amplitudes, k-means and noise.
    #[arg(long, default_value_t = qcshape::defaults::SEED)]
    seed: u64,
    /// Skip the second Table 1 with the previous configuration (--scale calibrated) beside it.
    #[arg(long)]
    no_previous: bool,
    /// Worker threads (default: all cores).
    /// At most 1,024.
    #[arg(long, value_parser = crate::bounds::count::<usize>(1, qcshape::limits::MAX_THREADS as u64), allow_negative_numbers = true)]
    threads: Option<usize>,
}

/// The settings of --quick (or the full run) with the explicit options applied.
fn settings(args: &Args) -> Reproduction {
    let base = if args.quick {
        Reproduction::quick()
    } else {
        Reproduction::full()
    };
    Reproduction {
        level: args.level.unwrap_or(base.level),
        insert: args.insert.unwrap_or(base.insert),
        steps: args.steps.unwrap_or(base.steps),
        restarts: args.restarts.unwrap_or(base.restarts),
        noise_levels: args.noise_levels.clone().unwrap_or(base.noise_levels),
        metrics: args.metrics.clone(),
        noise_metrics: args.noise_metrics.clone(),
        lambda: args.lambda,
        scale: args.scale,
        stretch: qcshape::defaults::STRETCH,
        transport: args.transport,
        align: args.align,
        smoothing: args.smooth.smoothing(),
        seed: args.seed,
        previous: !args.no_previous,
    }
}

/// Runs the command.
pub fn run(args: &Args) -> Result<()> {
    in_pool(args.threads, || run_in_pool(args))
}

fn run_in_pool(args: &Args) -> Result<()> {
    let t_all = Instant::now();
    let s = settings(args);
    s.validate()?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let defs = s.benchmark()?;
    let manifest = write_benchmark(&args.out.join("data"), &defs, qcshape::io::Format::Ply)?;
    let labels: Vec<String> = defs.iter().map(|d| d.label.clone().unwrap_or_default()).collect();
    eprintln!(
        "{} synthetic deformations, {} vertices, {} key poses; data in {}",
        defs.len(),
        defs[0].topology.n_vertices(),
        defs[0].poses.len(),
        manifest.display()
    );
    let bars = PipelineBars::new(defs.len());
    let cmd = std::env::args().collect::<Vec<String>>().join(" ");
    let path = args.out.join("report.md");
    // The report of the steps done so far (`after`: the last one; None: the final report).
    let previous_runs = std::cell::RefCell::new(Vec::new());
    let write_report = |runs: &[qcshape_studies::experiment::reproduce::MetricRun],
                        noise_rows: &[Table3Row],
                        figs: [&str; 2],
                        after: Option<String>|
     -> Result<()> {
        let mut report = ReproduceReport::new(
            &s,
            &defs,
            runs,
            noise_rows,
            figs,
            Provenance::current(cmd.clone(), t_all.elapsed().as_secs_f64()),
        )?
        .with_previous(&previous_runs.borrow());
        if let Some(after) = after {
            report = report.partial(after);
        }
        report
            .write(&path)
            .with_context(|| format!("cannot write {}", path.display()))
    };

    let mut runs = Vec::new();
    for &kind in &args.metrics {
        let name = kind.label();
        let r = s.run_metric(&defs, &labels, kind, &|stage| bars.tick(name, stage));
        bars.finish();
        let r = r?;
        r.write(&args.out, &labels)?;
        eprintln!(
            "{name:>16}: sensitivity {:.1} %, specificity {:.1} %, 1-NN {:.1} %, {:.1} s",
            100.0 * r.scores.eq15.sensitivity,
            100.0 * r.scores.eq15.specificity,
            100.0 * r.scores.nn_accuracy,
            r.classified.wall.iter().sum::<f64>()
        );
        runs.push(r);
        write_report(
            &runs,
            &[],
            ["", ""],
            Some(format!(
                "Table 1, {} of {} metrics: {name}",
                runs.len(),
                args.metrics.len()
            )),
        )?;
    }

    // Table 1 again with the previous configuration, beside the default's.
    if s.previous {
        for &kind in &args.metrics {
            let name = format!("{} (previous)", kind.label());
            let r = s.run_previous(&defs, &labels, kind, &|stage| bars.tick(&name, stage));
            bars.finish();
            let r = r?;
            eprintln!(
                "{name:>27}: sensitivity {:.1} %, specificity {:.1} %, 1-NN {:.1} %, {:.1} s",
                100.0 * r.scores.eq15.sensitivity,
                100.0 * r.scores.eq15.specificity,
                100.0 * r.scores.nn_accuracy,
                r.classified.wall.iter().sum::<f64>()
            );
            previous_runs.borrow_mut().push(r);
        }
        write_report(
            &runs,
            &[],
            ["", ""],
            Some("Table 1, previous configuration".into()),
        )?;
    }

    // Fig. 4: interpolation of the middle pose from the first and the last.
    let fig4 = {
        let pb = bar(defs.len(), "interp. error");
        let r = s.fig4().run_synthetic(&defs, &|| pb.inc(1))?;
        pb.finish_and_clear();
        r.write(&args.out.join("fig4"))?;
        eprintln!("{:>16}: {}", "Fig. 4", r.claim());
        r.to_markdown_in("fig4/")
    };
    write_report(&runs, &[], [&fig4, ""], Some("Fig. 4".into()))?;

    // Fig. 5: transfer of analytic deformations from a sphere to other bases.
    let fig5 = {
        let exp = s.fig5();
        let pb = bar(exp.n_transfers(), "transfer error");
        let r = exp.run(&|| pb.inc(1))?;
        pb.finish_and_clear();
        r.write(&args.out.join("fig5"))?;
        r.to_markdown_in("fig5/")
    };
    if !args.skip_noise {
        write_report(&runs, &[], [&fig4, &fig5], Some("Fig. 5".into()))?;
    }

    // Table 3 for each --noise-metrics metric (checked to be among the metrics run), level by
    // level, so an interrupted run has every metric at the first levels.
    let mut noise_rows = Vec::new();
    if !args.skip_noise {
        let references: Vec<_> = s
            .noise_kinds()
            .into_iter()
            .filter_map(|k| runs.iter().find(|r| r.kind == k))
            .collect();
        let cells = s.noise_levels.len() * references.len();
        for &level in &s.noise_levels {
            for reference in &references {
                let name = reference.kind.label();
                let row = s.noise_row(
                    &defs,
                    &labels,
                    reference,
                    level,
                    &|stage| bars.tick(name, stage),
                    &|kind, t| {
                        bars.finish();
                        if let Some(t) = t {
                            eprintln!(
                                "{name:>16}: {level} % {} noise, tau {:.1} %, accuracy {:.1} %",
                                kind.name(),
                                100.0 * t.tau,
                                100.0 * t.accuracy
                            );
                        }
                    },
                )?;
                noise_rows.push(row);
                if noise_rows.len() < cells {
                    write_report(
                        &runs,
                        &noise_rows,
                        [&fig4, &fig5],
                        Some(format!(
                            "Table 3, {} of {cells} metric and noise level runs",
                            noise_rows.len()
                        )),
                    )?;
                }
            }
        }
    }

    write_report(&runs, &noise_rows, [&fig4, &fig5], None)?;
    eprintln!(
        "wrote {} in {:.1} s",
        path.display(),
        t_all.elapsed().as_secs_f64()
    );
    Ok(())
}
