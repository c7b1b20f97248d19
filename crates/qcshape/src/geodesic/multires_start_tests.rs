//! A coarse-to-fine start for the default geodesic (a study, run on demand:
//! `MULTIRES_LEVELS=3,4,5 cargo test --release -p qcshape --lib multires_start -- --ignored
//! --nocapture`; docs/log/bending.md "The bending kernel's cost", its coarse-to-fine table).
//!
//! The default takes 19 / 28 / 54 iterations on the twisted sphere at 642 / 2,562 / 10,242
//! vertices, and the preconditioned spectrum says why: the Kronecker model fitted at the linear
//! start is far worse there (kappa 3,091 at 10,242 vertices) than at the geodesic (177). This
//! study starts the fine solve from the geodesic of a coarser level of the mesh hierarchy
//! ([`crate::multires::Hierarchy`], the temporal interpolation's), prolonged
//! ([`crate::multires::Prolongation::prolong_path`]), level by level, and reports the
//! iterations of each level and the seconds, against the direct solve from the linear start.

use super::preconditioned_spectrum_tests::env_list;
use super::*;
use crate::mesh::geometry::scaled;
use crate::metric::{MetricKind, MetricSpec};
use crate::multires::Hierarchy;

#[test]
#[ignore = "a study: prints a table; minutes at 10,242 vertices"]
fn multires_start_study() {
    let levels: Vec<u32> = env_list("MULTIRES_LEVELS", vec![3, 4]);
    let depths: Vec<usize> = env_list("MULTIRES_DEPTHS", vec![2, 3]);
    let kinds = [
        MetricKind::Isometric,
        MetricKind::Conformal,
        MetricKind::QuasiConformal,
    ];
    println!(
        "| vertices | metric | direct: iterations, s | hierarchy levels (vertices) | iterations per level, \
         coarse first | s | energy / direct's - 1 | rms pose difference (mean edges) |"
    );
    for level in levels {
        let (a, b) = crate::synth::twisted_sphere(level);
        for kind in kinds {
            let spec = MetricSpec::new(kind);
            let opts = GeodesicOptions::default();
            // The direct solve at the finest level.
            let (metric, f) = pair_metric(&spec, &a, &b).unwrap();
            let solver = GeodesicSolver::new(metric.as_ref(), a.topology.clone(), opts.clone()).unwrap();
            let (fa, fb) = (scaled(&a.positions, f), scaled(&b.positions, f));
            let t0 = std::time::Instant::now();
            let direct = solver.solve(&fa, &fb).unwrap();
            let direct_s = t0.elapsed().as_secs_f64();
            for &depth in &depths {
                let h =
                    Hierarchy::new(&a.topology, &a.positions, depth, crate::multires::DEFAULT_RATIO).unwrap();
                let t0 = std::time::Instant::now();
                let mut its = Vec::new();
                // Interior poses of the last solved level, in input units.
                let mut path: Option<Vec<Vec<[f64; 3]>>> = None;
                let mut last = None;
                for l in (0..h.n_levels()).rev() {
                    let lv = h.level(l);
                    let (la, lb) = (lv.restrict(&a.positions), lv.restrict(&b.positions));
                    let sa = crate::mesh::Shape::new(lv.topology.clone(), la.clone()).unwrap();
                    let sb = crate::mesh::Shape::new(lv.topology.clone(), lb.clone()).unwrap();
                    let (m, fl) = pair_metric(&spec, &sa, &sb).unwrap();
                    let s = GeodesicSolver::new(m.as_ref(), lv.topology.clone(), opts.clone()).unwrap();
                    let (ta, tb) = (scaled(&la, fl), scaled(&lb, fl));
                    let g = match &path {
                        None => s.solve(&ta, &tb).unwrap(),
                        Some(coarse) => {
                            let c = h.level(l + 1);
                            let (ca, cb) = (c.restrict(&a.positions), c.restrict(&b.positions));
                            let start = h.prolongation(l).prolong_path(&la, &lb, &ca, &cb, coarse);
                            let start: Vec<_> = start.iter().map(|p| scaled(p, fl)).collect();
                            s.solve_with_start(&ta, &tb, &start).unwrap()
                        }
                    };
                    its.push(g.iterations);
                    let n = g.poses.len();
                    path = Some(g.poses[1..n - 1].iter().map(|p| scaled(p, 1.0 / fl)).collect());
                    last = Some(g);
                }
                let secs = t0.elapsed().as_secs_f64();
                let g = last.unwrap();
                // Pose difference against the direct solve, in mean edge lengths (units of `f`).
                let mut ss = 0.0;
                let mut count = 0;
                for (p, q) in g.poses.iter().zip(&direct.poses) {
                    for (x, y) in p.iter().zip(q) {
                        ss += (0..3).map(|k| (x[k] - y[k]).powi(2)).sum::<f64>();
                        count += 1;
                    }
                }
                let sizes: Vec<String> = h
                    .levels()
                    .iter()
                    .rev()
                    .map(|l| l.n_vertices().to_string())
                    .collect();
                let its: Vec<String> = its.iter().map(|i| i.to_string()).collect();
                println!(
                    "| {} | {} | {}, {:.2} | {} ({}) | {} | {:.2} | {:.1e} | {:.1e} |",
                    a.n_vertices(),
                    kind,
                    direct.iterations,
                    direct_s,
                    h.n_levels(),
                    sizes.join(" / "),
                    its.join(" / "),
                    secs,
                    g.energy / direct.energy - 1.0,
                    (ss / count as f64).sqrt(),
                );
            }
        }
    }
}
