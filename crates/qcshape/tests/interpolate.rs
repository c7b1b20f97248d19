//! Temporal interpolation with spatial multiresolution (paper section 2.2.1).

use qcshape::geodesic::{
    interpolate_middle, interpolate_sequence, GeodesicOptions, GeodesicSolver, InterpolationOptions,
    Interpolator, Normalization,
};
use qcshape::mesh::{geometry, Shape};
use qcshape::metric::{FrozenL2, Isometric, Metric, Regularized};
use qcshape::multires::{Hierarchy, DEFAULT_RATIO};
use qcshape::synth::{icosphere, twist_along_z};

fn map(s: &Shape, f: impl Fn([f64; 3]) -> [f64; 3]) -> Vec<[f64; 3]> {
    s.positions.iter().map(|&p| f(p)).collect()
}

/// Twist about z by `angle * z` and stretch z by `stretch` ([`twist_along_z`] of one point).
fn twist(p: [f64; 3], angle: f64, stretch: f64) -> [f64; 3] {
    twist_along_z(&[p], angle, stretch)[0]
}

fn options(insert: usize, levels: usize) -> InterpolationOptions {
    InterpolationOptions {
        insert,
        levels,
        geodesic: GeodesicOptions {
            gradient_tolerance: 1e-8,
            ..Default::default()
        },
        ..Default::default()
    }
}

#[test]
fn counts_and_exact_key_poses() {
    let s = icosphere(2);
    let keys = vec![
        s.positions.clone(),
        map(&s, |p| twist(p, 0.4, 1.2)),
        map(&s, |p| twist(p, 0.8, 1.4)),
    ];
    let metric = Regularized::new(Box::new(Isometric), 0.1);
    for n in [1, 3, 7] {
        let out = interpolate_sequence(&metric, &s.topology, &keys, &options(n, 2)).unwrap();
        assert_eq!(out.poses.len(), 2 * (n + 1) + 1, "n = {n}");
        assert_eq!(out.segment_lengths.len(), 2 * (n + 1));
        assert_eq!(out.pairs.len(), 2);
        let key_at: Vec<usize> = (0..out.poses.len()).filter(|&i| out.is_key[i]).collect();
        assert_eq!(key_at, vec![0, n + 1, 2 * (n + 1)]);
        for (k, &i) in key_at.iter().enumerate() {
            assert_eq!(out.poses[i], keys[k], "key pose {k} not bit-exact");
        }
        for p in &out.pairs {
            assert!(p.converged && p.energy.is_finite() && p.energy > 0.0);
            assert_eq!(p.levels.len(), 2);
            assert!(p.levels[0].vertices < p.levels[1].vertices);
        }
        // A geodesic has (nearly) constant speed.
        let seg = &out.segment_lengths[..n + 1];
        let mean = seg.iter().sum::<f64>() / seg.len() as f64;
        assert!(
            seg.iter().all(|l| (l - mean).abs() < 0.05 * mean),
            "n = {n}: {seg:?}"
        );
    }
}

#[test]
fn insert_zero_is_the_identity() {
    let s = icosphere(1);
    let keys = vec![
        s.positions.clone(),
        map(&s, |p| twist(p, 0.5, 1.3)),
        map(&s, |p| twist(p, 1.0, 1.0)),
    ];
    let out = interpolate_sequence(&FrozenL2, &s.topology, &keys, &options(0, 3)).unwrap();
    assert_eq!(out.poses, keys);
    assert!(out.is_key.iter().all(|&k| k));
    assert_eq!(out.segment_lengths.len(), 2);
    assert!(out.segment_lengths.iter().all(|&l| l > 0.0));
}

/// Sphere to a uniformly scaled sphere: every interior pose is (nearly) a sphere, with radii
/// increasing strictly between the two.
#[test]
fn scaled_sphere_interior_poses_lie_between() {
    let s = icosphere(2);
    let big = 1.6;
    let keys = vec![s.positions.clone(), map(&s, |p| p.map(|c| big * c))];
    let metrics: [Box<dyn Metric>; 2] = [
        Box::new(FrozenL2),
        Box::new(Regularized::new(Box::new(Isometric), 0.1)),
    ];
    for metric in &metrics {
        for levels in [1, 2] {
            let out = interpolate_sequence(metric.as_ref(), &s.topology, &keys, &options(3, levels)).unwrap();
            let mut prev = 1.0;
            for (i, pose) in out.poses.iter().enumerate().skip(1).take(3) {
                let radii: Vec<f64> = pose.iter().map(|&p| geometry::norm(p)).collect();
                let mean = radii.iter().sum::<f64>() / radii.len() as f64;
                let spread = radii.iter().map(|r| (r - mean).abs()).fold(0.0, f64::max);
                // Vertices of different symmetry orbits may move by slightly different amounts.
                assert!(
                    spread < 1e-2 * mean,
                    "{} pose {i}: radii spread {spread}",
                    metric.name()
                );
                assert!(
                    mean > prev + 0.05 && mean < big - 0.05,
                    "{} pose {i}: {mean}",
                    metric.name()
                );
                prev = mean;
            }
            if metric.name().starts_with("l2") {
                // The frozen L2 metric is constant along the path: the geodesic is linear.
                for (i, pose) in out.poses.iter().enumerate() {
                    let r = 1.0 + (big - 1.0) * i as f64 / 4.0;
                    for (p, q) in pose.iter().zip(&s.positions) {
                        assert!(geometry::norm(geometry::sub(*p, q.map(|c| r * c))) < 1e-6);
                    }
                }
            }
        }
    }
}

#[test]
fn multiresolution_reaches_the_single_level_energy() {
    let s = icosphere(3);
    let b = map(&s, |p| twist(p, 1.2, 1.5));
    let metric = Regularized::new(Box::new(Isometric), 0.1);
    let opts = options(3, 3);
    let ip = Interpolator::new(&metric, &s.topology, &s.positions, opts.clone()).unwrap();
    assert_eq!(ip.hierarchy().n_levels(), 3, "{:?}", ip.hierarchy().stopped());
    let multi = ip.interpolate(&s.positions, &b).unwrap();
    // Single level, N = 4, from the linear start, in the same scale.
    let f = multi.scale;
    let scaled = |p: &[[f64; 3]]| p.iter().map(|v| v.map(|c| c * f)).collect::<Vec<_>>();
    let single = GeodesicSolver::new(
        &metric,
        s.topology.clone(),
        GeodesicOptions {
            steps: 4,
            ..opts.geodesic.clone()
        },
    )
    .unwrap()
    .solve(&scaled(&s.positions), &scaled(&b))
    .unwrap();
    assert!(single.converged && multi.stats.converged);
    assert!(
        multi.stats.energy <= 1.01 * single.energy,
        "multires {} vs single {}",
        multi.stats.energy,
        single.energy
    );
    // And the paths agree (mean vertex distance).
    for i in 1..4 {
        let d = multi.poses[i]
            .iter()
            .zip(&single.poses[i])
            .map(|(p, q)| geometry::norm(geometry::sub(p.map(|c| c * f), *q)))
            .sum::<f64>()
            / 642.0;
        // Within 2% of the sphere's radius (f in scaled units).
        assert!(d < 0.02 * f, "pose {i}: {d} (radius {f})");
    }
}

#[test]
fn prolonging_a_linear_coarse_path_gives_the_fine_linear_path() {
    let s = icosphere(3);
    let b = map(&s, |p| twist(p, 0.9, 1.3));
    let h = Hierarchy::new(&s.topology, &s.positions, 2, DEFAULT_RATIO).unwrap();
    let coarse = h.level(1);
    let (ca, cb) = (coarse.restrict(&s.positions), coarse.restrict(&b));
    let n = 5;
    let lin = |p: &[[f64; 3]], q: &[[f64; 3]], t: f64| -> Vec<[f64; 3]> {
        p.iter()
            .zip(q)
            .map(|(x, y)| [0, 1, 2].map(|c| (1.0 - t) * x[c] + t * y[c]))
            .collect()
    };
    let coarse_path: Vec<Vec<[f64; 3]>> = (1..n).map(|i| lin(&ca, &cb, i as f64 / n as f64)).collect();
    let fine = h
        .prolongation(0)
        .prolong_path(&s.positions, &b, &ca, &cb, &coarse_path);
    assert_eq!(fine.len(), n - 1);
    for (i, pose) in fine.iter().enumerate() {
        let expect = lin(&s.positions, &b, (i + 1) as f64 / n as f64);
        for (p, q) in pose.iter().zip(&expect) {
            assert!(geometry::norm(geometry::sub(*p, *q)) < 1e-12);
        }
    }
    // A coarse correction moves kept vertices by exactly that correction.
    let mut bumped = coarse_path.clone();
    bumped[0][0][2] += 0.25;
    let fine = h
        .prolongation(0)
        .prolong_path(&s.positions, &b, &ca, &cb, &bumped);
    let v = coarse.fine_ids[0] as usize;
    assert_eq!(fine[0][v], bumped[0][0]);
}

#[test]
fn middle_of_a_linear_deformation_is_recovered_by_l2() {
    let s = icosphere(2);
    let last = map(&s, |p| twist(p, 0.7, 1.4));
    let middle: Vec<[f64; 3]> = s
        .positions
        .iter()
        .zip(&last)
        .map(|(p, q)| geometry::scale(geometry::add(*p, *q), 0.5))
        .collect();
    let r = interpolate_middle(
        &FrozenL2,
        &s.topology,
        &s.positions,
        &middle,
        &last,
        &options(5, 2),
    )
    .unwrap();
    assert_eq!(r.errors.len(), 162);
    assert!(r.max < 1e-6 * r.diagonal, "{}", r.max);
    // The isometric metric bends the path: a measurable error.
    let iso = Regularized::new(Box::new(Isometric), 0.1);
    let r = interpolate_middle(&iso, &s.topology, &s.positions, &middle, &last, &options(1, 2)).unwrap();
    assert!(
        r.mean > 1e-4 * r.diagonal && r.mean < 0.2 * r.diagonal,
        "{}",
        r.mean
    );
    assert!(r.rms >= r.mean && r.max >= r.rms);
}

#[test]
fn bad_inputs_are_errors() {
    let s = icosphere(1);
    let other = icosphere(2);
    let err = interpolate_sequence(
        &FrozenL2,
        &s.topology,
        &[s.positions.clone(), other.positions.clone()],
        &options(1, 1),
    )
    .unwrap_err();
    assert!(err.to_string().contains("42"), "{err}");
    assert!(interpolate_sequence(&FrozenL2, &s.topology, &[], &options(1, 1)).is_err());
    assert!(interpolate_sequence(
        &FrozenL2,
        &s.topology,
        std::slice::from_ref(&s.positions),
        &options(1, 0)
    )
    .is_err());
    let mut o = options(1, 1);
    o.normalization = Normalization::Factor(-1.0);
    assert!(interpolate_sequence(
        &FrozenL2,
        &s.topology,
        &[s.positions.clone(), s.positions.clone()],
        &o
    )
    .is_err());
    // A single key pose is returned as is.
    let one = interpolate_sequence(
        &FrozenL2,
        &s.topology,
        std::slice::from_ref(&s.positions),
        &options(3, 1),
    )
    .unwrap();
    assert_eq!(one.poses, vec![s.positions.clone()]);
}
