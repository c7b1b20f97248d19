//! A cohort's deformations on one connectivity (section 4.2 steps 1-3 for a whole cohort):
//! register every subject (landmark splines frame 0 -> frame k), mesh the first subject's
//! frame 0 (the template), carry the template to every subject's frame 0 (landmark spline
//! between the subjects, projected on the subject's own surface) and then to every frame.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use super::analysis::{carry_template, Axis};
use super::cohort::{
    read_frame0, read_subject_landmarks, subjects, LvError, Registration, LABELS_NAME, LANDMARKS_NAME,
};
use super::freewall::{free_wall, LvAxis, SectorOptions};
use super::landmarks::{Landmarks, APEX, BASE_CENTRE, SEPTUM};
use super::meshing::{extract_surface, SurfaceOptions};
use super::study::{Progress, StudyError, Tick};
use crate::dataset::{write_manifest, Deformation, ManifestRow, MANIFEST_NAME};
use crate::mesh::Topology;

/// How the surfaces are made.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshSettings {
    /// Cavity threshold in image units (None: upper two-level Otsu threshold per subject).
    pub threshold: Option<f64>,
    /// Taubin smoothing iterations.
    pub smooth: usize,
    /// Vertex target of the template's whole surface (0: no decimation).
    pub vertices: usize,
    /// Keep the free wall only.
    pub free_wall: bool,
}

/// The meshed cohort.
#[derive(Debug, Clone)]
pub struct MeshedCohort {
    /// One deformation per subject (key frames, #V x 3 each, mm), all on one topology.
    pub defs: Vec<Deformation>,
    /// Each subject's long axis (frame-0 apex and base-centre landmarks).
    pub axes: Vec<Axis>,
    /// Seconds of registration and meshing per subject.
    pub seconds: Vec<f64>,
    /// Subjects (other than the template) whose frame 0 was projected on their own surface.
    pub snapped: usize,
    /// Vertices of the template's whole surface.
    pub whole_vertices: usize,
}

/// Whether `dir` is a cohort folder (labels.csv, or sub-folders with landmarks.csv).
pub fn is_cohort(dir: &Path) -> bool {
    if !dir.is_dir() {
        return false;
    }
    if dir.join(LABELS_NAME).is_file() {
        return true;
    }
    std::fs::read_dir(dir).is_ok_and(|entries| {
        entries
            .filter_map(|e| e.ok())
            .any(|e| e.path().join(LANDMARKS_NAME).is_file())
    })
}

fn landmark(lm: &Landmarks, id: u32, path: &Path) -> Result<[f64; 3], StudyError> {
    lm.get(0, id).ok_or_else(|| {
        StudyError::Input(format!(
            "{}: landmark {id} is missing in frame 0 (needed for the long axis)",
            path.display()
        ))
    })
}

fn subset(lm: &Landmarks, n: usize, path: &Path) -> Result<Landmarks, StudyError> {
    lm.first(n).ok_or_else(|| {
        StudyError::Input(format!(
            "{}: has {} landmarks per frame, fewer than the {n} asked for",
            path.display(),
            lm.ids.len()
        ))
    })
}

/// Registers and meshes every subject of the cohort `dir` with its first `n` landmarks.
/// `progress` ticks once per subject.
pub fn mesh_cohort(
    dir: &Path,
    n: usize,
    s: &MeshSettings,
    progress: Progress<'_>,
) -> Result<MeshedCohort, StudyError> {
    let subs = subjects(dir)?;
    if subs.len() < 2 {
        return Err(StudyError::Input(format!(
            "{}: a cohort needs at least two subjects",
            dir.display()
        )));
    }
    let surface_opts = |target: Option<usize>, relax: usize| SurfaceOptions {
        threshold: s.threshold,
        smoothing_iterations: s.smooth,
        target_vertices: target,
        relax_iterations: relax,
    };
    // The template: the first subject's frame-0 surface.
    let t0 = Instant::now();
    let (vol, file) = read_frame0(&subs[0].path)?;
    let template = extract_surface(&vol, &surface_opts((s.vertices > 0).then_some(s.vertices), 5))
        .map_err(|error| LvError::Surface { path: file, error })?;
    let (lm0, lm0_path) = read_subject_landmarks(&subs[0].path)?;
    let lm0 = subset(&lm0, n, &lm0_path)?;
    let whole_topo = template.shape.topology.clone();
    let (topo, keep): (Arc<Topology>, Option<Vec<u32>>) = if s.free_wall {
        let axis = LvAxis::new(
            landmark(&lm0, APEX, &lm0_path)?,
            landmark(&lm0, BASE_CENTRE, &lm0_path)?,
            landmark(&lm0, SEPTUM, &lm0_path)?,
        )
        .map_err(|e| StudyError::Input(format!("{}: long axis: {e}", lm0_path.display())))?;
        let sub = free_wall(
            &whole_topo,
            &template.shape.positions,
            &axis,
            &SectorOptions::default(),
        )
        .map_err(|error| LvError::FreeWall {
            path: subs[0].path.clone(),
            error,
        })?;
        (sub.topology.clone(), Some(sub.vertices.clone()))
    } else {
        (whole_topo.clone(), None)
    };
    let template_seconds = t0.elapsed().as_secs_f64();

    let what = format!("meshing (n={n})");
    let mut out = MeshedCohort {
        defs: Vec::new(),
        axes: Vec::new(),
        seconds: Vec::new(),
        snapped: 0,
        whole_vertices: whole_topo.n_vertices(),
    };
    for (i, sub) in subs.iter().enumerate() {
        let t = Instant::now();
        let (lm, lm_path) = read_subject_landmarks(&sub.path)?;
        let reg = Registration::fit(&lm, n, 0.0, &lm_path)?;
        let first = subset(&lm, n, &lm_path)?;
        if first.ids != lm0.ids {
            return Err(StudyError::Input(format!(
                "{}: landmark ids {:?} differ from those of {} ({:?}): subjects cannot be matched",
                lm_path.display(),
                first.ids,
                subs[0].name,
                lm0.ids
            )));
        }
        let frame0 = if i == 0 {
            template.shape.positions.clone()
        } else {
            let (vol, file) = read_frame0(&sub.path)?;
            let own = extract_surface(&vol, &surface_opts(None, 0))
                .map_err(|error| LvError::Surface { path: file, error })?;
            let (p, snapped) = carry_template(
                &template.shape.positions,
                &whole_topo,
                &lm0.frames[0],
                &first.frames[0],
                0.0,
                Some((&own.shape.positions, own.shape.topology.faces())),
            )
            .map_err(|error| StudyError::Subject {
                subject: sub.name.clone(),
                error,
            })?;
            out.snapped += usize::from(snapped);
            p
        };
        let poses: Vec<Vec<[f64; 3]>> = reg
            .carry(&frame0)
            .into_iter()
            .map(|p| match &keep {
                Some(k) => k.iter().map(|&v| p[v as usize]).collect(),
                None => p,
            })
            .collect();
        out.axes.push(
            Axis::through(
                landmark(&lm, APEX, &lm_path)?,
                landmark(&lm, BASE_CENTRE, &lm_path)?,
            )
            .map_err(|e| StudyError::Input(format!("{}: {e}", lm_path.display())))?,
        );
        out.defs.push(Deformation {
            name: sub.name.clone(),
            label: sub.label.clone(),
            topology: topo.clone(),
            poses,
            paths: Vec::new(),
            warnings: Vec::new(),
        });
        out.seconds
            .push(t.elapsed().as_secs_f64() + if i == 0 { template_seconds } else { 0.0 });
        progress(Tick {
            what: &what,
            total: subs.len(),
        });
    }
    progress(Tick::DONE);
    Ok(out)
}

/// Writes OUT/<subject>/poseNN.ply and OUT/manifest.csv (a data set for `lv run` or
/// `similarity`); returns the manifest's path.
pub fn write_meshes(out: &Path, defs: &[Deformation]) -> Result<PathBuf, StudyError> {
    let mut rows = Vec::new();
    for d in defs {
        let dir = out.join(&d.name);
        std::fs::create_dir_all(&dir).map_err(|source| StudyError::CreateDir {
            path: dir.clone(),
            source,
        })?;
        for (k, p) in d.poses.iter().enumerate() {
            let name = format!("pose{k:02}.ply");
            crate::io::write_mesh(&dir.join(&name), p, d.topology.faces(), &Default::default())?;
            rows.push(ManifestRow {
                deformation: d.name.clone(),
                label: d.label.clone(),
                pose: k as i64,
                path: Path::new(&d.name).join(name),
            });
        }
    }
    let path = out.join(MANIFEST_NAME);
    write_manifest(&path, &rows)?;
    Ok(path)
}
