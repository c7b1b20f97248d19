//! The eight analytic deformations of the synthetic benchmark (paper section 3, Fig. 3b-i).
//!
//! Each deformation is a smooth map `p -> phi(p, t)` of space with `phi(., 0)` the identity,
//! applied vertex by vertex. None of them is rigid, isometric or conformal (their fields have
//! non-zero rigid, isometric and conformal energy; tested), and they are clearly different
//! motions (their displacement fields on the sphere are far apart in L2; tested).
//!
//! All formulas are written in the shape's own [`Frame`]: `q = p - c` with `c` the centre of
//! the bounding box, `h = (h_x, h_y, h_z)` its half-extents, `R = max(h)` the shape's size and
//! `s = q_z / h_z` in `[-1, 1]` the normalized position along the z axis. So the same motion
//! means the same thing on every initial shape (the genus-0 shapes have their long axis along
//! z, the tori their ring in the xz-plane). The strength is `a = amplitude * t`; at
//! `amplitude = 1, t = 1` the largest vertex displacement is about 0.3-0.5 `R`. Amplitudes in
//! `[0, 1.5]` keep every motion orientation-preserving (no triangle can fold over).

use std::f64::consts::PI;
use std::fmt;
use std::str::FromStr;

use crate::mesh::{geometry, Shape};

/// Twist rate: the angle at `s = +-1` is `+-TWIST * a` (radians).
const TWIST: f64 = PI / 4.0;
/// Bend curvature times the size: `kappa = BEND * a / R`.
const BEND: f64 = 0.6;
/// Taper slope of the lateral scale along `s`.
const TAPER: f64 = 0.5;
/// Axial stretch: `q_z` grows by the factor `1 + STRETCH * a`.
const STRETCH: f64 = 0.4;
/// Bulge: lateral inflation at `s = 0`.
const BULGE: f64 = 0.4;
/// Bulge profile half-width in `s`.
const BULGE_WIDTH: f64 = 0.5;
/// Shear strain `d q_x / d q_z`.
const SHEAR: f64 = 0.4;
/// Dent depth as a fraction of `R`.
const DENT: f64 = 0.35;
/// Dent radius as a fraction of `R`.
const DENT_WIDTH: f64 = 0.6;
/// Ripple: relative amplitude of the lateral wave.
const RIPPLE: f64 = 0.25;

/// The frame a deformation is expressed in: bounding-box centre, half-extents and size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Bounding-box centre `c`.
    pub center: [f64; 3],
    /// Bounding-box half-extents `h` (each at least `1e-9 R`, so that `s` is finite on flat
    /// shapes).
    pub half: [f64; 3],
    /// Size `R = max(h)` (1 for an empty or single-point shape).
    pub size: f64,
}

impl Frame {
    /// The frame of a pose (#V x 3).
    pub fn of(positions: &[[f64; 3]]) -> Frame {
        if positions.is_empty() {
            return Frame {
                center: [0.0; 3],
                half: [1.0; 3],
                size: 1.0,
            };
        }
        let (lo, hi) = geometry::bounding_box(positions);
        let center = geometry::scale(geometry::add(lo, hi), 0.5);
        let half = geometry::scale(geometry::sub(hi, lo), 0.5);
        let mut size = half[0].max(half[1]).max(half[2]);
        if !(size > 0.0 && size.is_finite()) {
            size = 1.0;
        }
        Frame {
            center,
            half: half.map(|h| h.max(1e-9 * size)),
            size,
        }
    }
}

/// Parameters of a deformation instance: the frame of the shape it is applied to and an
/// amplitude multiplier (1 = the nominal motion; the benchmark's jitter varies it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeformParams {
    /// The shape's frame (take it from the initial pose, [`DeformParams::of`]).
    pub frame: Frame,
    /// Amplitude multiplier; `[0, 1.5]` keeps every motion valid.
    pub amplitude: f64,
}

impl DeformParams {
    /// The nominal parameters (amplitude 1) for `shape`'s frame.
    pub fn of(shape: &Shape) -> DeformParams {
        DeformParams {
            frame: Frame::of(&shape.positions),
            amplitude: 1.0,
        }
    }

    /// The same with another amplitude multiplier.
    pub fn with_amplitude(self, amplitude: f64) -> DeformParams {
        DeformParams { amplitude, ..self }
    }
}

/// The eight deformations (Fig. 3b-i): smooth maps `p -> phi(p, t)` with `phi(., 0)` the
/// identity, none rigid, isometric or conformal, all clearly different motions.
///
/// The formulas are written in the shape's own [`Frame`]: `q = p - c` with `c` the centre of
/// the bounding box, `h` its half-extents, `R = max(h)`, `s = q_z / h_z` in `[-1, 1]`;
/// `a = amplitude * t`; "lateral" is `(q_x, q_y)`. So the same motion means the same thing on
/// every initial shape. At `a = 1` the largest displacement is about 0.3-0.5 `R`; amplitudes
/// in `[0, 1.5]` keep every motion orientation-preserving.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DeformationKind {
    /// Twist about the z axis: `(q_x, q_y)` rotated by `phi = (pi/4) a s` (a quarter turn
    /// between the ends at `a = 1`).
    Twist,
    /// Bend of the z axis into a circular arc of curvature `kappa = 0.6 a / R` towards +x:
    /// with `theta = kappa q_z`, `q_x' = q_x cos(theta) + (1 - cos(theta)) / kappa`,
    /// `q_z' = (1/kappa - q_x) sin(theta)`.
    Bend,
    /// Taper: lateral scale `1 + 0.5 a s` (one end widens, the other narrows).
    Taper,
    /// Volume-preserving axial stretch: `q_z' = (1 + 0.4 a) q_z`, lateral scale
    /// `1 / sqrt(1 + 0.4 a)`.
    Stretch,
    /// Bulge: lateral scale `1 + 0.4 a exp(-(s / 0.5)^2)` (the middle inflates, the ends
    /// stay).
    Bulge,
    /// Shear: `q_x' = q_x + 0.4 a q_z`.
    Shear,
    /// One-sided dent: `q' = q - 0.35 a R exp(-|q - (h_x, 0, 0)|^2 / (0.6 R)^2) e_x`, a smooth
    /// push into the +x side.
    Dent,
    /// Ripple: lateral scale `1 + 0.25 a sin(2 pi s)` (two waves along the axis).
    Ripple,
    /// Swing (not in the paper's eight; curved vertex trajectories): the bend of [`Self::Bend`]
    /// towards the direction `(cos psi, sin psi, 0)` that turns with time, `psi = (pi/2) t`, so
    /// the shape bends and sweeps round by a quarter turn.
    Swing,
    /// Wring (not in the paper's eight; curved, back-and-forth trajectories): a twist whose
    /// angle profile travels along the axis, `phi = (pi/8) A t sin(pi (s + 1) / 2 + pi t)`.
    Wring,
}

impl DeformationKind {
    /// Every deformation, in the benchmark's order.
    pub fn all() -> [DeformationKind; 8] {
        use DeformationKind::*;
        [Twist, Bend, Taper, Stretch, Bulge, Shear, Dent, Ripple]
    }

    /// The paper's eight ([`Self::all`]) and the two with curved vertex trajectories
    /// ([`Self::Swing`], [`Self::Wring`]) of the robustness benchmark.
    pub fn extended() -> [DeformationKind; 10] {
        use DeformationKind::*;
        [
            Twist, Bend, Taper, Stretch, Bulge, Shear, Dent, Ripple, Swing, Wring,
        ]
    }

    /// Kebab-case name (`"twist"`, `"bend"`, ...), the benchmark's class label.
    pub fn name(self) -> &'static str {
        match self {
            DeformationKind::Twist => "twist",
            DeformationKind::Bend => "bend",
            DeformationKind::Taper => "taper",
            DeformationKind::Stretch => "stretch",
            DeformationKind::Bulge => "bulge",
            DeformationKind::Shear => "shear",
            DeformationKind::Dent => "dent",
            DeformationKind::Ripple => "ripple",
            DeformationKind::Swing => "swing",
            DeformationKind::Wring => "wring",
        }
    }

    /// The image of point `p` at time `t` in `[0, 1]` (identity at `t = 0`; smooth in `p`
    /// and `t`), in `p`'s length unit.
    pub fn apply(&self, p: [f64; 3], t: f64, params: &DeformParams) -> [f64; 3] {
        let Frame { center, half, size } = params.frame;
        let a = params.amplitude * t;
        let [x, y, z] = geometry::sub(p, center);
        let s = z / half[2];
        let lateral = |k: f64| [k * x, k * y, z];
        let bend = |x: f64, y: f64, z: f64| {
            let theta = BEND * a / size * z;
            let (sn, cs) = theta.sin_cos();
            [x * cs + z * cosc(theta), y, z * sinc(theta) - x * sn]
        };
        let q = match self {
            DeformationKind::Twist => {
                let (sn, cs) = (TWIST * a * s).sin_cos();
                [cs * x - sn * y, sn * x + cs * y, z]
            }
            DeformationKind::Bend => bend(x, y, z),
            DeformationKind::Swing => {
                // Rotate the bending direction to +x, bend, rotate back.
                let (sn, cs) = (PI / 2.0 * t).sin_cos();
                let b = bend(cs * x + sn * y, -sn * x + cs * y, z);
                [cs * b[0] - sn * b[1], sn * b[0] + cs * b[1], b[2]]
            }
            DeformationKind::Wring => {
                let phi = 0.5 * TWIST * params.amplitude * (PI * (s + 1.0) / 2.0 + PI * t).sin() * t.min(1.0);
                let (sn, cs) = phi.sin_cos();
                [cs * x - sn * y, sn * x + cs * y, z]
            }
            DeformationKind::Taper => lateral(1.0 + TAPER * a * s),
            DeformationKind::Stretch => {
                let k = (1.0 + STRETCH * a).max(1e-3);
                [x / k.sqrt(), y / k.sqrt(), z * k]
            }
            DeformationKind::Bulge => lateral(1.0 + BULGE * a * (-(s / BULGE_WIDTH).powi(2)).exp()),
            DeformationKind::Shear => [x + SHEAR * a * z, y, z],
            DeformationKind::Dent => {
                let d2 = (x - half[0]).powi(2) + y * y + z * z;
                let w = DENT_WIDTH * size;
                [x - DENT * a * size * (-d2 / (w * w)).exp(), y, z]
            }
            DeformationKind::Ripple => lateral(1.0 + RIPPLE * a * (2.0 * PI * s).sin()),
        };
        geometry::add(q, center)
    }
}

/// `sin(x) / x`, exact at 0.
fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-4 {
        1.0 - x * x / 6.0
    } else {
        x.sin() / x
    }
}

/// `(1 - cos(x)) / x`, exact at 0.
fn cosc(x: f64) -> f64 {
    if x.abs() < 1e-4 {
        x / 2.0 - x * x * x / 24.0
    } else {
        (1.0 - x.cos()) / x
    }
}

impl fmt::Display for DeformationKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for DeformationKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        DeformationKind::extended()
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| {
                let all: Vec<&str> = DeformationKind::extended().iter().map(|k| k.name()).collect();
                format!("unknown deformation '{s}' (expected {})", all.join(", "))
            })
    }
}

/// The pose (#V x 3) of `shape` deformed by `kind` at time `t` in `[0, 1]` with `params`
/// (normally [`DeformParams::of`]`(shape)`, or the frame of the deformation's first pose).
pub fn deform(shape: &Shape, kind: DeformationKind, t: f64, params: &DeformParams) -> Vec<[f64; 3]> {
    shape
        .positions
        .iter()
        .map(|p| kind.apply(*p, t, params))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::DEGENERATE_REL_TOL;
    use crate::synth::{initial_shape, template, torus_shape, torus_template, InitialShape, TorusShape};

    #[test]
    fn identity_at_zero_and_names_round_trip() {
        let s = initial_shape(InitialShape::Pear, &template(1));
        let params = DeformParams::of(&s);
        for kind in DeformationKind::extended() {
            assert_eq!(deform(&s, kind, 0.0, &params), s.positions, "{kind}");
            assert_eq!(kind.name().parse::<DeformationKind>().unwrap(), kind);
        }
        assert!("wiggle"
            .parse::<DeformationKind>()
            .unwrap_err()
            .contains("ripple"));
    }

    #[test]
    fn smooth_in_time_and_moderate() {
        let s = initial_shape(InitialShape::Sphere, &template(2));
        let params = DeformParams::of(&s);
        for kind in DeformationKind::extended() {
            let max_disp = |t: f64| {
                deform(&s, kind, t, &params)
                    .iter()
                    .zip(&s.positions)
                    .map(|(q, p)| geometry::norm(geometry::sub(*q, *p)))
                    .fold(0.0, f64::max)
            };
            let d1 = max_disp(1.0);
            assert!((0.15..=0.55).contains(&d1), "{kind}: max displacement {d1}");
            // Continuous at 0: displacement O(t).
            let d = max_disp(1e-6);
            assert!(d > 0.0 && d < 1e-5, "{kind}: {d}");
        }
    }

    #[test]
    fn valid_on_every_shape_even_at_the_largest_jittered_amplitude() {
        let t = template(2);
        let tt = torus_template(2);
        let genus0 = InitialShape::all().map(|k| (k.name(), initial_shape(k, &t)));
        let genus1 = TorusShape::all().map(|k| (k.name(), torus_shape(k, &tt)));
        for (shape, s) in genus0.iter().chain(&genus1) {
            for kind in DeformationKind::extended() {
                let params = DeformParams::of(s).with_amplitude(1.5);
                let pos = deform(s, kind, 1.0, &params);
                let d = Shape::new_checked(s.topology.clone(), pos.clone(), DEGENERATE_REL_TOL);
                assert!(d.is_ok(), "{shape} {kind}: {d:?}");
                // No triangle flips: each face normal stays within 90 degrees of the normal of
                // its neighbourhood after the motion (the motion is locally orientation
                // preserving).
                let n0 = geometry::face_normals(&s.topology, &pos);
                let nv = geometry::vertex_normals(&s.topology, &pos);
                for (f, n) in s.topology.faces().iter().zip(&n0) {
                    let avg = f
                        .iter()
                        .fold([0.0; 3], |acc, &v| geometry::add(acc, nv[v as usize]));
                    assert!(geometry::dot(*n, avg) > 0.0, "{shape} {kind}: a face flipped");
                }
            }
        }
    }
}
