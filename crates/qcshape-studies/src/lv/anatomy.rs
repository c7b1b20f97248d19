//! The phantom's left-ventricle model: geometry at any time of the cycle, the CT-like image
//! it renders, and its 32 material landmarks. Parameters and their sources are documented in
//! [`super::phantom`].
//!
//! Local coordinates (mm): `z` along the long axis (apex to base), `x` towards the septum.
//! The endocardial apex stays at `z = -C0`; the ellipsoids' common centre is at
//! `z_c(t) = -C0 + C(t)`, the base plane at `z_c + beta C(t)`. A material point is named by
//! its normalized height `h` (0 apex, 1 base plane) and material angle `Theta` (degrees from
//! the septum); at time `t` it sits at angle `Theta + psi(h, t)` (twist).

use rand::Rng;
use rand_chacha::ChaCha8Rng;

use qcshape::io::nifti::{apply_affine, Volume};

/// Landmarks per frame.
pub const N_LANDMARKS: usize = 32;

/// Lung-like background (HU).
pub const BACKGROUND_HU: f64 = -750.0;
/// Myocardium (HU).
pub const MYOCARDIUM_HU: f64 = 60.0;
/// Contrast-filled blood (HU).
pub const BLOOD_HU: f64 = 400.0;
/// Half-width (degrees) of the cos² tapers at the free-wall sector's edges.
pub const SECTOR_TAPER_DEG: f64 = 15.0;

/// Weight at angle `theta` (degrees) of a sector of `width` degrees centred at `centre`: 1
/// closer than `width / 2 - taper` to the centre, 0 farther than `width / 2 + taper`, a cos²
/// ramp between (angles wrap at 360°).
pub fn sector_weight(centre: f64, width: f64, taper: f64, theta: f64) -> f64 {
    let d = ((theta - centre + 540.0).rem_euclid(360.0) - 180.0).abs();
    let half = width / 2.0;
    if d <= half - taper {
        1.0
    } else if d >= half + taper {
        0.0
    } else {
        let x = (d - (half - taper)) / (2.0 * taper);
        (std::f64::consts::FRAC_PI_2 * x).cos().powi(2)
    }
}

/// Thickness of the valve-plane tissue closing the cavity at the base (mm).
const CAP_MM: f64 = 5.0;

/// One subject's geometry, motion and pose (lengths in mm, angles in degrees unless named
/// otherwise, strains as fractions).
#[derive(Debug, Clone, PartialEq)]
pub struct LvModel {
    /// End-diastolic endocardial short-axis semi-axis `A0`.
    pub endo_radius: f64,
    /// End-diastolic endocardial long semi-axis `C0`.
    pub endo_half_length: f64,
    /// Base plane height above the ellipsoid centre, as a fraction `beta` of `C`.
    pub base_fraction: f64,
    /// End-diastolic wall thickness outside the free-wall sector.
    pub wall: f64,
    /// End-diastolic wall thickness at the apex.
    pub apex_wall: f64,
    /// End-diastolic wall thickness in the middle of the free-wall sector.
    pub free_wall: f64,
    /// Free-wall sector centre, degrees from the septum.
    pub free_wall_centre_deg: f64,
    /// Free-wall sector width (degrees; cos² tapers of 15° on each side).
    pub free_wall_width_deg: f64,
    /// Short-axis ellipticity `e`: radius factor `1 + e cos 2(Theta - angle)`.
    pub ellipticity: f64,
    /// Orientation of the ellipticity (degrees).
    pub ellipse_angle_deg: f64,
    /// Peak endocardial circumferential strain `eps_c` (< 0).
    pub circ_strain: f64,
    /// Peak longitudinal strain `eps_l` of the cavity length (< 0).
    pub long_strain: f64,
    /// Factor of the circumferential strain in the free-wall sector (1: normal).
    pub free_wall_motion: f64,
    /// Amplitude of the smooth random variation of the motion (in the sector when
    /// `free_wall_motion < 1`, everywhere otherwise).
    pub unevenness: f64,
    /// Phases of that variation.
    pub uneven_phases: [f64; 3],
    /// Peak apical rotation (degrees, counter-clockwise seen from the apex).
    pub twist_apex_deg: f64,
    /// Peak basal rotation (degrees, negative: clockwise).
    pub twist_base_deg: f64,
    /// Diastolic filling exponent (< 1 fast early filling, > 1 delayed relaxation).
    pub filling_exponent: f64,
    /// Frames per cycle.
    pub period: f64,
    /// End-systolic time (frames).
    pub es_frame: f64,
    /// End-diastolic time (frames).
    pub ed_frame: f64,
    /// World position (mm) of the local origin.
    pub centre: [f64; 3],
    /// Local-to-world rotation; columns: septum direction, second axis, long axis.
    pub rotation: [[f64; 3]; 3],
}

/// The rotation whose third column is +z tilted by `tilt` (radians) towards azimuth
/// `tilt_dir`, and whose first column is turned by `spin` about it.
pub fn frame_rotation(tilt: f64, tilt_dir: f64, spin: f64) -> [[f64; 3]; 3] {
    let e3 = [
        tilt.sin() * tilt_dir.cos(),
        tilt.sin() * tilt_dir.sin(),
        tilt.cos(),
    ];
    let a = if e3[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let d = a[0] * e3[0] + a[1] * e3[1] + a[2] * e3[2];
    let u = normalize([a[0] - d * e3[0], a[1] - d * e3[1], a[2] - d * e3[2]]);
    let v = cross(e3, u);
    let e1: [f64; 3] = std::array::from_fn(|c| spin.cos() * u[c] + spin.sin() * v[c]);
    let e2 = cross(e3, e1);
    std::array::from_fn(|r| [e1[r], e2[r], e3[r]])
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normalize(a: [f64; 3]) -> [f64; 3] {
    let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    a.map(|c| c / n)
}

/// Radii at one material point and time.
struct Radii {
    a_en: f64,
    c_en: f64,
    a_ep: f64,
    c_ep: f64,
}

impl LvModel {
    /// Contraction `c(t)` in [0, 1]: 0 at end-diastole, 1 at end-systole (half-cosine
    /// systole, diastole with [`LvModel::filling_exponent`]).
    pub fn contraction(&self, t: f64) -> f64 {
        let p = self.period;
        let u = (t - self.ed_frame).rem_euclid(p);
        let s = (self.es_frame - self.ed_frame).rem_euclid(p);
        if u <= s {
            0.5 * (1.0 - (std::f64::consts::PI * u / s).cos())
        } else {
            let w = (u - s) / (p - s);
            0.5 * (1.0 + (std::f64::consts::PI * w.powf(self.filling_exponent)).cos())
        }
    }

    /// Weight of the free-wall sector at material angle `theta` (degrees): 1 inside, cos²
    /// tapers over 15° at the edges, 0 outside ([`sector_weight`]).
    pub fn sector_weight(&self, theta: f64) -> f64 {
        sector_weight(
            self.free_wall_centre_deg,
            self.free_wall_width_deg,
            SECTOR_TAPER_DEG,
            theta,
        )
    }

    /// End-diastolic wall thickness at material angle `theta` and height `h`.
    pub fn wall_at(&self, theta: f64, h: f64) -> f64 {
        let taper = ((h - 0.05) / 0.25).clamp(0.0, 1.0);
        self.wall + (self.free_wall - self.wall) * self.sector_weight(theta) * taper
    }

    /// Factor of the circumferential strain at material angle `theta` and height `h`.
    pub fn motion_at(&self, theta: f64, h: f64) -> f64 {
        let w = self.sector_weight(theta);
        let base = 1.0 - w * (1.0 - self.free_wall_motion);
        let th = theta.to_radians();
        let [p0, p1, p2] = self.uneven_phases;
        let xi = 0.6 * (2.0 * th + p0).sin() * (3.0 * h + p1).cos() + 0.4 * (3.0 * th + p2).sin();
        let amp = if self.free_wall_motion < 1.0 {
            self.unevenness * w
        } else {
            self.unevenness
        };
        base * (1.0 + amp * xi)
    }

    /// Twist angle (radians) of height `h` at time `t`.
    fn twist(&self, h: f64, t: f64) -> f64 {
        (self.contraction(t) * (self.twist_apex_deg * (1.0 - h) + self.twist_base_deg * h)).to_radians()
    }

    fn radii(&self, theta: f64, h: f64, t: f64) -> Radii {
        let c = self.contraction(t);
        let a0 = self.endo_radius
            * (1.0 + self.ellipticity * (2.0 * (theta - self.ellipse_angle_deg).to_radians()).cos());
        let c0 = self.endo_half_length;
        let t0 = self.wall_at(theta, h);
        let (ae0, ce0) = (a0 + t0, c0 + self.apex_wall);
        let a_en = a0 * (1.0 + self.circ_strain * self.motion_at(theta, h) * c);
        let c_en = c0 * (1.0 + self.long_strain * c);
        // Myocardial volume conservation: (A + T)^2 (C + k T) = K, k = apex_wall / T0.
        let k = self.apex_wall / t0;
        let target = ae0 * ae0 * ce0 - a0 * a0 * c0 + a_en * a_en * c_en;
        let mut th = t0;
        for _ in 0..8 {
            let f = (a_en + th).powi(2) * (c_en + k * th) - target;
            let df = 2.0 * (a_en + th) * (c_en + k * th) + k * (a_en + th).powi(2);
            th = (th - f / df).max(0.1);
        }
        Radii {
            a_en,
            c_en,
            a_ep: a_en + th,
            c_ep: c_en + k * th,
        }
    }

    fn local_to_world(&self, p: [f64; 3]) -> [f64; 3] {
        let r = &self.rotation;
        std::array::from_fn(|i| self.centre[i] + r[i][0] * p[0] + r[i][1] * p[1] + r[i][2] * p[2])
    }

    fn world_to_local(&self, w: [f64; 3]) -> [f64; 3] {
        let d = [
            w[0] - self.centre[0],
            w[1] - self.centre[1],
            w[2] - self.centre[2],
        ];
        let r = &self.rotation;
        std::array::from_fn(|c| r[0][c] * d[0] + r[1][c] * d[1] + r[2][c] * d[2])
    }

    /// Approximate signed distance (mm, negative inside) from a world point to the cavity
    /// wall (endocardium and valve plane) at frame time `t`: exact on the wall, within a few
    /// percent of the Euclidean distance within a few mm of it. The ground truth of tests of
    /// the registration ([`super::refine`]).
    pub fn cavity_distance(&self, world: [f64; 3], t: f64) -> f64 {
        self.distances(self.world_to_local(world), t).0
    }

    /// Approximate signed distances (mm, negative inside) to the cavity and to the
    /// myocardium-plus-cavity region at a local point and time.
    fn distances(&self, p: [f64; 3], t: f64) -> (f64, f64) {
        let beta = self.base_fraction;
        let c_en_t = self.endo_half_length * (1.0 + self.long_strain * self.contraction(t));
        let zc = -self.endo_half_length + c_en_t;
        let zb = zc + beta * c_en_t;
        let zeta = (p[2] - zc) / c_en_t;
        let h = ((zeta + 1.0) / (1.0 + beta)).clamp(0.0, 1.0);
        let theta = (p[1].atan2(p[0]) - self.twist(h, t)).to_degrees();
        let r = self.radii(theta, h, t);
        let rad = (p[0] * p[0] + p[1] * p[1]).sqrt();
        let dz = p[2] - zc;
        let ell = |a: f64, c: f64| {
            let rho = ((rad / a).powi(2) + (dz / c).powi(2)).sqrt();
            let g = ((rad / (a * a)).powi(2) + (dz / (c * c)).powi(2)).sqrt();
            if rho < 1e-9 || g < 1e-12 {
                -a.min(c)
            } else {
                (rho - 1.0) * rho / g
            }
        };
        let d_cav = ell(r.a_en, r.c_en).max(p[2] - zb);
        let d_myo = ell(r.a_ep, r.c_ep).max(p[2] - zb - CAP_MM);
        (d_cav, d_myo)
    }
}

/// The image of frame time `t` on `grid`'s voxels (HU) with Gaussian noise of `noise_hu`,
/// and the noise-free cavity volume (mL, partial-volume weighted).
pub fn render(model: &LvModel, grid: &Volume, t: f64, noise_hu: f64, rng: &mut ChaCha8Rng) -> (Volume, f64) {
    let mut vol = grid.clone();
    let [nx, ny, nz] = vol.dims;
    let width = 0.35 * vol.spacing.iter().copied().fold(f64::MAX, f64::min);
    let step = |d: f64| 0.5 * (1.0 - (d / width).tanh());
    let mut cavity = 0.0;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let w = apply_affine(&grid.affine, [i as f64, j as f64, k as f64]);
                let (d_cav, d_myo) = model.distances(model.world_to_local(w), t);
                let (f_cav, f_myo) = (step(d_cav), step(d_myo));
                cavity += f_cav;
                let mut v = BACKGROUND_HU
                    + (MYOCARDIUM_HU - BACKGROUND_HU) * f_myo
                    + (BLOOD_HU - MYOCARDIUM_HU) * f_cav;
                if noise_hu > 0.0 {
                    let u1 = 1.0 - rng.random::<f64>();
                    let u2 = rng.random::<f64>();
                    v += noise_hu * (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
                }
                let idx = i + nx * (j + ny * k);
                vol.data[idx] = v as f32;
            }
        }
    }
    (vol, cavity * grid.voxel_volume() / 1000.0)
}

/// Where each landmark sits: on the endocardium or epicardium at `(h, Theta)`, or special.
#[derive(Debug, Clone, Copy)]
enum Site {
    EndoApex,
    BaseCentre,
    EpiApex,
    Endo(f64, f64),
    Epi(f64, f64),
}

/// The 32 landmarks in id order; each block of 8 covers apex/base, both walls, several
/// heights and angles, so the first 8, 16, 24 and 32 are all usable subsets. Id 0 is the
/// apex, 1 the base centre, 3 the septum reference (see [`super::landmarks`]).
const SITES: [Site; N_LANDMARKS] = {
    use Site::*;
    [
        EndoApex,
        BaseCentre,
        EpiApex,
        Endo(0.9, 0.0),
        Endo(0.9, 120.0),
        Endo(0.9, 240.0),
        Endo(0.5, 180.0),
        Epi(0.5, 0.0),
        Endo(0.5, 60.0),
        Endo(0.5, 300.0),
        Epi(0.9, 60.0),
        Epi(0.9, 180.0),
        Epi(0.9, 300.0),
        Epi(0.5, 120.0),
        Epi(0.5, 240.0),
        Endo(0.25, 0.0),
        Endo(0.25, 120.0),
        Endo(0.25, 240.0),
        Endo(0.7, 90.0),
        Endo(0.7, 270.0),
        Epi(0.25, 60.0),
        Epi(0.25, 180.0),
        Epi(0.25, 300.0),
        Epi(0.7, 0.0),
        Endo(0.7, 150.0),
        Endo(0.7, 210.0),
        Endo(0.4, 30.0),
        Endo(0.4, 330.0),
        Epi(0.7, 120.0),
        Epi(0.7, 240.0),
        Epi(0.4, 90.0),
        Epi(0.4, 270.0),
    ]
};

/// The 32 landmark positions (world mm) at time `t`.
pub fn landmarks(model: &LvModel, t: f64) -> Vec<[f64; 3]> {
    let beta = model.base_fraction;
    let c_en_t = model.endo_half_length * (1.0 + model.long_strain * model.contraction(t));
    let zc = -model.endo_half_length + c_en_t;
    let at = |h: f64, theta: f64, epi: bool| {
        let zeta = h * (1.0 + beta) - 1.0;
        let r = model.radii(theta, h, t);
        let z = zc + zeta * r.c_en;
        let rad = if epi {
            r.a_ep * (1.0 - (zeta * r.c_en / r.c_ep).powi(2)).max(0.0).sqrt()
        } else {
            r.a_en * (1.0 - zeta * zeta).max(0.0).sqrt()
        };
        let ang = theta.to_radians() + model.twist(h, t);
        [rad * ang.cos(), rad * ang.sin(), z]
    };
    SITES
        .iter()
        .map(|s| {
            let local = match *s {
                Site::EndoApex => [0.0, 0.0, -model.endo_half_length],
                Site::BaseCentre => [0.0, 0.0, zc + beta * c_en_t],
                Site::EpiApex => [0.0, 0.0, zc - model.radii(0.0, 0.0, t).c_ep],
                Site::Endo(h, th) => at(h, th, false),
                Site::Epi(h, th) => at(h, th, true),
            };
            model.local_to_world(local)
        })
        .collect()
}
