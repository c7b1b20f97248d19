//! A phantom cohort of 4D cardiac CT-like volumes: controls and hypertrophic cardiomyopathy
//! (HCM), with landmarks, so that the left-ventricle pipeline runs exactly as on real data
//! (section 4; no patient CT is available here).
//!
//! # Anatomy and image
//! The LV is a truncated prolate ellipsoidal shell ([`super::anatomy`]): an endocardial
//! ellipsoid (semi-axes `A, A, C`, cut by the base plane at `beta C` above its centre), an
//! epicardial ellipsoid with the same centre and a valve-plane cap closing the cavity. The
//! image is CT-like in Hounsfield units: lung-like background −750 HU, myocardium 60 HU,
//! contrast-filled blood 400 HU, a partial-volume edge of ~0.35 voxel and Gaussian noise
//! (default σ = 25 HU). The field of view is 104 x 104 x 130 mm on a cube of `size` voxels, so
//! voxel sizes keep the paper's 0.5 : 0.5 : 0.625 ratio (2.17 x 2.17 x 2.71 mm at 48³). The
//! voxel-to-world affine flips x and y (DICOM LPS stored as NIfTI RAS), so the pipeline's
//! orientation handling is exercised.
//!
//! # Motion over one cycle
//! A contraction curve `c(t)` (0 at end-diastole, 1 at end-systole) with end-systole near
//! frame 3 and end-diastole near frame 7 of 8 (the paper: "time points 7 and 3 correspond to
//! the end of diastole and end of systole", 1-based there; here frames are 0-based and the
//! subject's phase varies by ±0.3 frame). Systole is a half cosine; diastole a faster early
//! filling (`w^0.6`) for controls and a delayed one (`w^1.3`) in HCM, whose impaired
//! relaxation is a hallmark (Elliott et al., 2014 ESC Guidelines on HCM, Eur Heart J
//! 35:2733–2779). Endocardial radii shrink by the circumferential strain `eps_c c(t)`, the
//! cavity length by the longitudinal strain `eps_l c(t)` (apex fixed, base descending), the
//! wall thickens by conservation of myocardial volume, and the ventricle twists: the apex
//! rotates counter-clockwise and the base clockwise (seen from the apex) in proportion to
//! `c(t)`.
//!
//! # Published figures the parameters follow
//! - **Size.** Control ED cavity diameter 44–52 mm, cavity length 70–78 mm (EDV ≈ 85–130
//!   mL); normal LV diastolic diameter 42–58 mm and EDV 62–150 mL in men (Lang et al., ASE/EACVI
//!   chamber quantification, J Am Soc Echocardiogr 2015;28:1–39). HCM cavity smaller
//!   (diameter 38–44 mm).
//! - **Wall thickness.** Controls 8–10 mm; HCM ≥ 15 mm (the ESC 2014 diagnostic criterion of
//!   maximal wall thickness ≥ 15 mm): here 16–22 mm over a free-wall sector of 100–140°
//!   (the paper's patients have their abnormality on the free wall), 9–11 mm elsewhere.
//! - **Ejection fraction.** Normal LVEF 52–72% (Lang et al. 2015); controls here ≈ 55–65%.
//!   HCM: preserved or hyperdynamic EF despite reduced strain (Elliott et al. 2014; Serri et
//!   al., J Am Coll Cardiol 2006;47:1175–1181); here ≈ 55–68%, with the remote walls
//!   hyperkinetic.
//! - **Longitudinal strain.** Normal GLS ≈ −20% (Yingchoncharoen et al., meta-analysis, J Am
//!   Soc Echocardiogr 2013;26:185–191: −19.7%); controls −18 to −22%. Reduced in HCM, about
//!   −11 to −15% (Serri et al. 2006).
//! - **Circumferential (endocardial) strain.** Controls −27 to −33% (with the above it gives
//!   the EF range); HCM free wall reduced to 45–65% of the remote value and regionally uneven
//!   (a smooth random factor of ±50% over the sector), remote walls −36 to −42%.
//! - **Twist.** Peak LV twist 10–16° (apex +7..+11°, base −3..−5°; Sengupta et al., "Twist
//!   mechanics of the left ventricle", JACC Cardiovasc Imaging 2008;1:366–376; Notomi et al.,
//!   J Am Coll Cardiol 2005;45:2034–2041). HCM: similar peak twist, delayed untwisting.
//!
//! # The overlapping cohort (`overlap`)
//! The default cohort separates the groups on every parameter; real cohorts do not. With
//! `PhantomOptions::overlap` the ranges overlap as they do in published series and the pose is
//! random; `qcshape lv phantom --overlap` also makes the landmarks noisy
//! (`PhantomOptions::landmark_noise_mm`):
//! - **Wall thickness.** Controls 8–12 mm (12 mm is the upper limit of normal in Lang et al.
//!   2015); HCM free wall 11–20 mm: mild phenotypes and genotype-positive relatives have
//!   12–14 mm walls (the ESC 2014 guideline, Elliott et al., accepts ≥ 13 mm in first-degree
//!   relatives), and the free wall is not always the thickest segment (asymmetric septal
//!   hypertrophy is the commonest form), so HCM free walls of 11–12 mm overlap the upper
//!   normal range; elsewhere 9–12 mm in HCM.
//! - **Longitudinal strain.** Controls −15 to −22% (the normal range of Yingchoncharoen et
//!   al. 2013 reaches −15.9%); HCM −11 to −18% (Serri et al. 2006: −11 ± 3%, with preserved
//!   strain in mild hypertrophy).
//! - **Circumferential strain.** Controls −25 to −35%; HCM remote walls −28 to −40%, free wall
//!   55–95% of it (mild HCM has near-normal regional function).
//! - **Ejection fraction** (from the strains): controls ≈ 50–68%, HCM ≈ 52–72% (normal LVEF
//!   52–72%, Lang et al. 2015; HCM preserved or hyperdynamic, Elliott et al. 2014).
//! - **Twist.** Apex +6..+12° in controls, +6..+14° in HCM, base −2..−6° in both (peak twist
//!   10–16° normal, Sengupta et al. 2008; normal or increased in HCM, Notomi et al. 2005).
//! - **Size and filling.** Cavity diameter 42–52 mm (controls) and 38–48 mm (HCM), length
//!   66–78 and 62–74 mm; filling exponent 0.5–1.0 and 0.8–1.4 (impaired relaxation is common
//!   in older controls too).
//! - **Pose.** Long axis tilted by up to 25° (any direction) besides the random spin about it,
//!   centre moved by up to ±5 mm in x and y and 12–20 mm in z: a random rigid pose per
//!   subject, kept inside the field of view.
//! - **Landmark (surface) noise.** Gaussian noise of σ = 1 mm on every landmark coordinate of
//!   every frame (about half a voxel; manual landmark placement on CT varies by a few mm), so
//!   every frame's mesh, carried from frame 0 by the landmark splines, is perturbed by a smooth
//!   random field, and so are the long axes of the baselines.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::anatomy::{self, LvModel};
use super::landmarks::Landmarks;
use qcshape::io::nifti::Volume;

/// The subject's class.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Group {
    /// Healthy control.
    Control,
    /// Hypertrophic cardiomyopathy with free-wall involvement.
    Hcm,
}

impl Group {
    /// `"control"` or `"hcm"` (the labels file's values).
    pub fn label(self) -> &'static str {
        match self {
            Group::Control => "control",
            Group::Hcm => "hcm",
        }
    }
}

/// Cohort options.
#[derive(Debug, Clone, PartialEq)]
pub struct PhantomOptions {
    /// Voxels per side (cube), >= 16.
    pub size: usize,
    /// Frames per cycle, >= 4 (8 in the paper).
    pub frames: usize,
    /// Standard deviation of the Gaussian image noise (HU).
    pub noise_hu: f64,
    /// Seed of every random choice.
    pub seed: u64,
    /// The harder cohort: overlapping parameter ranges and a random pose (module docs, "The
    /// overlapping cohort").
    pub overlap: bool,
    /// Standard deviation (mm) of the Gaussian noise on every landmark coordinate of every
    /// frame (0: exact landmarks; the overlapping cohort uses
    /// [`OVERLAP_LANDMARK_NOISE_MM`]).
    pub landmark_noise_mm: f64,
}

impl Default for PhantomOptions {
    fn default() -> Self {
        PhantomOptions {
            size: 48,
            frames: 8,
            noise_hu: 25.0,
            seed: 1,
            overlap: false,
            landmark_noise_mm: 0.0,
        }
    }
}

/// Standard deviation (mm) of the landmark noise of the overlapping cohort.
pub const OVERLAP_LANDMARK_NOISE_MM: f64 = 1.0;

/// One generated subject.
#[derive(Debug, Clone)]
pub struct PhantomSubject {
    /// Name (`subject01`, ...).
    pub name: String,
    /// Its class.
    pub group: Group,
    /// The model behind it (geometry, motion, pose).
    pub model: LvModel,
    /// The frames (each `size³` voxels, HU).
    pub frames: Vec<Volume>,
    /// 32 landmarks per frame (world mm).
    pub landmarks: Landmarks,
    /// Noise-free cavity volume per frame (mL), from the partial-volume fractions.
    pub cavity_ml: Vec<f64>,
}

/// The header of the cohort's `phantom.csv` (one [`PhantomSubject::summary_row`] per
/// subject).
pub const SUMMARY_HEADER: &str =
    "subject,label,edv_ml,esv_ml,ef,wall_mm,free_wall_mm,long_strain,circ_strain,free_wall_motion,twist_deg,seconds";

impl PhantomSubject {
    /// The subject's row of `phantom.csv` (volumes in mL, walls in mm, strains as fractions,
    /// twist in degrees; `seconds` its generation time), without a line end.
    pub fn summary_row(&self, seconds: f64) -> String {
        let m = &self.model;
        let max = self.cavity_ml.iter().copied().fold(f64::MIN, f64::max);
        let min = self.cavity_ml.iter().copied().fold(f64::MAX, f64::min);
        format!(
            "{},{},{max:.1},{min:.1},{:.3},{:.1},{:.1},{:.3},{:.3},{:.2},{:.1},{seconds:.2}",
            self.name,
            self.group.label(),
            self.ejection_fraction(),
            m.wall,
            m.free_wall,
            m.long_strain,
            m.circ_strain,
            m.free_wall_motion,
            m.twist_apex_deg - m.twist_base_deg,
        )
    }

    /// Ejection fraction `(max - min) / max` of the cavity volumes over the frames.
    pub fn ejection_fraction(&self) -> f64 {
        let max = self.cavity_ml.iter().copied().fold(f64::MIN, f64::max);
        let min = self.cavity_ml.iter().copied().fold(f64::MAX, f64::min);
        (max - min) / max
    }
}

fn uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.random::<f64>()
}

/// Draws a subject's model (see the module docs for the ranges and their sources).
pub fn sample_model(group: Group, frames: usize, rng: &mut ChaCha8Rng) -> LvModel {
    let hcm = group == Group::Hcm;
    let mut m = LvModel {
        endo_radius: if hcm {
            uniform(rng, 19.0, 22.0)
        } else {
            uniform(rng, 22.0, 26.0)
        },
        endo_half_length: 0.0,
        base_fraction: uniform(rng, 0.25, 0.32),
        wall: if hcm {
            uniform(rng, 9.0, 11.0)
        } else {
            uniform(rng, 8.0, 10.0)
        },
        apex_wall: 0.0,
        free_wall: 0.0,
        free_wall_centre_deg: 180.0 + uniform(rng, -20.0, 20.0),
        free_wall_width_deg: uniform(rng, 100.0, 140.0),
        ellipticity: uniform(rng, 0.0, 0.06),
        ellipse_angle_deg: uniform(rng, 0.0, 180.0),
        circ_strain: if hcm {
            uniform(rng, -0.42, -0.36)
        } else {
            uniform(rng, -0.33, -0.27)
        },
        long_strain: if hcm {
            uniform(rng, -0.15, -0.11)
        } else {
            uniform(rng, -0.22, -0.18)
        },
        free_wall_motion: if hcm { uniform(rng, 0.45, 0.65) } else { 1.0 },
        unevenness: if hcm { 0.5 } else { 0.05 },
        uneven_phases: [
            uniform(rng, 0.0, 6.3),
            uniform(rng, 0.0, 6.3),
            uniform(rng, 0.0, 6.3),
        ],
        twist_apex_deg: uniform(rng, 7.0, 11.0),
        twist_base_deg: -uniform(rng, 3.0, 5.0),
        filling_exponent: if hcm { 1.3 } else { 0.6 },
        period: frames as f64,
        es_frame: 3.0 * frames as f64 / 8.0 + uniform(rng, -0.3, 0.3),
        ed_frame: 7.0 * frames as f64 / 8.0 + uniform(rng, -0.3, 0.3),
        centre: [
            uniform(rng, -3.0, 3.0),
            uniform(rng, -3.0, 3.0),
            uniform(rng, 13.0, 19.0),
        ],
        rotation: [[0.0; 3]; 3],
    };
    // Cavity length 70-78 mm (controls), 62-70 mm (HCM), apex to base plane.
    let length = if hcm {
        uniform(rng, 62.0, 70.0)
    } else {
        uniform(rng, 70.0, 78.0)
    };
    m.endo_half_length = length / (1.0 + m.base_fraction);
    m.apex_wall = 0.8 * m.wall;
    m.free_wall = if hcm { uniform(rng, 16.0, 22.0) } else { m.wall };
    // Long axis: world +z tilted by up to 6 degrees; septum direction at a random azimuth.
    let tilt = uniform(rng, 0.0, 6.0).to_radians();
    let tilt_dir = uniform(rng, 0.0, std::f64::consts::TAU);
    let spin = uniform(rng, 0.0, std::f64::consts::TAU);
    m.rotation = anatomy::frame_rotation(tilt, tilt_dir, spin);
    m
}

/// Redraws a model's parameters from the overlapping ranges and gives it a random pose (module
/// docs, "The overlapping cohort").
pub fn overlap_model(m: &mut LvModel, group: Group, rng: &mut ChaCha8Rng) {
    let hcm = group == Group::Hcm;
    let pick = |rng: &mut ChaCha8Rng, c: (f64, f64), h: (f64, f64)| {
        let (lo, hi) = if hcm { h } else { c };
        uniform(rng, lo, hi)
    };
    m.endo_radius = pick(rng, (21.0, 26.0), (19.0, 24.0));
    m.wall = pick(rng, (8.0, 12.0), (9.0, 12.0));
    m.apex_wall = 0.8 * m.wall;
    m.free_wall = if hcm { uniform(rng, 11.0, 20.0) } else { m.wall };
    m.circ_strain = pick(rng, (-0.35, -0.25), (-0.40, -0.28));
    m.long_strain = pick(rng, (-0.22, -0.15), (-0.18, -0.11));
    m.free_wall_motion = if hcm { uniform(rng, 0.55, 0.95) } else { 1.0 };
    m.unevenness = pick(rng, (0.05, 0.2), (0.2, 0.5));
    m.twist_apex_deg = pick(rng, (6.0, 12.0), (6.0, 14.0));
    m.twist_base_deg = -uniform(rng, 2.0, 6.0);
    m.filling_exponent = pick(rng, (0.5, 1.0), (0.8, 1.4));
    let length = pick(rng, (66.0, 78.0), (62.0, 74.0));
    m.endo_half_length = length / (1.0 + m.base_fraction);
    m.centre = [
        uniform(rng, -5.0, 5.0),
        uniform(rng, -5.0, 5.0),
        uniform(rng, 12.0, 20.0),
    ];
    let tilt = uniform(rng, 0.0, 25.0).to_radians();
    let tilt_dir = uniform(rng, 0.0, std::f64::consts::TAU);
    let spin = uniform(rng, 0.0, std::f64::consts::TAU);
    m.rotation = anatomy::frame_rotation(tilt, tilt_dir, spin);
}

/// Adds Gaussian noise of standard deviation `sigma` (mm) to every landmark coordinate.
fn jitter(frames: &mut [Vec<[f64; 3]>], sigma: f64, rng: &mut ChaCha8Rng) {
    for f in frames {
        for p in f.iter_mut() {
            for c in p.iter_mut() {
                let u1: f64 = rng.random::<f64>().max(1e-300);
                let u2: f64 = rng.random();
                *c += sigma * (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
            }
        }
    }
}

/// The image grid of the cohort: `size³` voxels over 104 x 104 x 130 mm centred on the
/// origin, x and y flipped (see the module docs).
pub fn grid(size: usize) -> Volume {
    let sp = [104.0 / size as f64, 104.0 / size as f64, 130.0 / size as f64];
    let half = |a: usize| (size as f64 - 1.0) / 2.0 * sp[a];
    let mut v = Volume::filled([size; 3], sp, [half(0), half(1), -half(2)], 0.0);
    v.affine[0][0] = -sp[0];
    v.affine[1][1] = -sp[1];
    v
}

/// Generates one subject: model, frames (HU, with noise), landmarks and cavity volumes.
/// Deterministic in `(opts.seed, index)`.
pub fn subject(name: &str, group: Group, index: u64, opts: &PhantomOptions) -> PhantomSubject {
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    rng.set_stream(2 * index + 1);
    let mut model = sample_model(group, opts.frames, &mut rng);
    if opts.overlap {
        overlap_model(&mut model, group, &mut rng);
    }
    let grid = grid(opts.size);
    let rendered: Vec<(Volume, f64)> = {
        use rayon::prelude::*;
        (0..opts.frames)
            .into_par_iter()
            .map(|t| {
                let mut noise = ChaCha8Rng::seed_from_u64(opts.seed ^ 0x9e37_79b9_7f4a_7c15);
                noise.set_stream(index * 4096 + t as u64);
                anatomy::render(&model, &grid, t as f64, opts.noise_hu, &mut noise)
            })
            .collect()
    };
    let mut landmarks = Landmarks {
        ids: (0..anatomy::N_LANDMARKS as u32).collect(),
        frames: (0..opts.frames)
            .map(|t| anatomy::landmarks(&model, t as f64))
            .collect(),
    };
    if opts.landmark_noise_mm > 0.0 {
        let mut noise = ChaCha8Rng::seed_from_u64(opts.seed ^ 0x5851_f42d_4c95_7f2d);
        noise.set_stream(index);
        jitter(&mut landmarks.frames, opts.landmark_noise_mm, &mut noise);
    }
    let (frames, cavity_ml) = rendered.into_iter().unzip();
    PhantomSubject {
        name: name.to_string(),
        group,
        model,
        frames,
        landmarks,
        cavity_ml,
    }
}

/// The cohort's names and groups: `subject01 ..` with the labels in a seeded random order
/// (so a name does not reveal its class).
pub fn roster(controls: usize, hcm: usize, seed: u64) -> Vec<(String, Group)> {
    let mut groups: Vec<Group> = std::iter::repeat_n(Group::Control, controls)
        .chain(std::iter::repeat_n(Group::Hcm, hcm))
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    for i in (1..groups.len()).rev() {
        let j = rng.random_range(0..=i);
        groups.swap(i, j);
    }
    let width = (groups.len().max(1)).to_string().len().max(2);
    groups
        .into_iter()
        .enumerate()
        .map(|(i, g)| (format!("subject{:0width$}", i + 1), g))
        .collect()
}
