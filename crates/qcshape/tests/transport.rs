//! Discrete parallel transport, Schild's ladder and deformation transfer (issue 3, items 1-3).
#![allow(clippy::needless_range_loop)]

use std::sync::Arc;

use qcshape::geodesic::{GeodesicOptions, GeodesicSolver, Normalization};
use qcshape::mesh::{geometry, Shape, Topology};
use qcshape::metric::{At, Calibration, ConformalForm, MetricKind, MetricSpec, QcWeights, Segment};
use qcshape::synth::icosphere;
use qcshape::transport::{
    parallel_transport, schild_ladder, transfer, ParallelOptions, SchildOptions, TransferOptions,
    TransferSetup, Transport, TransportError, TransportMetric,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

type Pose = Vec<[f64; 3]>;

fn map(s: &Shape, f: impl Fn([f64; 3]) -> [f64; 3]) -> Shape {
    Shape::new(s.topology.clone(), s.positions.iter().map(|&p| f(p)).collect()).unwrap()
}

fn ellipsoid(s: &Shape) -> Shape {
    map(s, |p| [1.3 * p[0], p[1], 0.8 * p[2]])
}

/// Twist about z by `k` radians per unit height, then stretch z by `1 + e`, then bend x by `b z^2`.
fn twist_bend(p: [f64; 3], k: f64, e: f64, b: f64) -> [f64; 3] {
    let a = k * p[2];
    let (c, si) = (a.cos(), a.sin());
    [
        c * p[0] - si * p[1] + b * p[2] * p[2],
        si * p[0] + c * p[1],
        (1.0 + e) * p[2],
    ]
}

/// A deformation of `s` with `k + 1` poses: twisting, stretching and bending progressively.
fn deformation(s: &Shape, k: usize) -> Vec<Shape> {
    (0..=k)
        .map(|i| {
            let t = i as f64 / k as f64;
            map(s, |p| twist_bend(p, 0.5 * t, 0.2 * t, 0.15 * t))
        })
        .collect()
}

fn scaled(p: &[[f64; 3]], f: f64) -> Pose {
    p.iter().map(|v| v.map(|c| c * f)).collect()
}

fn random_field(n: usize, rng: &mut ChaCha8Rng) -> Pose {
    (0..n)
        .map(|_| [0; 3].map(|_| rng.random_range(-1.0..1.0)))
        .collect()
}

fn add(a: &[[f64; 3]], b: &[[f64; 3]], s: f64) -> Pose {
    a.iter()
        .zip(b)
        .map(|(p, q)| [p[0] + s * q[0], p[1] + s * q[1], p[2] + s * q[2]])
        .collect()
}

fn max_dist(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(p, q)| geometry::norm(geometry::sub(*p, *q)))
        .fold(0.0, f64::max)
}

fn spec(kind: MetricKind, lambda: f64) -> MetricSpec {
    MetricSpec {
        lambda,
        ..MetricSpec::previous(kind)
    }
}

fn all_specs() -> Vec<MetricSpec> {
    let mut v = vec![
        spec(MetricKind::L2, 0.0),
        MetricSpec {
            frozen_areas: false,
            ..spec(MetricKind::L2, 0.0)
        },
        spec(MetricKind::Rigid, 0.0),
        spec(MetricKind::Rigid, 0.2),
        spec(MetricKind::Isometric, 0.0),
        spec(MetricKind::Isometric, 0.1),
        spec(MetricKind::Conformal, 0.1),
        spec(MetricKind::QuasiConformal, 0.0),
        spec(MetricKind::QuasiConformal, 0.1),
    ];
    // The paper form and the segment weights go through the quadratic companion.
    let mut paper = spec(MetricKind::QuasiConformal, 0.1);
    paper.form = ConformalForm::Paper;
    paper.weights = QcWeights::Segment;
    v.push(paper);
    v
}

#[test]
fn operator_matches_the_polarization_of_squared_norm() {
    let s = icosphere(1);
    let f = 1.0 / geometry::mean_edge_length(&s.topology, &s.positions);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let pose = add(
        &scaled(&s.positions, f),
        &random_field(s.n_vertices(), &mut rng),
        0.1,
    );
    let end = scaled(&ellipsoid(&s).positions, f);
    for sp in all_specs() {
        let tm = TransportMetric::new(&sp, &Calibration::RAW, s.topology.clone());
        let frozen = tm.frozen_weights(&pose, &end);
        let g = tm.at(&pose, frozen.as_deref()).unwrap();
        let sq = |x: &[[f64; 3]]| {
            let b = add(&pose, x, 1.0);
            let seg = Segment {
                a: &pose,
                b: &b,
                at: At::Start,
                aux: &[],
                frozen: frozen.as_deref(),
            };
            tm.metric().squared_norm(&s.topology, tm.pattern(), &seg)
        };
        for _ in 0..3 {
            let u = random_field(s.n_vertices(), &mut rng);
            let v = random_field(s.n_vertices(), &mut rng);
            let (gp, gm) = (sq(&add(&u, &v, 1.0)), sq(&add(&u, &v, -1.0)));
            let polar = (gp - gm) / 4.0;
            let op = g.inner(&u, &v);
            let rel = (op - polar).abs() / ((gp.abs() + gm.abs()) / 4.0);
            assert!(
                rel < 1e-9,
                "{}: {op} vs {polar} (rel {rel:e})",
                tm.metric().name()
            );
            // The norm and the operator G v agree with the inner product.
            let nu = g.squared_norm(&u);
            assert!(
                (nu - sq(&u)).abs() <= 1e-9 * nu.abs().max(1e-300),
                "{}",
                tm.metric().name()
            );
            let mut gv = vec![0.0; g.dim()];
            g.apply(v.as_flattened(), &mut gv);
            let ugv: f64 = u.as_flattened().iter().zip(&gv).map(|(a, b)| a * b).sum();
            assert!(
                (ugv - op).abs() <= 1e-10 * (gp.abs() + gm.abs()),
                "{}",
                tm.metric().name()
            );
        }
    }
}

#[test]
fn transport_along_a_zero_length_curve_is_the_identity() {
    let s = ellipsoid(&icosphere(2));
    let f = 1.0 / geometry::mean_edge_length(&s.topology, &s.positions);
    let p = scaled(&s.positions, f);
    let curve = vec![p.clone(); 5];
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let v0 = random_field(s.n_vertices(), &mut rng);
    for sp in [
        spec(MetricKind::QuasiConformal, 0.1),
        spec(MetricKind::Rigid, 0.0),
    ] {
        let tm = TransportMetric::new(&sp, &Calibration::RAW, s.topology.clone());
        let t = parallel_transport(&tm, &curve, &v0, &ParallelOptions::default()).unwrap();
        assert_eq!(t.steps.len(), 4);
        assert!(max_dist(&t.vector, &v0) <= 1e-14, "{}", max_dist(&t.vector, &v0));
        assert!(t.steps.iter().all(|d| !d.tangent_constraint));
    }
    // A curve of rounding noise (samples agreeing to ~1e-15 relative, as for the geodesic
    // between two poses that differ only in the last bits) is constant too.
    let noisy: Vec<Pose> = (0..5)
        .map(|k| {
            p.iter()
                .enumerate()
                .map(|(i, v)| v.map(|c| c * (1.0 + 1e-15 * (((i * 7 + k * 13) % 5) as f64 - 2.0))))
                .collect()
        })
        .collect();
    let tm = TransportMetric::new(
        &spec(MetricKind::QuasiConformal, 0.1),
        &Calibration::RAW,
        s.topology.clone(),
    );
    let t = parallel_transport(&tm, &noisy, &v0, &ParallelOptions::default()).unwrap();
    assert!(max_dist(&t.vector, &v0) <= 1e-14, "{}", max_dist(&t.vector, &v0));
    // Zero vector stays zero, along any curve.
    let tm = TransportMetric::new(
        &spec(MetricKind::Isometric, 0.1),
        &Calibration::RAW,
        s.topology.clone(),
    );
    let curve = vec![p.clone(), scaled(&icosphere(2).positions, f)];
    let zero = vec![[0.0; 3]; s.n_vertices()];
    let t = parallel_transport(&tm, &curve, &zero, &ParallelOptions::default()).unwrap();
    assert!(t.vector.iter().flatten().all(|c| *c == 0.0));
}

/// The geodesic from the unit icosphere(2) to an ellipsoid in normalized units.
fn sphere_to_ellipsoid(sp: &MetricSpec, steps: usize) -> (Arc<Topology>, Vec<Pose>) {
    let a = icosphere(2);
    let b = ellipsoid(&a);
    let f = 1.0 / geometry::mean_edge_length(&a.topology, &a.positions);
    let metric = sp.build(&Calibration::RAW);
    let solver = GeodesicSolver::new(
        metric.as_ref(),
        a.topology.clone(),
        GeodesicOptions {
            steps,
            ..Default::default()
        },
    )
    .unwrap();
    let g = solver
        .solve(&scaled(&a.positions, f), &scaled(&b.positions, f))
        .unwrap();
    assert!(g.converged, "{:?}", g.stop);
    (a.topology.clone(), g.poses)
}

#[test]
fn transport_along_a_geodesic_keeps_the_inner_product_and_the_norm() {
    let tol = 1e-9;
    for sp in [
        spec(MetricKind::Isometric, 0.0),
        spec(MetricKind::QuasiConformal, 0.1),
    ] {
        let (topo, curve) = sphere_to_ellipsoid(&sp, 6);
        let nv = topo.n_vertices();
        let s0 = &curve[0];
        let v0: Pose = s0
            .iter()
            .map(|&p| geometry::sub(twist_bend(p, 0.02, 0.01, 0.005), p))
            .collect();
        let tm = TransportMetric::new(&sp, &Calibration::RAW, topo.clone());
        let t = parallel_transport(&tm, &curve, &v0, &ParallelOptions::default()).unwrap();
        assert_eq!(t.along.len(), curve.len());
        let frozen = tm.frozen_weights(&curve[0], &curve[curve.len() - 1]);
        let (a0, n0) = (t.initial_inner, t.initial_norm);
        assert!(n0 > 0.0 && a0.abs() > 0.0);
        let mut moved = 0.0f64;
        for j in 1..curve.len() {
            // Check afresh, independently of the step's own diagnostics.
            let g = tm.at(&curve[j], frozen.as_deref()).unwrap();
            let tangent = add(&curve[j], &curve[j - 1], -1.0);
            let v = &t.along[j];
            let cs = (n0 * g.squared_norm(&tangent)).sqrt();
            let inner_err = (g.inner(v, &tangent) - a0).abs() / cs;
            let norm_err = (g.squared_norm(v) - n0).abs() / n0;
            assert!(
                inner_err < tol && norm_err < tol,
                "{}: step {j}: {inner_err:e} {norm_err:e}",
                sp.kind_name()
            );
            assert!(t.steps[j - 1].inner_residual < tol && t.steps[j - 1].norm_residual < tol);
            moved = moved.max(max_dist(v, &v0));
        }
        // Not an empty test: V_0 itself violates the norm constraint at S_J by far more.
        let j = curve.len() - 1;
        let g = tm.at(&curve[j], frozen.as_deref()).unwrap();
        let identity_err = (g.squared_norm(&v0) - n0).abs() / n0;
        assert!(identity_err > 1e4 * tol, "{}: {identity_err:e}", sp.kind_name());
        let scale = v0.iter().map(|p| geometry::norm(*p)).fold(0.0, f64::max);
        println!(
            "{}: max residuals inner {:.2e} norm {:.2e}; V_0's norm drift {identity_err:.2e}; \
             |V_J - V_0|/|V_0|_inf = {:.3e}; newton {:?}",
            tm.metric().name(),
            t.max_inner_residual(),
            t.max_norm_residual(),
            moved / scale,
            t.steps.iter().map(|s| s.newton_iterations).collect::<Vec<_>>()
        );
        assert_eq!(nv, v0.len());
    }
}

trait KindName {
    fn kind_name(&self) -> String;
}
impl KindName for MetricSpec {
    fn kind_name(&self) -> String {
        format!("{:?}(lambda {})", self.kind, self.lambda)
    }
}

#[test]
fn a_metric_null_space_is_carried_exactly() {
    // Translations are in the null space of the isometric metric at every pose: a translation
    // keeps its (zero) norm and is transported unchanged.
    let sp = spec(MetricKind::Isometric, 0.0);
    let (topo, curve) = sphere_to_ellipsoid(&sp, 4);
    let tm = TransportMetric::new(&sp, &Calibration::RAW, topo.clone());
    let v0 = vec![[0.3, -0.2, 0.1]; topo.n_vertices()];
    let t = parallel_transport(&tm, &curve, &v0, &ParallelOptions::default()).unwrap();
    assert_eq!(t.initial_norm, 0.0);
    assert!(max_dist(&t.vector, &v0) < 1e-12, "{}", max_dist(&t.vector, &v0));
    // An infinitesimal rotation about z is a null vector at S_0 but not at the other samples;
    // each step goes to the closest null vector there (the limit mu -> inf), so the result
    // is (to the CG tolerance) a null vector of the last sample.
    let v0: Pose = curve[0].iter().map(|p| [-p[1], p[0], 0.0]).collect();
    let t = parallel_transport(&tm, &curve, &v0, &ParallelOptions::default()).unwrap();
    let j = curve.len() - 1;
    let g = tm.at(&curve[j], None).unwrap();
    let (before, after) = (g.squared_norm(&v0), g.squared_norm(&t.vector));
    let norm = |v: &[[f64; 3]]| v.iter().flatten().map(|c| c * c).sum::<f64>().sqrt();
    println!(
        "rotation: G_SJ(V_0) {before:.3e}, G_SJ(V_J) {after:.3e}, |V_J|/|V_0| {:.4}, steps {:?}",
        norm(&t.vector) / norm(&v0),
        t.steps
            .iter()
            .map(|s| (s.multiplier, s.cg_iterations))
            .collect::<Vec<_>>()
    );
    assert!(before > 1.0 && after < 1e-10 * before, "{before:e} -> {after:e}");
    assert!(t.max_norm_residual() < 1e-12, "{}", t.max_norm_residual());
    assert!((norm(&t.vector) / norm(&v0) - 1.0).abs() < 0.2);
}

fn options(steps: usize, factor: f64) -> TransferOptions {
    TransferOptions {
        geodesic: GeodesicOptions {
            steps,
            ..Default::default()
        },
        normalization: Normalization::Factor(factor),
        ..Default::default()
    }
}

#[test]
fn euclidean_transfer_is_exactly_the_translated_deformation() {
    let a = icosphere(1);
    let b = ellipsoid(&a);
    let m = deformation(&a, 3);
    let out = transfer(
        &spec(MetricKind::QuasiConformal, 0.1),
        &m,
        &b,
        Transport::Translate,
        &TransferOptions::default(),
    )
    .unwrap();
    assert_eq!(out.poses.len(), 4);
    assert_eq!(out.segments.len(), 3);
    for (k, n) in out.poses.iter().enumerate() {
        for v in 0..a.n_vertices() {
            let want = [0, 1, 2].map(|c| b.positions[v][c] + (m[k].positions[v][c] - m[0].positions[v][c]));
            assert_eq!(n[v], want);
        }
    }
}

#[test]
fn transfer_to_b_and_back_returns_the_deformation() {
    let a = icosphere(2);
    let b = ellipsoid(&a);
    let m = deformation(&a, 3);
    let f = 1.0 / geometry::mean_edge_length(&a.topology, &a.positions);
    for sp in [
        spec(MetricKind::QuasiConformal, 0.1),
        spec(MetricKind::Isometric, 0.1),
    ] {
        round_trip(&a, &b, &m, f, &sp);
    }
}

fn round_trip(a: &Shape, b: &Shape, m: &[Shape], f: f64, sp: &MetricSpec) {
    let opts = options(8, f);
    let setup = TransferSetup::new(sp, &Calibration::RAW, a.topology.clone(), opts).unwrap();
    let solver = setup.solver().unwrap();
    let there = solver.run_shapes(m, b, Transport::Parallel).unwrap();
    let euclid = solver.run_shapes(m, b, Transport::Translate).unwrap();
    let n: Vec<Shape> = there
        .poses
        .iter()
        .map(|p| Shape::new(a.topology.clone(), p.clone()).unwrap())
        .collect();
    let back = solver.run_shapes(&n, &m[0], Transport::Parallel).unwrap();
    let size = max_dist(&m[3].positions, &m[0].positions);
    let mut round_trip = 0.0f64;
    let mut vs_euclid = 0.0f64;
    for k in 0..m.len() {
        round_trip = round_trip.max(max_dist(&back.poses[k], &m[k].positions) / size);
        vs_euclid = vs_euclid.max(max_dist(&there.poses[k], &euclid.poses[k]) / size);
    }
    for s in there.segments.iter().chain(&back.segments) {
        assert!(s.geodesic_converged);
        assert!(s.max_inner_residual < 1e-9 && s.max_norm_residual < 1e-9, "{s:?}");
        assert!((s.output_norm - s.input_norm).abs() <= 1e-9 * s.input_norm);
    }
    println!(
        "{}: round trip {round_trip:.3e}, parallel vs euclidean {vs_euclid:.3e} (relative to the deformation's \
         size {size:.3}); seconds {:.2} + {:.2}",
        setup.metric().name(),
        there.seconds,
        back.seconds
    );
    // Stated tolerance (J = 8 transport steps): 1% of the deformation's size, and under 15% of
    // the transfer's own effect (its distance from Euclidean transfer). The discrete transport
    // is not exactly reversible: measured, the round trip error falls like 1/J (isometric +
    // 0.1 L2: 9.4e-3, 4.7e-3, 2.5e-3, 1.3e-3 for J = 2, 4, 8, 16).
    assert!(round_trip < 1e-2, "{round_trip:e}");
    assert!(round_trip < 0.15 * vs_euclid, "{round_trip:e} vs {vs_euclid:e}");
}

#[test]
fn on_a_flat_metric_parallel_and_schild_equal_euclidean() {
    // L2 with frozen areas is a constant quadratic form along each geodesic: straight geodesics,
    // and transport is the identity.
    let a = icosphere(1);
    let b = ellipsoid(&a);
    let m = deformation(&a, 2);
    let f = 1.0 / geometry::mean_edge_length(&a.topology, &a.positions);
    let sp = spec(MetricKind::L2, 0.0);
    let setup = TransferSetup::new(&sp, &Calibration::RAW, a.topology.clone(), options(3, f)).unwrap();
    let solver = setup.solver().unwrap();
    let e = solver.run_shapes(&m, &b, Transport::Translate).unwrap();
    let size = max_dist(&m[2].positions, &m[0].positions);
    for method in [Transport::Parallel, Transport::Schild] {
        let t = solver.run_shapes(&m, &b, method).unwrap();
        for k in 0..m.len() {
            let d = max_dist(&t.poses[k], &e.poses[k]) / size;
            assert!(d < 1e-8, "{method:?} pose {k}: {d:e}");
        }
    }
}

#[test]
fn schild_ladder_nearly_keeps_the_norm_on_a_riemannian_metric() {
    // The isometric metric without regularizer has no frozen weights: one metric for the path
    // and for every rung, so Schild's ladder approximates Levi-Civita transport, which keeps
    // the norm.
    let sp = spec(MetricKind::Isometric, 0.0);
    let (topo, curve) = sphere_to_ellipsoid(&sp, 4);
    let metric = sp.build(&Calibration::RAW);
    let solver2 = GeodesicSolver::new(
        metric.as_ref(),
        topo.clone(),
        GeodesicOptions {
            steps: 2,
            ..Default::default()
        },
    )
    .unwrap();
    let v0: Pose = curve[0]
        .iter()
        .map(|&p| geometry::sub(twist_bend(p, 0.02, 0.01, 0.005), p))
        .collect();
    let tm = TransportMetric::new(&sp, &Calibration::RAW, topo.clone());
    let par = parallel_transport(&tm, &curve, &v0, &ParallelOptions::default()).unwrap();
    let sch = schild_ladder(&solver2, &curve, &v0, &SchildOptions::default()).unwrap();
    assert_eq!(sch.rungs.len(), 4);
    assert!(sch.rungs.iter().all(|r| r.converged && r.geodesics == 3));
    let g = tm.at(&curve[4], None).unwrap();
    let n0 = par.initial_norm;
    let drift = |v: &[[f64; 3]]| (g.squared_norm(v) - n0).abs() / n0;
    let scale = v0.iter().map(|p| geometry::norm(*p)).fold(0.0, f64::max);
    println!(
        "norm drift at S_J: identity {:.3e}, Schild {:.3e}, parallel {:.1e}; |Schild - parallel| {:.3e}, \
         |parallel - V_0| {:.3e} (relative to |V_0|_inf)",
        drift(&v0),
        drift(&sch.vector),
        drift(&par.vector),
        max_dist(&sch.vector, &par.vector) / scale,
        max_dist(&par.vector, &v0) / scale
    );
    assert!(drift(&sch.vector) < 0.05 * drift(&v0));
    // A solver with N != 2 is refused.
    let bad = GeodesicSolver::new(metric.as_ref(), topo, GeodesicOptions::default()).unwrap();
    assert!(matches!(
        schild_ladder(&bad, &curve, &v0, &SchildOptions::default()),
        Err(TransportError::SchildSteps { steps: 8 })
    ));
}

#[test]
fn mismatched_topology_is_a_clear_error() {
    let a = icosphere(1);
    let m = deformation(&a, 2);
    let sp = spec(MetricKind::Isometric, 0.1);
    let other = icosphere(2);
    let err = transfer(&sp, &m, &other, Transport::Parallel, &TransferOptions::default()).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, TransportError::Mismatch { .. }), "{msg}");
    assert!(msg.contains("pose 0") && msg.contains("42"), "{msg}");
    // Same vertex count, different faces (one face's corners rotated).
    let mut faces = a.topology.faces().to_vec();
    faces[5] = [faces[5][1], faces[5][2], faces[5][0]];
    let topo = Topology::new(a.n_vertices(), faces).unwrap();
    let base = Shape::new(topo, a.positions.clone()).unwrap();
    let err = transfer(&sp, &m, &base, Transport::Translate, &TransferOptions::default()).unwrap_err();
    assert!(err.to_string().contains("face 5"), "{err}");
    // Wrong vertex counts through the pose API.
    let setup = TransferSetup::new(
        &sp,
        &Calibration::RAW,
        a.topology.clone(),
        TransferOptions::default(),
    )
    .unwrap();
    let solver = setup.solver().unwrap();
    let short = vec![a.positions.clone(), a.positions[..10].to_vec()];
    let err = solver.run(&short, &a.positions, Transport::Parallel).unwrap_err();
    assert!(
        matches!(err, TransportError::VertexCount { got: 10, expected, .. } if expected == a.n_vertices()),
        "{err:?}"
    );
}
