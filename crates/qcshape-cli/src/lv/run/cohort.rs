//! `qcshape lv run` on a cohort (images or meshes): file names, printing and the order of the
//! library's steps ([`qcshape::lv::cohort_mesh`], [`qcshape::lv::study`],
//! [`qcshape::lv::study_report`]).

use std::time::Instant;

use anyhow::{bail, Context, Result};
use qcshape::align::Alignment;
use qcshape::dataset::{load_sequence, Dataset};
use qcshape::lv::analysis::Axis;
use qcshape::lv::cohort_mesh::{is_cohort, mesh_cohort, write_meshes, MeshSettings};
use qcshape::lv::cycle_map::cycle_map;
use qcshape::lv::freewall::SectorOptions;
use qcshape::lv::region::{cohort_region, write_region, REGION_NAME};
use qcshape::lv::study::{analyse, baselines, coarsen, compare_methods, labels_of, SplitOptions, Tick};
use qcshape::lv::study_report::{run_report, RunSummary};
use qcshape::similarity::PipelineOptions;

use super::progress::Bars;
use super::{cycle_settings, pattern_files, run_cycle, RunArgs};

/// Runs `lv run` inside the worker pool.
pub(super) fn run(a: &RunArgs) -> Result<()> {
    let t_all = Instant::now();
    if a.restarts == 0 {
        bail!("--restarts must be at least 1");
    }
    let settings = cycle_settings(&a.common, 1)?;
    let opts = PipelineOptions {
        metric: settings.metric,
        geodesic: settings.geodesic.clone(),
        insert: a.common.insert,
        levels: qcshape::defaults::LEVELS,
        transport: a.transport,
        base: 0,
        align: a.align,
        smoothing: PipelineOptions::default().smoothing,
        approx: Default::default(),
    };
    let split = SplitOptions {
        method: a.cluster,
        restarts: a.restarts,
        seed: a.seed,
    };
    if a.tps_lambda != 0.0 && !is_cohort(&a.dir) {
        bail!(
            "{}: --tps-lambda acts on the landmark registration of a cohort folder, not on meshes \
             given as input",
            a.dir.display()
        );
    }
    std::fs::create_dir_all(&a.out).with_context(|| format!("cannot create {}", a.out.display()))?;
    let mesh = MeshSettings {
        threshold: a.threshold,
        smooth: a.smooth,
        vertices: a.common.vertices,
        free_wall: a.region.cuts(),
        sector: a.region.sector(SectorOptions::default()),
        tps_lambda: a.tps_lambda,
        harmonics: landmark_harmonics(a),
        refine: a.refine.0,
    };
    let bars = Bars::default();
    let progress = |t: Tick<'_>| bars.tick(t);
    // The deformations, their long axes and per-subject meshing seconds.
    let mut abnormal = None;
    let (defs, axes, mesh_seconds, input_note, from_images) =
        if is_cohort(&a.dir) {
            let t0 = Instant::now();
            let c = mesh_cohort(&a.dir, a.landmarks, &mesh, &progress)?;
            write_meshes(&a.out.join("meshes"), &c.defs)?;
            // A phantom cohort knows its abnormal region: write it on the template.
            if let Some(w) = cohort_region(&a.dir, &c.defs[0].name, &c.defs[0].poses[0])? {
                let file = a.out.join("meshes").join(REGION_NAME);
                write_region(&file, &w)?;
                abnormal = Some(w.iter().map(|&x| x >= 0.5).collect::<Vec<bool>>());
                eprintln!(
                    "abnormal region of the phantom: {} of {} vertices -> {}",
                    w.iter().filter(|&&x| x >= 0.5).count(),
                    w.len(),
                    file.display()
                );
            }
            eprintln!(
                "meshed {} subjects ({} vertices each, {} of {} projected on their own surface) in {:.1} s",
                c.defs.len(),
                c.defs[0].topology.n_vertices(),
                c.snapped,
                c.defs.len() - 1,
                t0.elapsed().as_secs_f64()
            );
            let frames: usize = c.defs.iter().map(|d| d.poses.len()).sum();
            let refined = match mesh.refine {
                Some(reach) => format!(
                    " Every frame's mesh was then refined on its own image (vertices moved along \
                     their normals to the cavity threshold, searched within {reach} mm): {} of {frames} \
                     frames, root mean square move {:.2} mm.",
                    c.refined.0, c.refined.1
                ),
                None => String::new(),
            };
            if !refined.is_empty() {
                eprintln!("{}", refined.trim());
            }
            let note =
                format!(
            "cohort `{}`: template = frame 0 of `{}` ({} vertices on the whole surface, {} in the {}), \
             carried to the other subjects by the landmark spline between frame-0 landmarks and projected \
             on each subject's own frame-0 surface ({} of {} projected; the rest kept the spline result, \
             which would otherwise fold a triangle).{} Meshes in `meshes/manifest.csv`.",
            a.dir.display(),
            c.defs[0].name,
            c.whole_vertices,
            c.defs[0].topology.n_vertices(),
            if mesh.free_wall { "free wall" } else { "whole surface" },
            c.snapped,
            c.defs.len() - 1,
            refined
        );
            (c.defs, c.axes, c.seconds, note, true)
        } else {
            let seq = if a.dir.is_dir() {
                let f = pattern_files(&a.dir, a.pattern.as_deref())?;
                (!f.is_empty()).then_some(f)
            } else {
                None
            };
            if let Some(files) = seq {
                let def = load_sequence(&files)?;
                eprintln!(
                    "{}: one sequence of {} frames: cycle map only",
                    a.dir.display(),
                    files.len()
                );
                let source = format!("{} files from {}", files.len(), a.dir.display());
                return run_cycle(def, &a.out, &a.common, 1, a.seed, &source);
            }
            let t0 = Instant::now();
            let mut data = Dataset::load(&a.dir)?;
            if data.deformations.len() == 1 {
                let def = data.deformations.pop().expect("one");
                return run_cycle(def, &a.out, &a.common, 1, a.seed, &a.dir.display().to_string());
            }
            let note = coarsen(&mut data.deformations, a.common.vertices)?;
            let axes = data
                .deformations
                .iter()
                .map(|d| Axis::fit(&d.poses[0]).with_context(|| format!("deformation '{}'", d.name)))
                .collect::<Result<Vec<_>>>()?;
            let per = t0.elapsed().as_secs_f64() / data.deformations.len() as f64;
            let n = data.deformations.len();
            let note = format!(
                "meshes from `{}` (no images: registration and meshing skipped, long axes fitted to \
             frame 0{}).",
                a.dir.display(),
                note.map_or(String::new(), |n| format!("; {n}"))
            );
            (data.deformations, axes, vec![per; n], note, false)
        };
    let frames = defs[0].poses.len();

    let main = analyse(&defs, &opts, a.common.open, &split, &progress)?;
    eprintln!(
        "{} landmarks: our method sensitivity {:.1} %, specificity {:.1} % ({:.1} s)",
        a.landmarks,
        100.0 * main.scores.sensitivity,
        100.0 * main.scores.specificity,
        main.wall.iter().sum::<f64>()
    );
    eprintln!("{}", main.shares.line());
    if let Some(w) = main.shares.warning(opts.metric.kind.label()) {
        eprintln!("warning: {w}");
    }
    let base = baselines(&defs, &axes, a.common.open, &split)?;
    for b in &base.rows {
        eprintln!(
            "{}: sensitivity {:.1} %, specificity {:.1} %",
            b.name,
            100.0 * b.scores.sensitivity,
            100.0 * b.scores.specificity
        );
    }
    main.matrix.write_csv(&a.out.join("similarity.csv"))?;
    let methods = compare_methods(&main, &opts, &base, &labels_of(&defs)?, &a.compare, &split)?;
    for m in &methods {
        eprintln!(
            "{} / {}: sensitivity {:.1} %, specificity {:.1} %, ARI {:.3}",
            m.data,
            m.method,
            100.0 * m.scores.sensitivity,
            100.0 * m.scores.specificity,
            m.scores.ari
        );
    }

    // Fig. 9.
    let idx = match &a.mds_subject {
        Some(name) => defs
            .iter()
            .position(|d| &d.name == name)
            .with_context(|| format!("--mds-subject {name:?} is not a subject"))?,
        None => 0,
    };
    let map = cycle_map(
        &main.prepared.interpolated[idx],
        &main.prepared.is_key,
        a.common.insert + 1,
        &main.prepared.topology,
        main.prepared.factor,
        &settings,
        a.seed,
        &progress,
    )?;
    map.write_files(
        &a.out,
        &format!("{}: {} frames + interpolated poses", defs[idx].name, frames),
    )?;

    // report.md after the main run and after each landmark count of Table 5 (marked partial
    // until the last), so an interrupted run leaves what is done.
    let path = a.out.join("report.md");
    let write_report =
        |sweep: &[(usize, qcshape::lv::study::BinaryScores, f64)], partial: Option<String>| -> Result<()> {
            let summary = RunSummary {
                args_line: super::args_line(),
                input_note: input_note.clone(),
                landmarks: a.landmarks,
                from_images,
                region: a.region.name().to_string(),
                frames,
                restarts: a.restarts,
                seed: a.seed,
                mesh_seconds: mesh_seconds.clone(),
                ed_es: base.ed_es.clone(),
                total_seconds: t_all.elapsed().as_secs_f64(),
                mds_subject: defs[idx].name.clone(),
                split: split.sentence(),
                align: match a.align {
                    Alignment::None => String::new(),
                    m => format!(
                    "{} alignment of every subject to the base (area-weighted Procrustes of its frame 0, the \
                     same motion on all its frames), ",
                    m.label()
                ),
                },
                registration: registration_clause(a, from_images),
                transport: a.transport.label().to_string(),
                abnormal: abnormal.clone(),
            };
            let mut md = run_report(
                &a.out, &summary, &settings, &defs, &main, &base.rows, sweep, &map, &methods,
            )?;
            if let Some(after) = partial {
                md = mark_partial(&md, &after);
            }
            qcshape::io::write_atomically(&path, |w| w.write_all(md.as_bytes()))?;
            Ok(())
        };

    // Table 5.
    let mut sweep = Vec::new();
    let sweeping = from_images && !a.no_sweep;
    if sweeping {
        write_report(&sweep, Some("Table 4 and Fig. 9".into()))?;
        for &n in &a.landmark_sweep {
            if n == a.landmarks {
                sweep.push((n, main.scores.clone(), 0.0));
                continue;
            }
            let t0 = Instant::now();
            let c = mesh_cohort(&a.dir, n, &mesh, &progress)?;
            let r = analyse(&c.defs, &opts, a.common.open, &split, &progress)?;
            let secs = t0.elapsed().as_secs_f64();
            eprintln!(
                "{n} landmarks: sensitivity {:.1} %, specificity {:.1} % ({secs:.1} s)",
                100.0 * r.scores.sensitivity,
                100.0 * r.scores.specificity
            );
            sweep.push((n, r.scores, secs));
            write_report(
                &sweep,
                Some(format!(
                    "Table 5, {} of {} landmark counts",
                    sweep.len(),
                    a.landmark_sweep.len()
                )),
            )?;
        }
    }

    write_report(&sweep, None)?;
    eprintln!(
        "wrote {} in {:.1} s",
        path.display(),
        t_all.elapsed().as_secs_f64()
    );
    Ok(())
}

/// `md` with the line "Partial report: still running (written after `after`)" under its title.
fn mark_partial(md: &str, after: &str) -> String {
    let note = format!(
        "**Partial report: still running (written after {after}).** The final report replaces this file.\n\n"
    );
    match md.find("\n\n") {
        Some(i) => format!("{}{note}{}", &md[..i + 2], &md[i + 2..]),
        None => format!("{note}{md}"),
    }
}

/// The harmonics kept in the landmark trajectories: `--harmonics`, but none for an open cycle
/// (the frames need not cover a whole cycle then, and the filter is periodic).
fn landmark_harmonics(a: &RunArgs) -> Option<usize> {
    a.harmonics.0.filter(|_| !a.common.open)
}

/// How the landmarks were filtered and the splines regularized, for the report (empty for raw
/// landmarks and exact splines, or meshes given as input).
fn registration_clause(a: &RunArgs, from_images: bool) -> String {
    let mut parts = Vec::new();
    match landmark_harmonics(a).filter(|_| from_images) {
        Some(h) => parts.push(format!(
            "landmark trajectories low-pass filtered to the Fourier harmonics 0-{h} of the cycle"
        )),
        None if from_images && a.harmonics.0.is_some() => {
            parts.push("raw landmarks (an open cycle is not filtered)".to_string())
        }
        None => {}
    }
    if from_images && a.tps_lambda != 0.0 {
        parts.push(format!("splines regularized with lambda {}", a.tps_lambda));
    }
    parts.iter().map(|p| format!("; {p}")).collect()
}
