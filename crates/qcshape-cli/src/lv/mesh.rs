//! `qcshape lv mesh`: the frame-0 cavity surface carried to every frame, one deformation per
//! subject, and a manifest.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use qcshape::dataset::{write_manifest, ManifestRow, MANIFEST_NAME};
use qcshape::io;
use qcshape_studies::lv::cohort::{read_subject_landmarks, subjects, SubjectDir};
use qcshape_studies::lv::cohort_mesh::{mesh_frames, mesh_subject, SubjectMeshOptions};
use qcshape_studies::lv::freewall::LvAxis;
use qcshape_studies::lv::freewall::SectorOptions;
use qcshape_studies::lv::landmarks::{APEX, BASE_CENTRE, SEPTUM};
use qcshape_studies::lv::meshing::SurfaceOptions;

use super::progress;
use crate::mesh_format::MeshFormat;

#[derive(Debug, clap::Args)]
pub(crate) struct Args {
    /// Cohort folder.
    dir: PathBuf,
    /// Output folder: OUT/<subject>/poseNN.ply and OUT/manifest.csv.
    #[arg(long)]
    out: PathBuf,
    /// Cavity threshold (image units); default: upper two-level Otsu threshold of frame 0.
    #[arg(long, allow_negative_numbers = true)]
    threshold: Option<f64>,
    /// Target vertex count of the whole surface after decimation (0: no decimation).
    /// At most 100,000,000.
    #[arg(long, default_value_t = 1000, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_VERTICES as u64), allow_negative_numbers = true)]
    vertices: usize,
    /// Taubin smoothing iterations before decimation.
    /// At most 1,000.
    #[arg(long, default_value_t = 10, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_SWEEPS as u64), allow_negative_numbers = true)]
    smooth: usize,
    /// Tangential relaxation sweeps after decimation (more regular triangles).
    /// At most 1,000.
    #[arg(long, default_value_t = 5, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_SWEEPS as u64), allow_negative_numbers = true)]
    relax: usize,
    /// Number of landmarks for the registration (uses DIR/<subject>/tps_nNN.json if present).
    /// At most 10,000.
    #[arg(long, default_value_t = 16, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_LANDMARKS as u64), allow_negative_numbers = true)]
    landmarks: usize,
    /// Thin-plate-spline regularization when fitting here.
    /// At most 1e6.
    #[arg(long, default_value_t = 0.0, value_parser = crate::bounds::real(qcshape::limits::MAX_LAMBDA), allow_negative_numbers = true)]
    lambda: f64,
    /// Region written: the free-wall submesh (the sector below), the wall (every angle from the
    /// apex to height 0.9, no valve-plane cap; the sector options are ignored) or the whole
    /// closed surface.
    #[arg(long, value_enum, default_value = "free-wall")]
    region: super::Region,
    /// Image refinement of every carried frame: each vertex moves along its normal to the
    /// cavity threshold of that frame's own image, searched within MM mm; `none` keeps the
    /// landmark splines alone (the paper's step 3).
    #[arg(long, value_name = "MM|none", default_value_t = super::Refine(qcshape_studies::study_defaults::LV_REFINE_MM))]
    refine: super::Refine,
    /// Free-wall sector centre, degrees from the septum landmark about the long axis.
    #[arg(long, default_value_t = 180.0, allow_negative_numbers = true)]
    sector_centre: f64,
    /// Free-wall sector width (degrees).
    #[arg(long, default_value_t = 180.0, allow_negative_numbers = true)]
    sector_width: f64,
    /// Free-wall height band LO,HI (0 apex, 1 base centre).
    #[arg(
        long,
        default_value = "0.15,0.9",
        value_delimiter = ',',
        num_args = 2,
        allow_negative_numbers = true
    )]
    heights: Vec<f64>,
    /// Mesh format of the written poses.
    #[arg(long, value_enum, default_value_t = MeshFormat::Ply)]
    format: MeshFormat,
    /// Extract every frame's own cavity surface from its own image, as frame 0's (frame 0's
    /// threshold for every frame): each pose gets its own triangulation, no landmarks are used
    /// (the data of per-frame segmentations; `qcshape fit` puts them on one connectivity).
    /// Needs --region whole; --refine and the registration options are unused.
    #[arg(long)]
    per_frame: bool,
    /// Write every pose in its subject's frame-0 landmark frame (origin the apex, z towards the
    /// base centre, x towards the septum, mm) instead of the image's world frame: poses of
    /// different subjects are then placed anatomically alike, which a fit without landmarks
    /// needs to match them (the phantom's subjects are turned at random about the long axis).
    #[arg(long)]
    landmark_frame: bool,
}

/// The map from world mm to the subject's frame-0 landmark frame (`--landmark-frame`).
fn landmark_frame(s: &SubjectDir) -> Result<impl Fn(&[[f64; 3]]) -> Vec<[f64; 3]>> {
    let (lm, path) = read_subject_landmarks(&s.path)?;
    let get = |id| {
        lm.get(0, id)
            .with_context(|| format!("{}: landmark {id} is missing in frame 0", path.display()))
    };
    let axis = LvAxis::new(get(APEX)?, get(BASE_CENTRE)?, get(SEPTUM)?)
        .with_context(|| format!("{}: frame-0 landmarks", path.display()))?;
    let (x, z) = (axis.reference, axis.axis);
    let y = [
        z[1] * x[2] - z[2] * x[1],
        z[2] * x[0] - z[0] * x[2],
        z[0] * x[1] - z[1] * x[0],
    ];
    Ok(move |p: &[[f64; 3]]| {
        p.iter()
            .map(|q| {
                let d = [q[0] - axis.apex[0], q[1] - axis.apex[1], q[2] - axis.apex[2]];
                [x, y, z].map(|e| e[0] * d[0] + e[1] * d[1] + e[2] * d[2])
            })
            .collect()
    })
}

/// Runs `qcshape lv mesh`.
pub(crate) fn run(a: &Args) -> Result<()> {
    if a.heights.len() != 2 {
        bail!("--heights takes two numbers LO,HI");
    }
    crate::input::refuse_out_folder(&[&a.dir], &a.out, "--out")?;
    let subs = subjects(&a.dir)?;
    std::fs::create_dir_all(&a.out).with_context(|| format!("cannot create {}", a.out.display()))?;
    let opts = SurfaceOptions {
        threshold: a.threshold,
        smoothing_iterations: a.smooth,
        target_vertices: (a.vertices > 0).then_some(a.vertices),
        relax_iterations: a.relax,
    };
    let sector = a.region.sector(SectorOptions {
        centre_deg: a.sector_centre,
        width_deg: a.sector_width,
        heights: (a.heights[0], a.heights[1]),
    });
    let mopts = SubjectMeshOptions {
        surface: opts,
        sector,
        landmarks: a.landmarks,
        lambda: a.lambda,
        free_wall: a.region.cuts(),
        refine: a.refine.0,
    };
    if a.per_frame {
        if a.region.cuts() {
            bail!("--per-frame needs --region whole (a sector cut per frame would not match)");
        }
        return per_frame(a, &subs, &mopts.surface);
    }
    let mut rows = Vec::new();
    let bar = progress(subs.len());
    for s in &subs {
        let t0 = Instant::now();
        let mut m = mesh_subject(s, &mopts)?;
        if a.landmark_frame {
            let to = landmark_frame(s)?;
            m.poses = m.poses.iter().map(|p| to(p)).collect();
        }
        let (poses, faces) = (&m.poses, &m.faces);
        write_poses(a, s, poses.iter().map(|p| (&p[..], &faces[..])), &mut rows)?;
        bar.suspend(|| -> anyhow::Result<()> {
            outln!(
                "{}: threshold {:.1}, surface {} -> {} vertices, {} written ({}), {} poses ({} refined on their images), {} landmarks{}, {:.2} s",
                s.name,
                m.threshold,
                m.raw_vertices,
                m.surface_vertices,
                poses[0].len(),
                a.region.name(),
                poses.len(),
                m.refined,
                m.landmarks,
                if m.saved_maps { " (saved maps)" } else { "" },
                t0.elapsed().as_secs_f64()
            );
            Ok(())
        })?;
        bar.inc(1);
    }
    bar.finish_and_clear();
    write_manifest(&a.out.join(MANIFEST_NAME), &rows)?;
    outln!(
        "wrote {} deformations to {}",
        subs.len(),
        a.out.join(MANIFEST_NAME).display()
    );
    Ok(())
}

/// Writes a subject's poses (positions #V x 3 and faces, in frame order) as
/// `OUT/SUBJECT/poseKKK.EXT` and appends their manifest rows.
fn write_poses<'p>(
    a: &Args,
    s: &SubjectDir,
    poses: impl Iterator<Item = (&'p [[f64; 3]], &'p [[u32; 3]])>,
    rows: &mut Vec<ManifestRow>,
) -> Result<()> {
    let dir = a.out.join(&s.name);
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    for (k, (positions, faces)) in poses.enumerate() {
        let name = format!("pose{k:03}.{}", a.format.extension());
        io::write_mesh(&dir.join(&name), positions, faces, &Default::default())?;
        rows.push(ManifestRow {
            deformation: s.name.clone(),
            label: s.label.clone(),
            pose: k as i64,
            path: Path::new(&s.name).join(name),
        });
    }
    Ok(())
}

/// `--per-frame`: every frame's own surface, written with its own faces.
fn per_frame(a: &Args, subs: &[SubjectDir], opts: &SurfaceOptions) -> Result<()> {
    let mut rows = Vec::new();
    let bar = progress(subs.len());
    for s in subs {
        let t0 = Instant::now();
        let mut surfaces = mesh_frames(s, opts)?;
        if a.landmark_frame {
            let to = landmark_frame(s)?;
            for m in &mut surfaces {
                m.shape.positions = to(&m.shape.positions);
            }
        }
        let poses = surfaces
            .iter()
            .map(|m| (&m.shape.positions[..], m.shape.topology.faces()));
        write_poses(a, s, poses, &mut rows)?;
        let counts: Vec<String> = surfaces
            .iter()
            .map(|m| m.shape.n_vertices().to_string())
            .collect();
        bar.suspend(|| -> anyhow::Result<()> {
            outln!(
                "{}: threshold {:.1}, {} frames meshed on their own images ({} vertices), {:.2} s",
                s.name,
                surfaces[0].threshold,
                surfaces.len(),
                counts.join(" "),
                t0.elapsed().as_secs_f64()
            );
            Ok(())
        })?;
        bar.inc(1);
    }
    bar.finish_and_clear();
    write_manifest(&a.out.join(MANIFEST_NAME), &rows)?;
    outln!(
        "wrote {} deformations, every frame on its own triangulation, to {}",
        subs.len(),
        a.out.join(MANIFEST_NAME).display()
    );
    Ok(())
}
