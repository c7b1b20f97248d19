//! `qcshape lv phantom | register | mesh`: the left-ventricle pipeline from 4D images and
//! landmarks to one deformation per subject (paper section 4.2), and the cohort classification
//! (`run`, `cycle`).

mod bars;
mod cycle;
mod mesh;
mod run;

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use indicatif::ProgressBar;
use qcshape::io;
use qcshape_studies::lv::cohort::{
    self, read_subject_landmarks, subjects, write_labels, write_subject, Registration,
};
use qcshape_studies::lv::freewall::SectorOptions;
use qcshape_studies::lv::phantom::{
    roster, subject, PhantomOptions, OVERLAP_LANDMARK_NOISE_MM, SUMMARY_HEADER,
};
use qcshape_studies::lv::region::{write_abnormal, AbnormalSector, ABNORMAL_NAME};

/// Arguments of `qcshape lv`.
#[derive(Debug, clap::Args)]
#[command(
    about = "Left-ventricle pipeline: phantom cohort, landmark registration, meshes per frame",
    long_about = "Left-ventricle pipeline (paper section 4.2). A cohort folder holds labels.csv \
(subject,label) and one folder per subject with its frames (frameNN.nii[.gz], or one 4D .nii[.gz]) \
and landmarks.csv (frame,landmark,x,y,z in world mm; landmark 0 = apex, 1 = base centre, 3 = \
septum). 'phantom' makes such a cohort, 'register' fits the frame-0 -> frame-k thin-plate splines, \
'mesh' extracts the cavity surface of frame 0 and carries it to every frame."
)]
pub struct Args {
    #[command(subcommand)]
    command: LvCommand,
}

#[derive(Debug, clap::Subcommand)]
enum LvCommand {
    /// Generate a phantom cohort of 4D CT-like volumes (controls and HCM) with landmarks.
    Phantom(PhantomArgs),
    /// Fit landmark thin-plate splines from frame 0 to every frame (writes tps_nNN.json).
    Register(RegisterArgs),
    /// Extract the frame-0 cavity surface and carry it to every frame; write a manifest.
    Mesh(mesh::Args),
    /// Classify a cohort's wall motion (Tables 4 and 5, Fig. 9), from images or meshes.
    Run(run::RunArgs),
    /// MDS map of one heart cycle with interpolated poses (Fig. 9) from mesh files.
    Cycle(cycle::CycleArgs),
}

#[derive(Debug, clap::Args)]
struct PhantomArgs {
    /// Output folder (created).
    #[arg(long)]
    out: PathBuf,
    /// Number of control subjects.
    /// At most 10,000.
    #[arg(long, default_value_t = 14, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_SUBJECTS as u64), allow_negative_numbers = true)]
    controls: usize,
    /// Number of HCM subjects.
    /// At most 10,000.
    #[arg(long, default_value_t = 9, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_SUBJECTS as u64), allow_negative_numbers = true)]
    hcm: usize,
    /// Frames per cycle (end-systole near frame 3/8, end-diastole near 7/8 of the cycle).
    /// At most 10,000.
    #[arg(long, default_value_t = 8, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_POSES as u64), allow_negative_numbers = true)]
    frames: usize,
    /// Voxels per side of the cubic volume (field of view 104 x 104 x 130 mm).
    /// At most 1,024.
    #[arg(long, default_value_t = 48, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_IMAGE_SIZE as u64), allow_negative_numbers = true)]
    size: usize,
    /// Standard deviation of the Gaussian image noise (HU).
    #[arg(long, default_value_t = 25.0, allow_negative_numbers = true)]
    noise: f64,
    /// Seed of every random choice.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Write one 4D image.nii.gz per subject instead of one file per frame.
    #[arg(long = "4d")]
    four_d: bool,
    /// The harder cohort: overlapping parameter ranges between controls and HCM, a random
    /// rigid pose per subject (long axis tilted up to 25 degrees, any spin, centre moved up to
    /// 5 mm) and landmark noise (sources in the library's lv::phantom docs).
    #[arg(long)]
    overlap: bool,
    /// Standard deviation (mm) of the Gaussian noise on every landmark coordinate of every
    /// frame (default: 1 with --overlap, else 0).
    #[arg(long, allow_negative_numbers = true)]
    landmark_noise: Option<f64>,
}

#[derive(Debug, clap::Args)]
struct RegisterArgs {
    /// Cohort folder.
    dir: PathBuf,
    /// Number of landmarks used (the first N of each frame; the paper uses 16, Table 5 8-32).
    /// At most 10,000.
    #[arg(long, default_value_t = 16, value_parser = crate::bounds::count::<usize>(0, qcshape::limits::MAX_LANDMARKS as u64), allow_negative_numbers = true)]
    landmarks: usize,
    /// Thin-plate-spline regularization (0: exact at the landmarks).
    /// At most 1e6.
    #[arg(long, default_value_t = 0.0, value_parser = crate::bounds::real(qcshape::limits::MAX_LAMBDA), allow_negative_numbers = true)]
    lambda: f64,
}

/// Runs the command.
pub fn run(args: &Args) -> Result<()> {
    match &args.command {
        LvCommand::Phantom(a) => phantom(a),
        LvCommand::Register(a) => register(a),
        LvCommand::Mesh(a) => mesh::run(a),
        LvCommand::Run(a) => run::run(a),
        LvCommand::Cycle(a) => cycle::cycle(a),
    }
}

/// The part of each subject's surface that `lv mesh` writes and `lv run` analyses (`--region`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum Region {
    /// The free-wall sector (the paper's; `lv mesh` takes its sector options).
    FreeWall,
    /// Every angle from the apex to height 0.9, without the valve-plane cap (a disk).
    Wall,
    /// The whole closed cavity surface.
    Whole,
}

impl Region {
    /// The sector cut out: [`SectorOptions::wall`] for the wall, `free_wall` otherwise
    /// (unused for the whole surface).
    pub(crate) fn sector(self, free_wall: SectorOptions) -> SectorOptions {
        match self {
            Region::Wall => SectorOptions::wall(),
            Region::FreeWall | Region::Whole => free_wall,
        }
    }

    /// Whether a sector is cut out of the closed surface (all but the whole surface).
    pub(crate) fn cuts(self) -> bool {
        self != Region::Whole
    }

    /// The command-line name.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Region::FreeWall => "free-wall",
            Region::Wall => "wall",
            Region::Whole => "whole",
        }
    }
}

/// `--refine MM|none`: the image refinement's search reach along the normals (mm), or none
/// (the landmark splines alone).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Refine(pub(crate) Option<f64>);

impl std::str::FromStr for Refine {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "none" => Ok(Refine(None)),
            mm => match mm.parse::<f64>() {
                Ok(r) if r.is_finite() && r > 0.0 => Ok(Refine(Some(r))),
                _ => Err(format!("expected a search reach in mm (> 0) or none, got {mm:?}")),
            },
        }
    }
}

impl std::fmt::Display for Refine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.0 {
            Some(r) => write!(f, "{r}"),
            None => f.write_str("none"),
        }
    }
}

/// A plain progress bar of `n` subjects.
pub(crate) fn progress(n: usize) -> ProgressBar {
    let pb = crate::progress::new_bar(n);
    crate::progress::start(&pb);
    pb
}

fn phantom(a: &PhantomArgs) -> Result<()> {
    if a.size < 16 || a.size > 512 {
        bail!("--size {} must be between 16 and 512", a.size);
    }
    if a.frames < 4 {
        bail!("--frames {} must be at least 4", a.frames);
    }
    if a.controls + a.hcm == 0 {
        bail!("the cohort is empty: give --controls and/or --hcm");
    }
    if !(a.noise.is_finite() && a.noise >= 0.0) {
        bail!("--noise {} must be a non-negative number", a.noise);
    }
    std::fs::create_dir_all(&a.out).with_context(|| format!("cannot create {}", a.out.display()))?;
    let opts = PhantomOptions {
        size: a.size,
        frames: a.frames,
        noise_hu: a.noise,
        seed: a.seed,
        overlap: a.overlap,
        landmark_noise_mm: a.landmark_noise.unwrap_or(if a.overlap {
            OVERLAP_LANDMARK_NOISE_MM
        } else {
            0.0
        }),
    };
    if !(opts.landmark_noise_mm.is_finite() && opts.landmark_noise_mm >= 0.0) {
        bail!(
            "--landmark-noise {} must be a non-negative number",
            opts.landmark_noise_mm
        );
    }
    let names = roster(a.controls, a.hcm, a.seed);
    let bar = progress(names.len());
    let mut summary = format!("{SUMMARY_HEADER}\n");
    let mut sectors = Vec::with_capacity(names.len());
    for (i, (name, group)) in names.iter().enumerate() {
        let t0 = Instant::now();
        let s = subject(name, *group, i as u64, &opts);
        write_subject(&a.out, &s, a.four_d)?;
        sectors.push(AbnormalSector::of(&s));
        summary.push_str(&s.summary_row(t0.elapsed().as_secs_f64()));
        summary.push('\n');
        bar.inc(1);
    }
    bar.finish_and_clear();
    let labels: Vec<(String, Option<String>)> = names
        .iter()
        .map(|(n, g)| (n.clone(), Some(g.label().to_string())))
        .collect();
    write_labels(&a.out.join(cohort::LABELS_NAME), &labels)?;
    io::write_atomically(&a.out.join("phantom.csv"), |w| w.write_all(summary.as_bytes()))?;
    write_abnormal(&a.out.join(ABNORMAL_NAME), &sectors)?;
    outln!(
        "wrote {} subjects ({} control, {} hcm{}), {} frames of {}^3 voxels, to {}",
        names.len(),
        a.controls,
        a.hcm,
        if a.overlap {
            ", overlapping ranges, random poses"
        } else {
            ""
        },
        a.frames,
        a.size,
        a.out.display()
    );
    Ok(())
}

fn register(a: &RegisterArgs) -> Result<()> {
    let subs = subjects(&a.dir)?;
    let bar = progress(subs.len());
    for s in &subs {
        let (lm, path) = read_subject_landmarks(&s.path)?;
        let reg = Registration::fit(&lm, a.landmarks, a.lambda, &path)?;
        let out = s.path.join(Registration::file_name(a.landmarks));
        reg.write(&out)?;
        // Largest landmark residual over frames (0 up to rounding when lambda = 0).
        let worst = reg.max_landmark_residual(&lm).context("landmark subset")?;
        bar.suspend(|| -> anyhow::Result<()> {
            outln!(
                "{}: {} frames, {} landmarks, max landmark residual {} mm -> {}",
                s.name,
                reg.maps.len(),
                a.landmarks,
                qcshape::numfmt::significant(worst, 4),
                out.display()
            );
            Ok(())
        })?;
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok(())
}
