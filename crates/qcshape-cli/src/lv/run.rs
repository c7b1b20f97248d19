//! `qcshape lv run`: the left-ventricle analysis of section 4.3 from one command (Tables 4
//! and 5, Fig. 9). The study is [`qcshape_studies::lv::pipeline`]; this module parses the arguments,
//! shows its progress and prints its lines.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{bail, Result};
use qcshape::align::Alignment;
use qcshape::cluster::ClusterMethod;
use qcshape::similarity::PipelineOptions;
use qcshape::transport::Transport;
use qcshape_studies::lv::cohort_mesh::MeshSettings;
use qcshape_studies::lv::freewall::SectorOptions;
use qcshape_studies::lv::pipeline::{load_input, run_cohort, Event, Input, RunSettings};
use qcshape_studies::lv::study::SplitOptions;

use super::bars::Bars;
use super::cycle::{args_line, cycle_settings, run_cycle, CycleCommon};
use crate::args::in_pool;

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
    /// applied with --open. The default was chosen on five harder phantom cohorts
    /// (docs/log/lv-clustering.md).
    #[arg(long, value_name = "H|none", default_value_t = Harmonics(qcshape_studies::study_defaults::LANDMARK_HARMONICS))]
    pub(crate) harmonics: Harmonics,
    /// Image refinement of every carried frame: each vertex moves along its normal to the
    /// cavity threshold of that frame's own image, searched within MM mm on both sides; `none`
    /// keeps the landmark splines alone (the paper's). Image cohorts only: meshes given as input
    /// are used as they are. The default was chosen on five harder phantom cohorts
    /// (docs/log/lv-clustering.md).
    #[arg(long, value_name = "MM|none", default_value_t = super::Refine(qcshape_studies::study_defaults::LV_REFINE_MM))]
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
    #[arg(long, help = qcshape::settings::ALIGN.help(), default_value = qcshape::settings::ALIGN.default_text(), value_parser = crate::args::choice::<qcshape::align::Alignment>())]
    pub(crate) align: Alignment,
    /// Transport of every subject's cycle to the base: parallel (the paper's section 4
    /// pipeline, the default here), schild or euclidean (the other commands' default).
    #[arg(long, default_value = qcshape_studies::study_defaults::LV_TRANSPORT.label())]
    pub(crate) transport: Transport,
    #[arg(long, help = qcshape::settings::APPROX.help(), default_value = qcshape::settings::APPROX.default_text(), value_parser = crate::args::choice::<qcshape::similarity::Approx>())]
    pub(crate) approx: qcshape::similarity::Approx,
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

/// `qcshape lv run`.
pub fn run(a: &RunArgs) -> Result<()> {
    crate::input::refuse_out_folder(&[&a.dir], &a.out, "--out")?;
    in_pool(a.common.threads, || run_in_pool(a))
}

/// Runs `lv run` inside the worker pool.
fn run_in_pool(a: &RunArgs) -> Result<()> {
    let started = Instant::now();
    if a.restarts == 0 {
        bail!("--restarts must be at least 1");
    }
    let cycle = cycle_settings(&a.common, 1)?;
    let s = RunSettings {
        dir: a.dir.clone(),
        out: a.out.clone(),
        landmarks: a.landmarks,
        landmark_sweep: (!a.no_sweep).then(|| a.landmark_sweep.clone()),
        mesh: MeshSettings {
            threshold: a.threshold,
            smooth: a.smooth,
            vertices: a.common.vertices,
            free_wall: a.region.cuts(),
            sector: a.region.sector(SectorOptions::default()),
            tps_lambda: a.tps_lambda,
            // None for an open cycle: the frames need not cover a whole cycle then, and the
            // filter is periodic.
            harmonics: a.harmonics.0.filter(|_| !a.common.open),
            refine: a.refine.0,
        },
        harmonics_asked: a.harmonics.0.is_some(),
        pipeline: PipelineOptions {
            metric: cycle.metric,
            geodesic: cycle.geodesic.clone(),
            insert: a.common.insert,
            levels: qcshape::defaults::LEVELS,
            transport: a.transport,
            base: 0,
            align: a.align,
            smoothing: PipelineOptions::default().smoothing,
            approx: a.approx,
        },
        cycle,
        split: SplitOptions {
            method: a.cluster,
            restarts: a.restarts,
            seed: a.seed,
        },
        compare: a.compare.clone(),
        mds_subject: a.mds_subject.clone(),
        region: a.region.name().to_string(),
        pattern: a.pattern.clone(),
        args_line: args_line(),
        started,
    };
    let bars = Bars::default();
    let events = |e: Event<'_>| match e {
        Event::Tick(t) => bars.tick(t),
        Event::Line(l) => eprintln!("{l}"),
    };
    let input = match load_input(&s, &events)? {
        Input::Cycle { def, source } => return run_cycle(def, &a.out, &a.common, 1, a.seed, &source),
        Input::Cohort(c) => c,
    };
    let path = run_cohort(&s, &input, &events)?;
    eprintln!(
        "wrote {} in {:.1} s",
        path.display(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}
