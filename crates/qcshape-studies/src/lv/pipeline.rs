//! `qcshape lv run` as one library call: the input (a cohort folder meshed from images, a data
//! set of meshes, or one sequence), the main analysis beside the baselines and the other
//! clustering methods (Table 4), Fig. 9, the landmark sweep (Table 5) and OUT/report.md,
//! written after the main run and after every landmark count so an interrupted run leaves
//! what is done. Progress and the lines worth printing reach the caller as [`Event`]s.
//!
//! [`load_input`] decides what the input is; [`run_cohort`] runs the study on a cohort. A
//! single sequence is only mapped ([`Input::Cycle`], [`super::cycle_map::study_cycle`]).

use std::path::{Path, PathBuf};
use std::time::Instant;

use super::analysis::Axis;
use super::cohort_mesh::{is_cohort, mesh_cohort, write_meshes, MeshSettings};
use super::cycle_map::{cycle_map, CycleSettings};
use super::region::{cohort_region, write_region, REGION_NAME};
use super::study::{
    analyse, baselines, coarsen, compare_methods, labels_of, BinaryScores, SplitOptions, StudyError, Tick,
};
use super::study_report::{run_report, RunSummary};
use qcshape::align::Alignment;
use qcshape::cluster::ClusterMethod;
use qcshape::dataset::{load_sequence, mesh_files, Dataset, DatasetError, Deformation};
use qcshape::similarity::PipelineOptions;

/// What the study reports while it runs (called from worker threads).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Event<'a> {
    /// One more item of a stage is done (progress bars).
    Tick(Tick<'a>),
    /// A line for the user (a stage's result, a note on the input).
    Line(&'a str),
}

/// The callback receiving [`Event`]s.
pub type Events<'a> = &'a (dyn Fn(Event<'_>) + Sync);

/// The settings of one `lv run`.
#[derive(Debug, Clone)]
pub struct RunSettings {
    /// Cohort folder, manifest CSV, folder of deformation folders, or folder of one sequence.
    pub dir: PathBuf,
    /// Output folder (created).
    pub out: PathBuf,
    /// Registration landmarks of the main run (the first N of each frame; paper: 16).
    pub landmarks: usize,
    /// Landmark counts of Table 5 (the whole pipeline once per count); `None` skips Table 5.
    pub landmark_sweep: Option<Vec<usize>>,
    /// How the surfaces are made (its `harmonics` already `None` for an open cycle).
    pub mesh: MeshSettings,
    /// Whether landmark harmonics were asked for (the report says an open cycle is not
    /// filtered).
    pub harmonics_asked: bool,
    /// Metric, solver, insertion, vertex budget and openness of the cycle.
    pub cycle: CycleSettings,
    /// The similarity pipeline (transport, alignment, insertion).
    pub pipeline: PipelineOptions,
    /// The two-cluster split.
    pub split: SplitOptions,
    /// Clustering methods also reported.
    pub compare: Vec<ClusterMethod>,
    /// The subject of Fig. 9 (default: the first).
    pub mds_subject: Option<String>,
    /// The region's name for the report (`free-wall`, `wall`, `whole`).
    pub region: String,
    /// With a folder of mesh files: only files whose name contains this text.
    pub pattern: Option<String>,
    /// The command line, as typed (for the report).
    pub args_line: String,
    /// When the run started (the report's total time).
    pub started: Instant,
}

/// A cohort on one connectivity, ready for [`run_cohort`].
#[derive(Debug, Clone)]
pub struct CohortInput {
    /// One deformation per subject (frames #V x 3, mm).
    pub defs: Vec<Deformation>,
    /// Each subject's long axis.
    pub axes: Vec<Axis>,
    /// Seconds of registration and meshing per subject.
    pub mesh_seconds: Vec<f64>,
    /// A sentence on where the meshes came from.
    pub input_note: String,
    /// Whether the cohort was meshed from images here (then Table 5 can run).
    pub from_images: bool,
    /// The phantom's abnormal region on the template (per vertex), when known.
    pub abnormal: Option<Vec<bool>>,
}

/// What [`load_input`] found.
#[derive(Debug, Clone)]
pub enum Input {
    /// Several subjects: the study.
    Cohort(CohortInput),
    /// One sequence: its cycle map only (`source` names the input for the report).
    Cycle {
        /// The sequence.
        def: Deformation,
        /// Where it came from.
        source: String,
    },
}

/// The mesh files of `dir` whose names contain `pattern`, in natural name order.
pub fn pattern_files(dir: &Path, pattern: Option<&str>) -> Result<Vec<PathBuf>, DatasetError> {
    Ok(mesh_files(dir)?
        .into_iter()
        .filter(|f| pattern.is_none_or(|p| f.file_name().is_some_and(|n| n.to_string_lossy().contains(p))))
        .collect())
}

/// Reads (or meshes, for a cohort folder: OUT/meshes and the phantom's abnormal region are
/// written) the input of `s`. Creates `s.out`.
pub fn load_input(s: &RunSettings, events: Events<'_>) -> Result<Input, StudyError> {
    let line = |l: &str| events(Event::Line(l));
    let progress = |t: Tick<'_>| events(Event::Tick(t));
    if s.mesh.tps_lambda != 0.0 && !is_cohort(&s.dir) {
        return Err(StudyError::TpsLambdaOnMeshes(s.dir.clone()));
    }
    std::fs::create_dir_all(&s.out).map_err(|source| StudyError::CreateDir {
        path: s.out.clone(),
        source,
    })?;
    if is_cohort(&s.dir) {
        let t0 = Instant::now();
        let c = mesh_cohort(&s.dir, s.landmarks, &s.mesh, &progress)?;
        write_meshes(&s.out.join("meshes"), &c.defs)?;
        // A phantom cohort knows its abnormal region: write it on the template.
        let mut abnormal = None;
        if let Some(w) = cohort_region(&s.dir, &c.defs[0].name, &c.defs[0].poses[0])? {
            let file = s.out.join("meshes").join(REGION_NAME);
            write_region(&file, &w)?;
            abnormal = Some(w.iter().map(|&x| x >= 0.5).collect::<Vec<bool>>());
            line(&format!(
                "abnormal region of the phantom: {} of {} vertices -> {}",
                w.iter().filter(|&&x| x >= 0.5).count(),
                w.len(),
                file.display()
            ));
        }
        line(&format!(
            "meshed {} subjects ({} vertices each, {} of {} projected on their own surface) in {:.1} s",
            c.defs.len(),
            c.defs[0].topology.n_vertices(),
            c.snapped,
            c.defs.len() - 1,
            t0.elapsed().as_secs_f64()
        ));
        let frames: usize = c.defs.iter().map(|d| d.poses.len()).sum();
        let refined = match s.mesh.refine {
            Some(reach) => format!(
                " Every frame's mesh was then refined on its own image (vertices moved along \
                 their normals to the cavity threshold, searched within {reach} mm): {} of {frames} \
                 frames, root mean square move {:.2} mm.",
                c.refined.0, c.refined.1
            ),
            None => String::new(),
        };
        if !refined.is_empty() {
            line(refined.trim());
        }
        let input_note = format!(
            "cohort `{}`: template = frame 0 of `{}` ({} vertices on the whole surface, {} in the {}), \
             carried to the other subjects by the landmark spline between frame-0 landmarks and projected \
             on each subject's own frame-0 surface ({} of {} projected; the rest kept the spline result, \
             which would otherwise fold a triangle).{} Meshes in `meshes/manifest.csv`.",
            s.dir.display(),
            c.defs[0].name,
            c.whole_vertices,
            c.defs[0].topology.n_vertices(),
            if s.mesh.free_wall {
                "free wall"
            } else {
                "whole surface"
            },
            c.snapped,
            c.defs.len() - 1,
            refined
        );
        return Ok(Input::Cohort(CohortInput {
            defs: c.defs,
            axes: c.axes,
            mesh_seconds: c.seconds,
            input_note,
            from_images: true,
            abnormal,
        }));
    }
    if s.dir.is_dir() {
        let files = pattern_files(&s.dir, s.pattern.as_deref())?;
        if !files.is_empty() {
            let def = load_sequence(&files)?;
            line(&format!(
                "{}: one sequence of {} frames: cycle map only",
                s.dir.display(),
                files.len()
            ));
            let source = format!("{} files from {}", files.len(), s.dir.display());
            return Ok(Input::Cycle { def, source });
        }
    }
    let t0 = Instant::now();
    let mut data = Dataset::load(&s.dir)?;
    if data.deformations.len() == 1 {
        let def = data.deformations.pop().expect("one");
        return Ok(Input::Cycle {
            def,
            source: s.dir.display().to_string(),
        });
    }
    let note = coarsen(&mut data.deformations, s.cycle.vertices)?;
    let axes = data
        .deformations
        .iter()
        .map(|d| {
            Axis::fit(&d.poses[0]).map_err(|error| StudyError::Deformation {
                name: d.name.clone(),
                error,
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let n = data.deformations.len();
    let per = t0.elapsed().as_secs_f64() / n as f64;
    let input_note = format!(
        "meshes from `{}` (no images: registration and meshing skipped, long axes fitted to \
         frame 0{}).",
        s.dir.display(),
        note.map_or(String::new(), |n| format!("; {n}"))
    );
    Ok(Input::Cohort(CohortInput {
        defs: data.deformations,
        axes,
        mesh_seconds: vec![per; n],
        input_note,
        from_images: false,
        abnormal: None,
    }))
}

/// Runs the study on a cohort and writes OUT/similarity.csv, the Fig. 9 files, the report's
/// CSVs and figures and OUT/report.md (after the main run and after every landmark count of
/// Table 5, marked partial until the last). Returns the report's path.
pub fn run_cohort(s: &RunSettings, input: &CohortInput, events: Events<'_>) -> Result<PathBuf, StudyError> {
    let line = |l: &str| events(Event::Line(l));
    let progress = |t: Tick<'_>| events(Event::Tick(t));
    let CohortInput { defs, axes, .. } = input;
    let (opts, split, open) = (&s.pipeline, &s.split, s.cycle.open);
    let frames = defs[0].poses.len();

    let main = analyse(defs, opts, open, split, &progress)?;
    line(&format!(
        "{} landmarks: our method sensitivity {:.1} %, specificity {:.1} % ({:.1} s)",
        s.landmarks,
        100.0 * main.scores.sensitivity,
        100.0 * main.scores.specificity,
        main.wall.iter().sum::<f64>()
    ));
    line(&main.shares.line());
    if let Some(w) = main.shares.warning(opts.metric.kind.label()) {
        line(&format!("warning: {w}"));
    }
    let base = baselines(defs, axes, open, split)?;
    for b in &base.rows {
        line(&format!(
            "{}: sensitivity {:.1} %, specificity {:.1} %",
            b.name,
            100.0 * b.scores.sensitivity,
            100.0 * b.scores.specificity
        ));
    }
    main.matrix.write_csv(&s.out.join("similarity.csv"))?;
    let methods = compare_methods(&main, opts, &base, &labels_of(defs)?, &s.compare, split)?;
    for m in &methods {
        line(&format!(
            "{} / {}: sensitivity {:.1} %, specificity {:.1} %, ARI {:.3}",
            m.data,
            m.method,
            100.0 * m.scores.sensitivity,
            100.0 * m.scores.specificity,
            m.scores.ari
        ));
    }

    // Fig. 9.
    let idx = match &s.mds_subject {
        Some(name) => defs
            .iter()
            .position(|d| &d.name == name)
            .ok_or_else(|| StudyError::UnknownSubject(name.clone()))?,
        None => 0,
    };
    let map = cycle_map(
        &main.prepared.interpolated[idx],
        &main.prepared.is_key,
        opts.insert + 1,
        &main.prepared.topology,
        main.prepared.factor,
        &s.cycle,
        split.seed,
        &progress,
    )?;
    map.write_files(
        &s.out,
        &format!("{}: {} frames + interpolated poses", defs[idx].name, frames),
    )?;

    let path = s.out.join("report.md");
    let write_report =
        |sweep: &[(usize, BinaryScores, f64)], partial: Option<String>| -> Result<(), StudyError> {
            let summary = RunSummary {
                args_line: s.args_line.clone(),
                input_note: input.input_note.clone(),
                landmarks: s.landmarks,
                from_images: input.from_images,
                region: s.region.clone(),
                frames,
                restarts: split.restarts,
                seed: split.seed,
                mesh_seconds: input.mesh_seconds.clone(),
                ed_es: base.ed_es.clone(),
                total_seconds: s.started.elapsed().as_secs_f64(),
                mds_subject: defs[idx].name.clone(),
                split: split.sentence(),
                align: match opts.align {
                    Alignment::None => String::new(),
                    m => format!(
                    "{} alignment of every subject to the base (area-weighted Procrustes of its frame 0, the \
                     same motion on all its frames), ",
                    m.label()
                ),
                },
                registration: registration_clause(s, input.from_images),
                transport: opts.transport.label().to_string(),
                abnormal: input.abnormal.clone(),
            };
            let mut md = run_report(
                &s.out, &summary, &s.cycle, defs, &main, &base.rows, sweep, &map, &methods,
            )?;
            if let Some(after) = partial {
                md = mark_partial(&md, &after);
            }
            qcshape::io::write_atomically(&path, |w| w.write_all(md.as_bytes()))?;
            Ok(())
        };

    // Table 5.
    let mut sweep = Vec::new();
    if let Some(counts) = s.landmark_sweep.as_ref().filter(|_| input.from_images) {
        write_report(&sweep, Some("Table 4 and Fig. 9".into()))?;
        for &n in counts {
            if n == s.landmarks {
                sweep.push((n, main.scores.clone(), 0.0));
                continue;
            }
            let t0 = Instant::now();
            let c = mesh_cohort(&s.dir, n, &s.mesh, &progress)?;
            let r = analyse(&c.defs, opts, open, split, &progress)?;
            let secs = t0.elapsed().as_secs_f64();
            line(&format!(
                "{n} landmarks: sensitivity {:.1} %, specificity {:.1} % ({secs:.1} s)",
                100.0 * r.scores.sensitivity,
                100.0 * r.scores.specificity
            ));
            sweep.push((n, r.scores, secs));
            write_report(
                &sweep,
                Some(format!(
                    "Table 5, {} of {} landmark counts",
                    sweep.len(),
                    counts.len()
                )),
            )?;
        }
    }
    write_report(&sweep, None)?;
    Ok(path)
}

/// `md` with the line "Partial report: still running (written after `after`)" under its title.
pub fn mark_partial(md: &str, after: &str) -> String {
    let note = format!(
        "**Partial report: still running (written after {after}).** The final report replaces this file.\n\n"
    );
    match md.find("\n\n") {
        Some(i) => format!("{}{note}{}", &md[..i + 2], &md[i + 2..]),
        None => format!("{note}{md}"),
    }
}

/// How the landmarks were filtered and the splines regularized, for the report (empty for raw
/// landmarks and exact splines, or meshes given as input).
fn registration_clause(s: &RunSettings, from_images: bool) -> String {
    let mut parts = Vec::new();
    match s.mesh.harmonics.filter(|_| from_images) {
        Some(h) => parts.push(format!(
            "landmark trajectories low-pass filtered to the Fourier harmonics 0-{h} of the cycle"
        )),
        None if from_images && s.harmonics_asked => {
            parts.push("raw landmarks (an open cycle is not filtered)".to_string())
        }
        None => {}
    }
    if from_images && s.mesh.tps_lambda != 0.0 {
        parts.push(format!("splines regularized with lambda {}", s.mesh.tps_lambda));
    }
    parts.iter().map(|p| format!("; {p}")).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_partial_report_says_so_under_its_title() {
        let md = mark_partial("# Title\n\nBody\n", "Table 4");
        assert!(md.starts_with("# Title\n\n**Partial report: still running (written after Table 4).**"));
        assert!(md.ends_with("Body\n"));
        assert!(mark_partial("one line", "x").starts_with("**Partial"));
    }

    #[test]
    fn pattern_files_filters_by_name() {
        let dir = std::env::temp_dir().join(format!("qcshape-pattern-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for n in ["a_LV.ply", "b_RV.ply", "c_LV.ply"] {
            std::fs::write(dir.join(n), "").unwrap();
        }
        let got = pattern_files(&dir, Some("LV")).unwrap();
        let names: Vec<_> = got
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, ["a_LV.ply", "c_LV.ply"]);
        assert_eq!(pattern_files(&dir, None).unwrap().len(), 3);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
