//! Initial shapes of the synthetic benchmark (paper section 3, Fig. 3a): six genus-0 shapes
//! made by moving the vertices of one icosphere template, and three genus-1 shapes made from
//! one torus template. Shapes of one genus therefore share one `Arc<Topology>` and full point
//! correspondence.
//!
//! Every shape is centred on its bounding-box centre and scaled to bounding radius 1 (the
//! largest vertex distance from the centre). The genus-0 shapes have their long (or symmetry)
//! axis along z, which is the axis the deformations of
//! [`DeformationKind`](super::DeformationKind) twist about, bend, taper and stretch along.

use std::fmt;
use std::str::FromStr;
use std::sync::Arc;

use super::primitives::{icosphere, torus};
use crate::mesh::{geometry, Shape};

/// The finest template level accepted by the benchmark (icosphere level 6: 40,962 vertices).
pub const MAX_LEVEL: u32 = 6;

/// The genus-0 template: the unit icosphere of `level` subdivisions (`10 * 4^level + 2`
/// vertices, see [`icosphere`]). Every [`InitialShape`] moves its vertices.
pub fn template(level: u32) -> Shape {
    icosphere(level)
}

/// The genus-1 template for a level: a torus sampled on `6 * 2^level` (around the ring) by
/// `3 * 2^level` (around the tube) vertices (level 1: 72, 2: 288, 3: 1,152), major radius 1,
/// minor radius 0.5, axis z. Every [`TorusShape`] moves its vertices.
pub fn torus_template(level: u32) -> Shape {
    let k = 1usize << level.min(MAX_LEVEL);
    torus(6 * k, 3 * k, 1.0, 0.5)
}

/// The six genus-0 initial shapes (Fig. 3a), each a smooth map of the unit sphere.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum InitialShape {
    /// The unit sphere.
    Sphere,
    /// Prolate ellipsoid, semi-axes 0.6 : 0.6 : 1 (long axis z).
    Ellipsoid,
    /// Oblate ellipsoid, semi-axes 1 : 1 : 0.5 (short axis z).
    OblateEllipsoid,
    /// Superquadric box `|x/0.7|^4 + |y/0.85|^4 + |z|^4 = 1` (radial projection of the sphere).
    RoundedBox,
    /// Sphere with lateral scale `0.62 (1 - 0.3 z) (1 - 0.3 exp(-((z - 0.3) / 0.3)^2))`: a bulb
    /// at the bottom and a narrow neck towards the top.
    Pear,
    /// Sphere with lateral scale `0.6 (1 - 0.4 exp(-(z / 0.3)^2))`: two lobes and a waist.
    Peanut,
}

impl InitialShape {
    /// Every shape, in the benchmark's order.
    pub fn all() -> [InitialShape; 6] {
        use InitialShape::*;
        [Sphere, Ellipsoid, OblateEllipsoid, RoundedBox, Pear, Peanut]
    }

    /// Kebab-case name (`"sphere"`, `"oblate-ellipsoid"`, ...), used in file and set names.
    pub fn name(self) -> &'static str {
        match self {
            InitialShape::Sphere => "sphere",
            InitialShape::Ellipsoid => "ellipsoid",
            InitialShape::OblateEllipsoid => "oblate-ellipsoid",
            InitialShape::RoundedBox => "rounded-box",
            InitialShape::Pear => "pear",
            InitialShape::Peanut => "peanut",
        }
    }

    /// The image of a unit-sphere point `u` (before centring and scaling).
    fn map(self, u: [f64; 3]) -> [f64; 3] {
        let [x, y, z] = u;
        let lateral = |s: f64| [s * x, s * y, z];
        match self {
            InitialShape::Sphere => u,
            InitialShape::Ellipsoid => lateral(0.6),
            InitialShape::OblateEllipsoid => [x, y, 0.5 * z],
            InitialShape::RoundedBox => {
                let q = (x / 0.7).powi(4) + (y / 0.85).powi(4) + z.powi(4);
                geometry::scale(u, q.powf(-0.25))
            }
            InitialShape::Pear => {
                let neck = 1.0 - 0.3 * (-((z - 0.3) / 0.3).powi(2)).exp();
                lateral(0.62 * (1.0 - 0.3 * z) * neck)
            }
            InitialShape::Peanut => lateral(0.6 * (1.0 - 0.4 * (-(z / 0.3).powi(2)).exp())),
        }
    }
}

impl fmt::Display for InitialShape {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for InitialShape {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        InitialShape::all()
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| {
                format!(
                    "unknown initial shape '{s}' (expected {})",
                    names(&InitialShape::all())
                )
            })
    }
}

/// The three genus-1 initial shapes: tori with the ring in the xz-plane (axis y), so that z
/// runs along the ring like the long axis of the genus-0 shapes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TorusShape {
    /// Major radius 1, circular tube of radius 0.45.
    Round,
    /// Major radius 1, circular tube of radius 0.25.
    Thin,
    /// Major radius 1, elliptical tube: 0.3 in the ring plane, 0.55 along the axis.
    Elliptic,
}

impl TorusShape {
    /// Every torus shape, in the benchmark's order.
    pub fn all() -> [TorusShape; 3] {
        [TorusShape::Round, TorusShape::Thin, TorusShape::Elliptic]
    }

    /// Kebab-case name, prefixed `torus-` (`"torus-round"`, ...).
    pub fn name(self) -> &'static str {
        match self {
            TorusShape::Round => "torus-round",
            TorusShape::Thin => "torus-thin",
            TorusShape::Elliptic => "torus-elliptic",
        }
    }

    /// `(major radius, tube semi-axis in the ring plane, tube semi-axis along the axis)`.
    fn radii(self) -> (f64, f64, f64) {
        match self {
            TorusShape::Round => (1.0, 0.45, 0.45),
            TorusShape::Thin => (1.0, 0.25, 0.25),
            TorusShape::Elliptic => (1.0, 0.3, 0.55),
        }
    }
}

impl fmt::Display for TorusShape {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for TorusShape {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        TorusShape::all()
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| {
                format!(
                    "unknown torus shape '{s}' (expected {})",
                    names(&TorusShape::all())
                )
            })
    }
}

fn names<T: fmt::Display>(all: &[T]) -> String {
    all.iter().map(|k| k.to_string()).collect::<Vec<_>>().join(", ")
}

/// Centres `pos` on its bounding-box centre and scales it to bounding radius 1.
fn normalize(mut pos: Vec<[f64; 3]>) -> Vec<[f64; 3]> {
    let (lo, hi) = geometry::bounding_box(&pos);
    let c = geometry::scale(geometry::add(lo, hi), 0.5);
    let r = pos
        .iter()
        .map(|p| geometry::norm(geometry::sub(*p, c)))
        .fold(0.0, f64::max);
    let s = if r > 0.0 { 1.0 / r } else { 1.0 };
    for p in &mut pos {
        *p = geometry::scale(geometry::sub(*p, c), s);
    }
    pos
}

/// The initial shape `kind` on `template` (#V x 3, normally [`template`]`(level)`): each
/// vertex is projected to the unit sphere, mapped, then the shape is centred and scaled to
/// bounding radius 1. The result shares `template`'s `Arc<Topology>`.
pub fn initial_shape(kind: InitialShape, template: &Shape) -> Shape {
    let pos = template
        .positions
        .iter()
        .map(|p| {
            let r = geometry::norm(*p);
            let u = if r > 0.0 {
                geometry::scale(*p, 1.0 / r)
            } else {
                [0.0, 0.0, 1.0]
            };
            kind.map(u)
        })
        .collect();
    Shape {
        topology: Arc::clone(&template.topology),
        positions: normalize(pos),
    }
}

/// The torus shape `kind` on `template` (#V x 3, normally [`torus_template`]`(level)`, a torus
/// about the z axis): each vertex's ring angle `u` and tube angle `v` are read from its
/// position, the torus is rebuilt with `kind`'s radii, turned so its axis is y (a proper
/// rotation, orientation kept), centred and scaled to bounding radius 1. Shares `template`'s
/// `Arc<Topology>`.
pub fn torus_shape(kind: TorusShape, template: &Shape) -> Shape {
    let (big, a, b) = kind.radii();
    let (lo, hi) = geometry::bounding_box(&template.positions);
    // Major radius of the template: the tube centre line lies midway between the inner and
    // outer equators.
    let c = geometry::scale(geometry::add(lo, hi), 0.5);
    let rho_max = template
        .positions
        .iter()
        .map(|p| (p[0] - c[0]).hypot(p[1] - c[1]))
        .fold(0.0, f64::max);
    let rho_min = template
        .positions
        .iter()
        .map(|p| (p[0] - c[0]).hypot(p[1] - c[1]))
        .fold(f64::INFINITY, f64::min);
    let r0 = 0.5 * (rho_max + rho_min);
    let pos = template
        .positions
        .iter()
        .map(|p| {
            let (x, y, z) = (p[0] - c[0], p[1] - c[1], p[2] - c[2]);
            let u = y.atan2(x);
            let v = z.atan2(x.hypot(y) - r0);
            let rho = big + a * v.cos();
            let q = [rho * u.cos(), rho * u.sin(), b * v.sin()];
            // Rotation about x by -90 degrees: (x, y, z) -> (x, z, -y).
            [q[0], q[2], -q[1]]
        })
        .collect();
    Shape {
        topology: Arc::clone(&template.topology),
        positions: normalize(pos),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::DEGENERATE_REL_TOL;

    /// Smallest corner angle of a shape, in degrees.
    pub(crate) fn min_angle_deg(s: &Shape) -> f64 {
        geometry::corner_angles(&s.topology, &s.positions)
            .iter()
            .flatten()
            .fold(f64::INFINITY, |m, a| m.min(*a))
            .to_degrees()
    }

    fn signed_volume(s: &Shape) -> f64 {
        s.topology
            .faces()
            .iter()
            .map(|f| {
                let [p, q, r] = f.map(|i| s.positions[i as usize]);
                geometry::dot(p, geometry::cross(q, r)) / 6.0
            })
            .sum()
    }

    #[test]
    fn genus0_shapes_share_the_template_and_are_well_shaped() {
        let t = template(3);
        for kind in InitialShape::all() {
            let s = initial_shape(kind, &t);
            assert!(Arc::ptr_eq(&s.topology, &t.topology));
            Shape::new_checked(s.topology.clone(), s.positions.clone(), DEGENERATE_REL_TOL).unwrap();
            let r = s.positions.iter().map(|p| geometry::norm(*p)).fold(0.0, f64::max);
            assert!((r - 1.0).abs() < 1e-12, "{kind}: bounding radius {r}");
            let (lo, hi) = geometry::bounding_box(&s.positions);
            for c in 0..3 {
                assert!((lo[c] + hi[c]).abs() < 1e-12, "{kind}: not centred");
            }
            assert!(signed_volume(&s) > 0.05, "{kind}: orientation or collapse");
            let a = min_angle_deg(&s);
            assert!(a > 12.0, "{kind}: min angle {a:.1} deg");
            assert_eq!(kind.name().parse::<InitialShape>().unwrap(), kind);
        }
        assert!("cube"
            .parse::<InitialShape>()
            .unwrap_err()
            .contains("rounded-box"));
    }

    #[test]
    fn the_shapes_are_different_and_have_their_long_axis_along_z() {
        let t = template(2);
        let shapes: Vec<Shape> = InitialShape::all()
            .iter()
            .map(|k| initial_shape(*k, &t))
            .collect();
        for (i, a) in shapes.iter().enumerate() {
            for b in &shapes[i + 1..] {
                let d = a
                    .positions
                    .iter()
                    .zip(&b.positions)
                    .map(|(p, q)| geometry::norm(geometry::sub(*p, *q)))
                    .fold(0.0, f64::max);
                assert!(d > 0.1, "two shapes nearly coincide ({d})");
            }
        }
        for kind in [InitialShape::Ellipsoid, InitialShape::Pear, InitialShape::Peanut] {
            let s = initial_shape(kind, &t);
            let (lo, hi) = geometry::bounding_box(&s.positions);
            assert!(hi[2] - lo[2] > 1.4 * (hi[0] - lo[0]), "{kind}");
        }
        // The peanut has a waist: narrower at z = 0 than at its lobes.
        let s = initial_shape(InitialShape::Peanut, &t);
        let width = |z0: f64| {
            s.positions
                .iter()
                .filter(|p| (p[2] - z0).abs() < 0.08)
                .map(|p| p[0].hypot(p[1]))
                .fold(0.0, f64::max)
        };
        assert!(width(0.0) < 0.85 * width(0.5), "{} {}", width(0.0), width(0.5));
    }

    #[test]
    fn torus_shapes_share_the_template_and_are_genus_one() {
        for level in [1, 3] {
            let t = torus_template(level);
            for kind in TorusShape::all() {
                let s = torus_shape(kind, &t);
                assert!(Arc::ptr_eq(&s.topology, &t.topology));
                assert_eq!(s.topology.genus(), Some(1));
                Shape::new_checked(s.topology.clone(), s.positions.clone(), DEGENERATE_REL_TOL).unwrap();
                assert!(signed_volume(&s) > 0.01, "{kind}: orientation");
                let (lo, hi) = geometry::bounding_box(&s.positions);
                // Ring in the xz-plane, axis y.
                assert!(hi[1] - lo[1] < 0.75 * (hi[2] - lo[2]), "{kind}");
                if level == 3 {
                    let a = min_angle_deg(&s);
                    assert!(a > 12.0, "{kind}: min angle {a:.1} deg");
                }
                assert_eq!(kind.name().parse::<TorusShape>().unwrap(), kind);
            }
        }
    }
}
