//! The synthetic benchmark's deformations (paper section 3): none is rigid, isometric or
//! conformal, and they are clearly different motions.

use qcshape::mesh::{geometry, Shape};
use qcshape::metric::{At, Conformal, ConformalForm, Isometric, Metric, Rigid, Segment, L2};
use qcshape::synth::{deform, initial_shape, template, DeformParams, DeformationKind, InitialShape};

/// `G_M(X)` (eqs. 1, 3, 7-9, 11) measured at `s` for the field `X` (#V x 3).
fn energy(metric: &dyn Metric, s: &Shape, x: &[[f64; 3]]) -> f64 {
    let b: Vec<[f64; 3]> = s
        .positions
        .iter()
        .zip(x)
        .map(|(p, d)| geometry::add(*p, *d))
        .collect();
    let seg = Segment {
        a: &s.positions,
        b: &b,
        at: At::Start,
        aux: &[],
        frozen: None,
    };
    metric.squared_norm(&s.topology, &metric.pattern(&s.topology), &seg)
}

fn metrics() -> Vec<(&'static str, Box<dyn Metric>)> {
    vec![
        ("rigid", Box::new(Rigid)),
        ("isometric", Box::new(Isometric)),
        ("conformal", Box::new(Conformal::new(ConformalForm::Quadratic))),
    ]
}

/// `G_M(X) / G_L2(X)`, divided by the same ratio for the reference field `(-x/2, -y/2, z)` (an
/// infinitesimal volume-preserving stretch, neither rigid, isometric nor conformal): a scale-
/// and resolution-free measure of how far `X` is from the metric's null space.
fn relative_energy(metric: &dyn Metric, s: &Shape, x: &[[f64; 3]]) -> f64 {
    let reference: Vec<[f64; 3]> = s
        .positions
        .iter()
        .map(|p| [-0.5 * p[0], -0.5 * p[1], p[2]])
        .collect();
    let ratio = |x: &[[f64; 3]]| energy(metric, s, x) / energy(&L2, s, x);
    ratio(x) / ratio(&reference)
}

fn displacement(s: &Shape, kind: DeformationKind, t: f64) -> Vec<[f64; 3]> {
    let pos = deform(s, kind, t, &DeformParams::of(s));
    pos.iter()
        .zip(&s.positions)
        .map(|(q, p)| geometry::sub(*q, *p))
        .collect()
}

#[test]
fn the_null_space_controls_have_zero_relative_energy() {
    // The measure can fail: an infinitesimal rotation is rigid, isometric and conformal; a
    // uniform scaling is conformal but neither rigid nor isometric.
    let s = initial_shape(InitialShape::Pear, &template(2));
    let rotation: Vec<[f64; 3]> = s
        .positions
        .iter()
        .map(|p| geometry::cross([0.3, -0.2, 0.5], *p))
        .collect();
    let scaling: Vec<[f64; 3]> = s.positions.iter().map(|p| geometry::scale(*p, 0.2)).collect();
    for (name, m) in metrics() {
        let e = relative_energy(m.as_ref(), &s, &rotation);
        assert!(e < 1e-12, "{name}: rotation {e}");
        let e = relative_energy(m.as_ref(), &s, &scaling);
        if name == "conformal" {
            assert!(e < 1e-12, "{name}: scaling {e}");
        } else {
            assert!(e > 0.1, "{name}: scaling {e}");
        }
    }
}

#[test]
fn no_deformation_is_rigid_isometric_or_conformal() {
    let t = template(2);
    for shape in InitialShape::all() {
        let s = initial_shape(shape, &t);
        for kind in DeformationKind::all() {
            // The displacement at t = 1, and the velocity at t = 0 (what the metrics measure
            // at the initial pose).
            for time in [1.0, 1e-3] {
                let x = displacement(&s, kind, time);
                for (name, m) in metrics() {
                    let e = relative_energy(m.as_ref(), &s, &x);
                    assert!(e > 0.1, "{shape} {kind} t = {time}: {name} relative energy {e}");
                }
            }
        }
    }
}

#[test]
fn the_eight_fields_are_pairwise_far_apart() {
    for shape in [InitialShape::Sphere, InitialShape::Ellipsoid] {
        let s = initial_shape(shape, &template(2));
        let areas = geometry::vertex_areas(&s.topology, &s.positions);
        // L2 inner product (eq. 11) of two fields.
        let ip = |a: &[[f64; 3]], b: &[[f64; 3]]| -> f64 {
            a.iter()
                .zip(b)
                .zip(&areas)
                .map(|((p, q), w)| w * geometry::dot(*p, *q))
                .sum()
        };
        let fields: Vec<Vec<[f64; 3]>> = DeformationKind::all()
            .iter()
            .map(|k| displacement(&s, *k, 1.0))
            .collect();
        let kinds = DeformationKind::all();
        for i in 0..fields.len() {
            for j in i + 1..fields.len() {
                let (a, b) = (&fields[i], &fields[j]);
                let cos = ip(a, b) / (ip(a, a) * ip(b, b)).sqrt();
                // Distance between the unit fields: sqrt(2 - 2 cos); sqrt(2) for orthogonal ones.
                let d = (2.0 - 2.0 * cos).sqrt();
                assert!(
                    d > 1.0,
                    "{shape}: {} and {} are close ({d:.3})",
                    kinds[i],
                    kinds[j]
                );
            }
        }
    }
}
