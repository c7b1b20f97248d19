//! A cohort's deformations on one connectivity (section 4.2 steps 1-3 for a whole cohort):
//! register every subject (landmark splines frame 0 -> frame k), mesh the first subject's
//! frame 0 (the template), carry the template to every subject's frame 0 (landmark spline
//! between the subjects, projected on the subject's own surface) and then to every frame.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use super::analysis::{carry_template, Axis};
use super::cohort::{
    image_files, read_frame0, read_frames, read_subject_landmarks, subjects, LvError, Registration,
    SubjectDir, LABELS_NAME, LANDMARKS_NAME,
};
use super::freewall::{free_wall, LvAxis, SectorOptions};
use super::landmarks::{Landmarks, APEX, BASE_CENTRE, SEPTUM};
use super::meshing::{extract_surface, Surface, SurfaceOptions};
use super::refine::{refine_to_image, RefineOptions};
use super::study::{Progress, StudyError, Tick};
use qcshape::dataset::{write_manifest, Deformation, ManifestRow, MANIFEST_NAME};
use qcshape::mesh::Topology;

/// How the surfaces are made.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshSettings {
    /// Cavity threshold in image units (None: upper two-level Otsu threshold per subject).
    pub threshold: Option<f64>,
    /// Taubin smoothing iterations.
    pub smooth: usize,
    /// Vertex target of the template's whole surface (0: no decimation).
    pub vertices: usize,
    /// Keep the submesh of `sector` only (the free wall, or the wall without the valve plane).
    pub free_wall: bool,
    /// The sector kept with `free_wall` ([`SectorOptions::default`]: the paper's free wall;
    /// [`SectorOptions::wall`]: the whole wall).
    pub sector: SectorOptions,
    /// Regularization of the frame-0 -> frame-k landmark splines ([`super::tps::Tps::fit`];
    /// normalized units, 0: exact at the landmarks, the paper's).
    pub tps_lambda: f64,
    /// Low-pass filter of every landmark's trajectory over the cycle before registration
    /// ([`Landmarks::low_pass`]): the Fourier harmonics kept, `None` for the raw landmarks.
    pub harmonics: Option<usize>,
    /// Image refinement of every carried frame ([`super::refine::refine_to_image`]): the
    /// search reach along the normals (mm), `None` for the landmark splines alone (the
    /// paper's step 3).
    pub refine: Option<f64>,
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
    /// Frames refined on their image (of all subjects' frames), and the root mean square
    /// normal offset of those (mm).
    pub refined: (usize, f64),
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
    lm.get(0, id).ok_or_else(|| StudyError::MissingLandmark {
        path: path.to_path_buf(),
        id,
    })
}

fn subset(lm: &Landmarks, n: usize, path: &Path) -> Result<Landmarks, StudyError> {
    lm.first(n).ok_or_else(|| StudyError::TooFewLandmarks {
        path: path.to_path_buf(),
        found: lm.ids.len(),
        asked: n,
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
        return Err(StudyError::TooFewSubjects(dir.to_path_buf()));
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
    let filtered = |lm: Landmarks| match s.harmonics {
        Some(h) => lm.low_pass(h),
        None => lm,
    };
    let (lm0, lm0_path) = read_subject_landmarks(&subs[0].path)?;
    let lm0 = subset(&filtered(lm0), n, &lm0_path)?;
    let whole_topo = template.shape.topology.clone();
    let (topo, keep): (Arc<Topology>, Option<Vec<u32>>) = if s.free_wall {
        let axis = LvAxis::new(
            landmark(&lm0, APEX, &lm0_path)?,
            landmark(&lm0, BASE_CENTRE, &lm0_path)?,
            landmark(&lm0, SEPTUM, &lm0_path)?,
        )
        .map_err(|error| LvError::FreeWall {
            path: subs[0].path.clone(),
            error,
        })?;
        let sub = free_wall(&whole_topo, &template.shape.positions, &axis, &s.sector).map_err(|error| {
            LvError::FreeWall {
                path: subs[0].path.clone(),
                error,
            }
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
        refined: (0, 0.0),
    };
    let mut sum_sq = 0.0;
    for (i, sub) in subs.iter().enumerate() {
        let t = Instant::now();
        let (lm, lm_path) = read_subject_landmarks(&sub.path)?;
        let lm = filtered(lm);
        let reg = Registration::fit(&lm, n, s.tps_lambda, &lm_path)?;
        let first = subset(&lm, n, &lm_path)?;
        if first.ids != lm0.ids {
            return Err(StudyError::LandmarkIds {
                path: lm_path,
                ids: first.ids,
                first: subs[0].name.clone(),
                first_ids: lm0.ids.clone(),
            });
        }
        let (frame0, threshold) = if i == 0 {
            (template.shape.positions.clone(), template.threshold)
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
            (p, own.threshold)
        };
        let mut carried = reg.carry(&frame0);
        if let Some(reach) = s.refine {
            let (n, sq) = refine_frames(&sub.path, &whole_topo, &mut carried, threshold, reach)?;
            out.refined.0 += n;
            sum_sq += sq;
        }
        let poses: Vec<Vec<[f64; 3]>> = carried
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
            .map_err(|error| StudyError::Subject {
                subject: sub.name.clone(),
                error,
            })?,
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
    if out.refined.0 > 0 {
        out.refined.1 = (sum_sq / out.refined.0 as f64).sqrt();
    }
    Ok(out)
}

/// Refines every carried frame of a subject (`poses`, one #V x 3 pose per frame on the
/// closed surface `topo`) on that frame's image at the subject's cavity `threshold`
/// ([`refine_to_image`], search `reach` mm). Returns the frames refined and the sum of their
/// squared root mean square offsets (mm²).
fn refine_frames(
    subject: &Path,
    topo: &Topology,
    poses: &mut [Vec<[f64; 3]>],
    threshold: f64,
    reach: f64,
) -> Result<(usize, f64), StudyError> {
    let images = read_frames(subject)?;
    if images.len() != poses.len() {
        return Err(StudyError::FrameCounts {
            path: subject.to_path_buf(),
            images: images.len(),
            landmarks: poses.len(),
        });
    }
    let opts = RefineOptions::within(reach);
    let (mut n, mut sum_sq) = (0, 0.0);
    for (p, vol) in poses.iter_mut().zip(&images) {
        let (q, r) = refine_to_image(topo, p, vol, threshold, &opts);
        if r.rounds > 0 {
            n += 1;
            sum_sq += r.rms_offset * r.rms_offset;
        }
        *p = q;
    }
    Ok((n, sum_sq))
}

/// Writes `OUT/<subject>/poseNN.ply` and `OUT/manifest.csv` (a data set for `lv run` or
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
            let name = format!("pose{k:03}.ply");
            qcshape::io::write_mesh(&dir.join(&name), p, d.topology.faces(), &Default::default())?;
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

/// How one subject is meshed on its own (`qcshape lv mesh`).
#[derive(Debug, Clone)]
pub struct SubjectMeshOptions {
    /// Surface extraction of frame 0.
    pub surface: SurfaceOptions,
    /// Free-wall sector (used with `free_wall`).
    pub sector: SectorOptions,
    /// Landmarks of the registration (the first N of each frame).
    pub landmarks: usize,
    /// Thin-plate-spline regularization when the registration is fitted here.
    pub lambda: f64,
    /// Keep the free-wall submesh only.
    pub free_wall: bool,
    /// Image refinement of every carried frame: the search reach along the normals (mm),
    /// `None` for the landmark splines alone ([`MeshSettings::refine`]).
    pub refine: Option<f64>,
}

/// One subject's frame-0 surface carried to every frame.
#[derive(Debug, Clone)]
pub struct MeshedSubject {
    /// One pose per frame (#V x 3, world mm).
    pub poses: Vec<Vec<[f64; 3]>>,
    /// The faces (#F x 3) shared by the poses.
    pub faces: Vec<[u32; 3]>,
    /// The cavity threshold used (image units).
    pub threshold: f64,
    /// Vertices of the raw isosurface.
    pub raw_vertices: usize,
    /// Vertices of the decimated whole surface.
    pub surface_vertices: usize,
    /// Landmarks of the registration.
    pub landmarks: usize,
    /// Whether the registration was read from the subject's saved `tps_nNN.json`.
    pub saved_maps: bool,
    /// Frames refined on their image (0 without `refine`).
    pub refined: usize,
}

/// The subject's saved registration with `n` landmarks (`tps_nNN.json`), else one fitted here;
/// the flag says which.
pub fn registration_for(s: &SubjectDir, n: usize, lambda: f64) -> Result<(Registration, bool), LvError> {
    let saved = s.path.join(Registration::file_name(n));
    if saved.is_file() {
        let r = Registration::read(&saved)?;
        if r.landmarks == n {
            return Ok((r, true));
        }
    }
    let (lm, path) = read_subject_landmarks(&s.path)?;
    Ok((Registration::fit(&lm, n, lambda, &path)?, false))
}

/// Extracts the subject's frame-0 cavity surface and carries it to every frame through its
/// landmark splines (section 4.2 steps 2-3), keeping the free wall if asked.
pub fn mesh_subject(s: &SubjectDir, o: &SubjectMeshOptions) -> Result<MeshedSubject, StudyError> {
    let (vol, file) = read_frame0(&s.path)?;
    let surface =
        extract_surface(&vol, &o.surface).map_err(|error| LvError::Surface { path: file, error })?;
    let (reg, saved_maps) = registration_for(s, o.landmarks, o.lambda)?;
    let (lm, lm_path) = read_subject_landmarks(&s.path)?;
    if lm.n_frames() != reg.maps.len() {
        return Err(StudyError::RegistrationCount {
            path: lm_path,
            frames: lm.n_frames(),
            maps: reg.maps.len(),
        });
    }
    let mut poses = reg.carry(&surface.shape.positions);
    let mut refined = 0;
    if let Some(reach) = o.refine {
        let topo = &surface.shape.topology;
        refined = refine_frames(&s.path, topo, &mut poses, surface.threshold, reach)?.0;
    }
    let mut faces = surface.shape.topology.faces().to_vec();
    if o.free_wall {
        let freewall = |error| LvError::FreeWall {
            path: s.path.clone(),
            error,
        };
        let axis = LvAxis::new(
            landmark(&lm, APEX, &lm_path)?,
            landmark(&lm, BASE_CENTRE, &lm_path)?,
            landmark(&lm, SEPTUM, &lm_path)?,
        )
        .map_err(freewall)?;
        let sub = free_wall(
            &surface.shape.topology,
            &surface.shape.positions,
            &axis,
            &o.sector,
        )
        .map_err(freewall)?;
        poses = poses.iter().map(|p| sub.restrict(p)).collect();
        faces = sub.topology.faces().to_vec();
    }
    Ok(MeshedSubject {
        poses,
        faces,
        threshold: surface.threshold,
        raw_vertices: surface.raw_vertices,
        surface_vertices: surface.shape.n_vertices(),
        landmarks: reg.landmarks,
        saved_maps,
        refined,
    })
}

/// Every frame's own cavity surface, each extracted from that frame's image as frame 0's is
/// ([`extract_surface`]: iso-surface, largest component, smoothing, decimation, relaxation), so
/// every frame has its own triangulation and no vertex corresponds between frames: the data a
/// per-frame segmentation gives (to be put on one connectivity by [`qcshape::fit`]). No
/// landmarks are used. Without a threshold in `o`, frame 0's upper Otsu threshold is used for
/// every frame of the subject (the level [`refine_to_image`] moves carried frames to).
pub fn mesh_frames(s: &SubjectDir, o: &SurfaceOptions) -> Result<Vec<Surface>, StudyError> {
    let files = image_files(&s.path)?;
    let frames = read_frames(&s.path)?;
    let mut opts = o.clone();
    let mut out: Vec<Surface> = Vec::with_capacity(frames.len());
    for (k, vol) in frames.iter().enumerate() {
        let file = files[k.min(files.len() - 1)].clone();
        let surface = extract_surface(vol, &opts).map_err(|error| LvError::Surface { path: file, error })?;
        opts.threshold = Some(surface.threshold);
        out.push(surface);
    }
    Ok(out)
}
