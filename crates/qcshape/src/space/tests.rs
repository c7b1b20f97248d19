//! Unit tests of [`super::ShapeSpace`] on the 42-vertex icosphere.

use super::*;
use crate::metric::MetricKind;
use crate::synth::icosphere;

fn pair() -> (Shape, Pose) {
    let a = icosphere(1);
    let b = a
        .positions
        .iter()
        .map(|p| [p[0] * (1.0 + 0.2 * p[2]), 0.8 * p[1], p[2] + 0.15 * p[0] * p[0]])
        .collect();
    (a, b)
}

fn space(kind: MetricKind, steps: usize) -> ShapeSpace {
    let a = icosphere(1);
    let geo = GeodesicOptions {
        steps,
        ..Default::default()
    };
    ShapeSpace::new(a.topology.clone(), MetricSpec::new(kind), geo)
        .unwrap()
        .normalized_to(&a.positions)
        .unwrap()
}

#[test]
fn dist_is_zero_on_the_diagonal_symmetric_and_positive() {
    let (a, b) = pair();
    for kind in [MetricKind::Isometric, MetricKind::QuasiConformal] {
        let s = space(kind, 4);
        assert_eq!(s.dist(&a.positions, &a.positions).unwrap(), 0.0);
        let (ab, ba) = (
            s.dist(&a.positions, &b).unwrap(),
            s.dist(&b, &a.positions).unwrap(),
        );
        assert!(ab > 0.0);
        assert!((ab - ba).abs() <= 1e-6 * ab, "{kind:?}: {ab} vs {ba}");
    }
}

#[test]
fn dist_equals_the_library_geodesic() {
    let (a, b) = pair();
    let s = ShapeSpace::new(
        a.topology.clone(),
        MetricSpec::new(MetricKind::Conformal),
        GeodesicOptions {
            steps: 3,
            ..Default::default()
        },
    )
    .unwrap();
    let sb = Shape::new(a.topology.clone(), b.clone()).unwrap();
    // Both ends' units, as `qcshape geodesic`: the same geodesic, in either order.
    let direct = geodesic::geodesic_between(
        &MetricSpec::new(MetricKind::Conformal),
        &a,
        &sb,
        s.geodesic_options(),
    )
    .unwrap();
    assert_eq!(s.geodesic(&a.positions, &b).unwrap().length, direct.length);
    let back = geodesic::geodesic_between(
        &MetricSpec::new(MetricKind::Conformal),
        &sb,
        &a,
        s.geodesic_options(),
    )
    .unwrap();
    let d = s.dist(&b, &a.positions).unwrap();
    assert!((d - back.length).abs() <= 1e-6 * d, "{d} vs {}", back.length);
}

#[test]
fn log_is_the_first_step_of_the_geodesic() {
    let (a, b) = pair();
    let s = space(MetricKind::Isometric, 4);
    let g = s.geodesic(&a.positions, &b).unwrap();
    let (log, d) = s.log(&a.positions, &b).unwrap();
    assert!((d - g.length).abs() <= 1e-9 * d);
    for ((p1, m), l) in g.poses[1].iter().zip(&a.positions).zip(&log) {
        for c in 0..3 {
            assert!((m[c] + l[c] / 4.0 - p1[c]).abs() < 1e-9, "{p1:?} {m:?} {l:?}");
        }
    }
    // And its squared norm is about the squared length (a geodesic has constant speed).
    let n2 = s.squared_norm(&a.positions, &log).unwrap();
    assert!((n2.sqrt() - d).abs() < 0.1 * d, "{} vs {d}", n2.sqrt());
}

#[test]
fn inner_polarizes_the_squared_norm() {
    let (a, b) = pair();
    let v: Pose = b
        .iter()
        .zip(&a.positions)
        .map(|(p, q)| [0, 1, 2].map(|c| p[c] - q[c]))
        .collect();
    for kind in [
        MetricKind::Isometric,
        MetricKind::QuasiConformal,
        MetricKind::Rigid,
    ] {
        // Exactly for the quadratic forms (no bending term); with the bending term the squared
        // norm charges the change of the dihedral angles from M to M + v and the inner product
        // its linearization at M: equal to second order in v.
        let quadratic = ShapeSpace::new(
            a.topology.clone(),
            MetricSpec {
                bending: 0.0,
                ..MetricSpec::new(kind)
            },
            GeodesicOptions {
                steps: 2,
                ..Default::default()
            },
        )
        .unwrap()
        .normalized_to(&a.positions)
        .unwrap();
        let n2 = quadratic.squared_norm(&a.positions, &v).unwrap();
        let ip = quadratic
            .inner(&a.positions, &v, &v, Some((&a.positions, &b)))
            .unwrap();
        assert!((n2 - ip).abs() <= 1e-8 * n2, "{kind:?}: {n2} vs {ip}");
        let s = space(kind, 2);
        let n2 = s.squared_norm(&a.positions, &v).unwrap();
        let ip = s.inner(&a.positions, &v, &v, Some((&a.positions, &b))).unwrap();
        assert!(
            (n2 - ip).abs() <= 1e-3 * n2,
            "{kind:?} with bending: {n2} vs {ip}"
        );
        let half: Pose = v.iter().map(|x| x.map(|c| 0.5 * c)).collect();
        let ih = s.inner(&a.positions, &v, &half, None).unwrap();
        let iv = s.inner(&a.positions, &v, &v, None).unwrap();
        assert!((2.0 * ih - iv).abs() <= 1e-10 * iv, "{kind:?}: bilinear");
    }
}

#[test]
fn transfer_to_its_own_base_is_the_deformation_and_transport_along_a_point_is_identity() {
    let (a, b) = pair();
    let s = space(MetricKind::QuasiConformal, 3);
    let poses = vec![a.positions.clone(), b.clone()];
    for method in [Transport::Parallel, Transport::Translate] {
        let t = s.transfer(&poses, &a.positions, method).unwrap();
        for (p, q) in t.poses[1].iter().zip(&b) {
            for c in 0..3 {
                assert!((p[c] - q[c]).abs() < 1e-9, "{method:?}: {p:?} vs {q:?}");
            }
        }
    }
    let v: Pose = b
        .iter()
        .zip(&a.positions)
        .map(|(p, q)| [0, 1, 2].map(|c| p[c] - q[c]))
        .collect();
    let w = s
        .transport(
            &[a.positions.clone(), a.positions.clone()],
            &v,
            Transport::Parallel,
        )
        .unwrap();
    for (p, q) in w.iter().zip(&v) {
        for c in 0..3 {
            assert!((p[c] - q[c]).abs() < 1e-12, "{p:?} vs {q:?}");
        }
    }
}

#[test]
fn karcher_mean_of_two_shapes_is_near_the_geodesic_midpoint() {
    let (a, b) = pair();
    let s = space(MetricKind::Isometric, 2);
    let m = s
        .karcher_mean(
            &[a.positions.clone(), b.clone()],
            None,
            &KarcherOptions::default(),
        )
        .unwrap();
    let g = s.geodesic(&a.positions, &b).unwrap();
    let (da, db) = (
        s.dist(&m.mean, &a.positions).unwrap(),
        s.dist(&m.mean, &b).unwrap(),
    );
    assert!((da - db).abs() < 0.05 * g.length, "{da} vs {db}");
    assert!(
        (da + db - g.length).abs() < 0.05 * g.length,
        "{da} + {db} vs {}",
        g.length
    );
}

#[test]
fn interpolation_keeps_key_poses_and_pairwise_matches_dist() {
    let (a, b) = pair();
    let s = space(MetricKind::Isometric, 2);
    let r = s
        .interpolate(&[a.positions.clone(), b.clone()], 1, 1, &|| {})
        .unwrap();
    assert_eq!(r.poses.len(), 3);
    assert_eq!(r.poses[0], a.positions);
    assert_eq!(r.poses[2], b);
    let d = s.pairwise_distances(&r.poses, None).unwrap();
    assert_eq!(d.len(), 9);
    assert_eq!(d[1], d[3]);
    assert_eq!(d[2], s.dist(&a.positions, &b).unwrap());
}

#[test]
fn bad_inputs_are_named() {
    let (a, _) = pair();
    let s = space(MetricKind::L2, 2);
    let short = &a.positions[1..];
    let e = s.dist(&a.positions, short).unwrap_err();
    assert!(e.to_string().contains("the second shape"), "{e}");
    let mut spec = MetricSpec::new(MetricKind::L2);
    spec.lambda = -1.0;
    assert!(ShapeSpace::new(a.topology.clone(), spec, GeodesicOptions::default()).is_err());
    let zero = GeodesicOptions {
        steps: 0,
        ..Default::default()
    };
    assert!(ShapeSpace::new(a.topology.clone(), MetricSpec::new(MetricKind::L2), zero).is_err());
    assert!(s.transport(&[], &a.positions, Transport::Parallel).is_err());
}

#[test]
fn space_is_shareable() {
    fn sync<T: Send + Sync + Clone + 'static>() {}
    sync::<ShapeSpace>();
}

#[test]
fn poses_of_very_different_sizes_are_recognized() {
    // Issue 60: a pose and the same pose scaled 1,000 x (millimetres against metres).
    let s = crate::synth::icosphere(1);
    let times = |f: f64| -> Vec<[f64; 3]> { s.positions.iter().map(|p| p.map(|c| c * f)).collect() };
    let (la, lb) = super::size_mismatch(&s.topology, &s.positions, &times(1000.0)).unwrap();
    assert!((lb / la - 1000.0).abs() < 1e-9, "{la} {lb}");
    assert!(super::size_mismatch(&s.topology, &times(1000.0), &s.positions).is_some());
    assert!(super::size_mismatch(&s.topology, &s.positions, &times(9.0)).is_none());
    assert!(super::size_mismatch(&s.topology, &s.positions, &times(11.0)).is_some());
}
