//! `qcshape lv run` and `qcshape lv cycle`: the left-ventricle analysis of section 4.3 from
//! one command (Tables 4 and 5, Fig. 9). The analysis is in the library
//! ([`qcshape::lv::study`], [`qcshape::lv::cycle_map`], [`qcshape::lv::study_report`]); this
//! module parses the arguments, `lv/run/cohort.rs` runs a cohort, `lv/run/progress.rs` shows
//! the library's progress.

mod cohort;
mod progress;

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use qcshape::align::Alignment;
use qcshape::cluster::ClusterMethod;
use qcshape::dataset::{load_sequence, mesh_files, Deformation};
use qcshape::geodesic::GeodesicOptions;
use qcshape::lv::cycle_map::{cycle_title, study_cycle, CycleSettings};
use qcshape::lv::study_report::cycle_report;
use qcshape::transport::Transport;

use crate::args::{in_pool, MetricArgs};
use progress::Bars;

/// Options of `qcshape lv run`.
#[derive(Debug, clap::Args)]
#[command(
    about = "Classify left-ventricle motion (Tables 4 and 5, Fig. 9) from images or meshes",
    long_about = "Section 4.3 in one command. DIR is a cohort folder (labels.csv and per-subject images \
and landmarks.csv, as made by 'qcshape lv phantom'), a manifest CSV or folder of deformations already \
meshed on one connectivity, or a folder of one subject's mesh files (then only the cycle map, as \
'qcshape lv cycle').\n\nFor a cohort: per subject, the landmark trajectories low-pass filtered over the \
cycle (--harmonics), landmark thin-plate splines frame 0 -> frame k (--landmarks, --tps-lambda); the first subject's frame-0 cavity surface (decimated to --vertices) is the template, \
carried to every other subject's frame 0 by the landmark spline between the subjects and projected on \
that subject's own surface, then to every frame through the subject's splines (one connectivity for \
the cohort); --region keeps the free wall, the wall without the valve plane or the whole surface. The cycle is closed (frame 0 is \
appended, so the gap last -> first is interpolated too: F (1 + --insert) poses, 8 x 4 = 32 as in the \
paper); interpolation, parallel transport to the first subject's frame 0, similarity (eq. 13), \
a 2-cluster split (--cluster); sensitivity (hcm) and specificity (controls) after Hungarian matching, beside two \
baselines on the same meshes (mean systolic radial displacement, mean radial velocity) clustered the \
same way; Table 5 reruns everything for each --landmark-sweep count; Fig. 9 is the MDS of one subject's \
interpolated cycle. Writes OUT/report.md, CSVs, the similarity matrix, meshes and figures."
)]
pub struct RunArgs {
    /// Cohort folder, manifest CSV, folder of deformation folders, or folder of one sequence's meshes.
    pub(crate) dir: PathBuf,
    /// Output folder (created).
    #[arg(long)]
    pub(crate) out: PathBuf,
    /// Landmarks of the registrations (the first N of each frame; paper: 16).
    /// At most 10,000.
    #[arg(long, default_value_t = 16, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_LANDMARKS as u64), allow_negative_numbers = true)]
    pub(crate) landmarks: usize,
    #[command(flatten)]
    pub(crate) common: CycleCommon,
    /// Region analysed: the free wall (paper; a 180-degree sector, heights 0.15-0.9), the wall
    /// (every angle from the apex to height 0.9: no valve-plane cap) or the whole closed cavity
    /// surface.
    #[arg(long, value_enum, default_value = "free-wall")]
    pub(crate) region: super::Region,
    /// Landmark counts of Table 5 (the whole pipeline once per count).
    /// At most 10,000.
    #[arg(long, value_delimiter = ',', default_value = "8,16,24,32", value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_LANDMARKS as u64), allow_negative_numbers = true)]
    pub(crate) landmark_sweep: Vec<usize>,
    /// Skip Table 5.
    #[arg(long)]
    pub(crate) no_sweep: bool,
    /// Cavity threshold (default: upper two-level Otsu threshold of each frame 0).
    #[arg(long, allow_negative_numbers = true)]
    pub(crate) threshold: Option<f64>,
    /// Taubin smoothing iterations of the surfaces.
    /// At most 1,000.
    #[arg(long, default_value_t = 10, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_SWEEPS as u64), allow_negative_numbers = true)]
    pub(crate) smooth: usize,
    /// Regularization of the frame-0 -> frame-k landmark thin-plate splines (normalized units;
    /// 0: exact at the landmarks, the paper's).
    /// At most 1e6.
    #[arg(long, default_value_t = 0.0, value_parser = crate::bounds::real(qcshape::limits::MAX_LAMBDA), allow_negative_numbers = true)]
    pub(crate) tps_lambda: f64,
    /// Low-pass filter of the landmark trajectories before registration: keep the Fourier
    /// harmonics 0..H of the cycle (the frames must cover one whole cycle), which removes
    /// frame-to-frame landmark jitter; `none` registers the raw landmarks (the paper's). Not
    /// applied with --open. The default was chosen on five harder phantom cohorts (README,
    /// "Left ventricle").
    #[arg(long, value_name = "H|none", default_value_t = Harmonics(qcshape::defaults::LANDMARK_HARMONICS))]
    pub(crate) harmonics: Harmonics,
    /// Image refinement of every carried frame: each vertex moves along its normal to the
    /// cavity threshold of that frame's own image, searched within MM mm on both sides; `none`
    /// keeps the landmark splines alone (the paper's). Image cohorts only: meshes given as input
    /// are used as they are. The default was chosen on five harder phantom cohorts (README,
    /// "Left ventricle").
    #[arg(long, value_name = "MM|none", default_value_t = super::Refine(qcshape::defaults::LV_REFINE_MM))]
    pub(crate) refine: super::Refine,
    /// Name of the subject whose cycle is mapped in Fig. 9 (default: the first).
    #[arg(long)]
    pub(crate) mds_subject: Option<String>,
    /// How the subjects are split in two: kmeans (kernel k-means on squared similarities),
    /// kmedoids, spectral[:SCALE] (Gaussian affinity, bandwidth SCALE x the median distance),
    /// mds-kmeans[:DIMS] (k-means in the leading DIMS classical-MDS coordinates), intrinsic
    /// (eq. 14 with Karcher means, slow).
    #[arg(long, default_value = "kmeans")]
    pub(crate) cluster: ClusterMethod,
    /// Clustering methods also reported, on the similarity and the baselines (comma-separated).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "kmeans,kmedoids,spectral,mds-kmeans:2,mds-kmeans:3"
    )]
    pub(crate) compare: Vec<ClusterMethod>,
    /// Placement of every subject on the base before transfer: rigid (area-weighted
    /// Procrustes of its frame 0 onto the base's, the same motion on every frame), similarity
    /// (also a uniform scale) or none (the paper's pipeline).
    #[arg(long, default_value = qcshape::defaults::ALIGN.label())]
    pub(crate) align: Alignment,
    /// Transport of every subject's cycle to the base: parallel (the paper's section 4
    /// pipeline, the default here), schild or euclidean (the other commands' default).
    #[arg(long, default_value = qcshape::defaults::LV_TRANSPORT.label())]
    pub(crate) transport: Transport,
    /// Clustering restarts.
    /// At most 10,000.
    #[arg(long, default_value_t = qcshape::defaults::RESTARTS, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_RESTARTS as u64), allow_negative_numbers = true)]
    pub(crate) restarts: usize,
    /// Seed of the clustering and MDS.
    #[arg(long, default_value_t = 0)]
    pub(crate) seed: u64,
    /// With a folder of mesh files: only files whose name contains this text (e.g. LV_ENDO).
    #[arg(long)]
    pub(crate) pattern: Option<String>,
}

/// `--harmonics`: the Fourier harmonics of the cycle kept in the landmark trajectories, or
/// `none` (raw landmarks).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Harmonics(pub(crate) Option<usize>);

impl std::str::FromStr for Harmonics {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "none" => Ok(Harmonics(None)),
            n => n
                .parse::<usize>()
                .map(|h| Harmonics(Some(h)))
                .map_err(|_| format!("expected a number of harmonics (0, 1, 2, ...) or none, got {n:?}")),
        }
    }
}

impl std::fmt::Display for Harmonics {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.0 {
            Some(h) => write!(f, "{h}"),
            None => f.write_str("none"),
        }
    }
}

/// Options shared by `lv run` and `lv cycle`.
#[derive(Debug, Clone, clap::Args)]
pub struct CycleCommon {
    #[command(flatten)]
    pub metric: MetricArgs,
    /// Poses inserted between consecutive frames (default 3, the paper's section 4 setting, not
    /// the other commands' 0).
    /// At most 1,000.
    #[arg(long, default_value_t = qcshape::defaults::PAPER_INSERT, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_INSERT as u64), allow_negative_numbers = true)]
    pub insert: usize,
    /// Segments N of every geodesic (default 4, the setting the README's LV tables were measured
    /// with, not the other commands' 8).
    /// At most 10,000.
    #[arg(long, default_value_t = qcshape::defaults::PAPER_STEPS, value_parser = crate::bounds::count::<usize>(1, qcshape::limits::MAX_STEPS as u64), allow_negative_numbers = true)]
    pub steps: usize,
    /// Vertex budget: the cohort template's whole surface, or meshes given as input are coarsened
    /// (a vertex subset, multires hierarchy) when larger.
    /// At most 100,000,000.
    #[arg(long, default_value_t = 600, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_VERTICES as u64), allow_negative_numbers = true)]
    pub vertices: usize,
    /// Do not close the cycle (no gap last frame -> frame 0).
    #[arg(long)]
    pub open: bool,
    /// Worker threads (default: all cores).
    /// At most 1,024.
    #[arg(long, value_parser = crate::bounds::count::<usize>(1, qcshape::limits::MAX_THREADS as u64), allow_negative_numbers = true)]
    pub threads: Option<usize>,
}

/// Options of `qcshape lv cycle`.
#[derive(Debug, clap::Args)]
#[command(
    about = "MDS path of one heart cycle with interpolated poses (Fig. 9) from mesh files",
    long_about = "Fig. 9 for one sequence of meshes with one connectivity (e.g. a fitted real cycle): \
the frames in natural name order (FILES: mesh files, or one folder filtered by --pattern), every \
--every-th frame kept, coarsened to about --vertices vertices (a subset of the vertices, so every frame \
keeps its correspondence), the cycle closed unless --open, --insert poses interpolated between \
consecutive frames, the geodesic distance dis(P_i, P_j) of every pair of poses (one solver) and its \
2-D SMACOF map: frames as filled dots, interpolated poses in a second colour. Writes OUT/report.md, \
OUT/fig9_mds.svg|png, OUT/fig9_mds.csv, OUT/fig9_distances.csv."
)]
pub struct CycleArgs {
    /// Mesh files in cycle order, or one folder of them.
    #[arg(required = true)]
    files: Vec<PathBuf>,
    /// Output folder (created).
    #[arg(long)]
    out: PathBuf,
    /// With a folder: only files whose name contains this text (e.g. LV_ENDO).
    #[arg(long)]
    pattern: Option<String>,
    /// Keep every K-th frame (1: all).
    /// At most 10,000.
    #[arg(long, default_value_t = 1, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_EVERY as u64), allow_negative_numbers = true)]
    every: usize,
    #[command(flatten)]
    common: CycleCommon,
    /// Seed of the MDS.
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

/// The library's cycle settings of the command line.
fn cycle_settings(c: &CycleCommon, frame_stride: usize) -> Result<CycleSettings> {
    if c.steps == 0 {
        bail!("--steps must be at least 1");
    }
    Ok(CycleSettings {
        metric: c.metric.spec()?,
        geodesic: GeodesicOptions {
            steps: c.steps,
            ..Default::default()
        },
        insert: c.insert,
        vertices: c.vertices,
        open: c.open,
        frame_stride,
    })
}

/// The command line, as typed (for reports).
fn args_line() -> String {
    std::env::args().collect::<Vec<_>>().join(" ")
}

/// Interpolates one sequence and maps it (the single-subject path of `lv run`, and `lv cycle`).
fn run_cycle(
    def: Deformation,
    out: &Path,
    common: &CycleCommon,
    frame_stride: usize,
    seed: u64,
    source: &str,
) -> Result<()> {
    let t_all = Instant::now();
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let settings = cycle_settings(common, frame_stride)?;
    let nv = def.topology.n_vertices();
    eprintln!(
        "{}: {} frames of {nv} vertices{}",
        def.name,
        def.poses.len(),
        if common.vertices > 0 && nv > common.vertices {
            format!(
                "; coarsened to about {} vertices first (--vertices; 0 keeps every vertex)",
                common.vertices
            )
        } else {
            String::new()
        }
    );
    let bars = Bars::default();
    let c = study_cycle(def, &settings, seed, &|t| bars.tick(t)).with_context(|| source.to_string())?;
    c.map.write_files(out, &cycle_title(&c.name, c.frames))?;
    eprintln!(
        "{}: {} frames -> {} poses, {} vertices; interpolation {:.1} s, {} pose pairs {:.1} s",
        c.name,
        c.frames,
        c.map.n_poses,
        c.vertices,
        c.interpolation_seconds,
        c.map.n_poses * (c.map.n_poses - 1) / 2,
        c.map.seconds
    );
    let md = cycle_report(&args_line(), source, &c, &settings, t_all.elapsed().as_secs_f64())?;
    let path = out.join("report.md");
    qcshape::io::write_atomically(&path, |w| w.write_all(md.as_bytes()))?;
    eprintln!(
        "wrote {} in {:.1} s",
        path.display(),
        t_all.elapsed().as_secs_f64()
    );
    Ok(())
}

/// The mesh files of `dir` whose names contain `pattern`.
fn pattern_files(dir: &Path, pattern: Option<&str>) -> Result<Vec<PathBuf>> {
    let files: Vec<PathBuf> = mesh_files(dir)?
        .into_iter()
        .filter(|f| pattern.is_none_or(|p| f.file_name().is_some_and(|n| n.to_string_lossy().contains(p))))
        .collect();
    Ok(files)
}

/// `qcshape lv cycle`.
pub fn cycle(a: &CycleArgs) -> Result<()> {
    if a.every == 0 {
        bail!("--every must be at least 1");
    }
    in_pool(a.common.threads, || {
        let files = match a.files.as_slice() {
            [dir] if dir.is_dir() => {
                let f = pattern_files(dir, a.pattern.as_deref())?;
                if f.is_empty() {
                    bail!(
                        "{}: no mesh files{}",
                        dir.display(),
                        a.pattern
                            .as_ref()
                            .map_or(String::new(), |p| format!(" containing {p:?}"))
                    );
                }
                f
            }
            files => files.to_vec(),
        };
        let given: Vec<&Path> = a.files.iter().chain(&files).map(PathBuf::as_path).collect();
        crate::input::refuse_out_folder(&given, &a.out, "--out")?;
        let files: Vec<PathBuf> = files.into_iter().step_by(a.every).collect();
        let def = load_sequence(&files)?;
        let source = format!(
            "{} files from {}{}",
            files.len(),
            files[0].parent().unwrap_or(Path::new(".")).display(),
            if a.every > 1 {
                format!(
                    ", one frame in {} (frames 0, {}, {}, ...)",
                    a.every,
                    a.every,
                    2 * a.every
                )
            } else {
                String::new()
            }
        );
        run_cycle(def, &a.out, &a.common, a.every, a.seed, &source)
    })
}

/// `qcshape lv run`.
pub fn run(a: &RunArgs) -> Result<()> {
    crate::input::refuse_out_folder(&[&a.dir], &a.out, "--out")?;
    in_pool(a.common.threads, || cohort::run(a))
}
