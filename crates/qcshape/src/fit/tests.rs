//! Tests of the whole fit (closest points, alignment and the non-rigid solve together) on
//! small meshes; the ground-truth comparison with the baseline is in `tests/fit.rs`.

use super::target::prepare;
use super::*;
use crate::align::{Alignment, Motion};
use crate::mesh::geometry::{add, norm, scale, sub};
use crate::mesh::{Shape, Topology};
use crate::synth::icosphere;

/// A level-3 sphere (642 vertices) stretched into an ellipsoid and dented: a target on another
/// triangulation than the level-1 or level-2 template.
fn target_points(scale_by: f64) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let s = icosphere(3);
    let p = s
        .positions
        .iter()
        .map(|p| [1.3 * p[0], 0.9 * p[1], p[2] + 0.2 * p[0] * p[0]].map(|c| c * scale_by))
        .collect();
    (p, s.topology.faces().to_vec())
}

fn max_residual(f: &Fitted) -> f64 {
    f.residual.iter().fold(0.0f64, |m, r| m.max(*r)) / f.quality.edge_length
}

#[test]
fn fits_a_surface_of_another_triangulation() {
    let template = icosphere(2);
    let (p, faces) = target_points(1.0);
    let f = fit(
        &template,
        &Target {
            positions: &p,
            faces: &faces,
        },
        &FitOptions::default(),
    )
    .unwrap();
    assert!(f.quality.mean < 0.1, "{:?}", f.quality);
    assert!(max_residual(&f) < 0.2, "{}", max_residual(&f));
    assert_eq!(f.quality.flipped, 0);
    assert!(!f.quality.poor, "{:?}", f.quality.problems());
    assert_eq!(f.positions.len(), template.n_vertices());
}

#[test]
fn scale_invariant() {
    // An asymmetric template, so that the fit is unique (a sphere fits in any orientation).
    let s = icosphere(2);
    let bent = s
        .positions
        .iter()
        .map(|p| [p[0] + 0.3 * p[1] * p[1], p[1], 1.2 * p[2] + 0.2 * p[0]])
        .collect();
    let template = Shape::new(s.topology.clone(), bent).unwrap();
    let mut means = Vec::new();
    let mut shapes = Vec::new();
    for k in [0.01, 1.0, 100.0] {
        let (p, faces) = target_points(k);
        let f = fit(
            &template,
            &Target {
                positions: &p,
                faces: &faces,
            },
            &FitOptions::default(),
        )
        .unwrap();
        assert!((f.motion.scale / k - 1.0).abs() < 0.05, "{k}: {}", f.motion.scale);
        means.push(f.quality.mean);
        shapes.push(f.positions.iter().map(|x| x.map(|c| c / k)).collect::<Vec<_>>());
    }
    for m in &means {
        assert!((m - means[1]).abs() < 1e-3, "{means:?}");
    }
    let d = crate::align::rms_distance(&shapes[0], &shapes[2]);
    assert!(d < 1e-4, "{d}");
}

#[test]
fn point_clouds_use_the_point_terms() {
    let template = icosphere(2);
    let (p, _) = target_points(1.0);
    let f = fit(
        &template,
        &Target {
            positions: &p,
            faces: &[],
        },
        &FitOptions::default(),
    )
    .unwrap();
    // The distance to a point set includes the gaps between its points (about half an edge
    // of the level-3 target, a quarter of the template's).
    assert!(f.quality.median_vertex < 0.25, "{:?}", f.quality);
    assert_eq!(f.quality.flipped, 0);
}

#[test]
fn a_partial_target_fits_where_it_is() {
    let template = icosphere(2);
    let (p, faces) = target_points(1.0);
    // Keep the faces above z = -0.3: about 65 % of the surface, one open boundary.
    let kept: Vec<[u32; 3]> = faces
        .iter()
        .copied()
        .filter(|f| f.iter().all(|&i| p[i as usize][2] > -0.3))
        .collect();
    let opts = FitOptions {
        alignment: Alignment::None,
        ..FitOptions::default()
    };
    let f = fit(
        &template,
        &Target {
            positions: &p,
            faces: &kept,
        },
        &opts,
    )
    .unwrap();
    let whole = fit(
        &template,
        &Target {
            positions: &p,
            faces: &faces,
        },
        &opts,
    )
    .unwrap();
    // Where the target is, the partial fit agrees with the fit to the whole surface.
    let mut worst: f64 = 0.0;
    for (i, x) in template.positions.iter().enumerate() {
        if x[2] > 0.0 {
            let d = crate::mesh::geometry::norm(sub(f.positions[i], whole.positions[i]));
            worst = worst.max(d / f.quality.edge_length);
        }
    }
    assert!(worst < 0.5, "{worst}");
    assert_eq!(f.quality.flipped, 0);
}

#[test]
fn tracks_a_sequence_and_is_deterministic() {
    let template = icosphere(2);
    type Mesh = (Vec<[f64; 3]>, Vec<[u32; 3]>);
    let frames: Vec<Mesh> = (0..3)
        .map(|k| {
            let (p, f) = target_points(1.0);
            let t = 0.1 * k as f64;
            (p.iter().map(|x| [x[0] + t * x[2], x[1], x[2]]).collect(), f)
        })
        .collect();
    let targets: Vec<Target> = frames
        .iter()
        .map(|(p, f)| Target {
            positions: p,
            faces: f,
        })
        .collect();
    let mut seen = Vec::new();
    let a = fit_sequence(&template, &targets, &FitOptions::default(), |k| seen.push(k)).unwrap();
    assert_eq!(seen, [0, 1, 2]);
    for f in &a {
        assert!(f.quality.mean < 0.1, "{:?}", f.quality);
    }
    assert_eq!(a[1].motion, Motion::IDENTITY);
    let b = fit_sequence(&template, &targets, &FitOptions::default(), |_| {}).unwrap();
    assert_eq!(a, b);
}

#[test]
fn refuses_bad_input_with_one_line() {
    let template = icosphere(1);
    let (p, faces) = target_points(1.0);
    let opts = FitOptions::default();
    let err = |t: Target| fit(&template, &t, &opts).unwrap_err();
    assert!(matches!(
        err(Target {
            positions: &[],
            faces: &[]
        }),
        FitError::EmptyTarget
    ));
    let mut nan = p.clone();
    nan[3][1] = f64::NAN;
    assert!(matches!(
        err(Target {
            positions: &nan,
            faces: &faces
        }),
        FitError::NonFinite {
            what: "target",
            vertex: 3
        }
    ));
    let bad_faces = vec![[0, 1, 9999]];
    assert!(matches!(
        err(Target {
            positions: &p,
            faces: &bad_faces
        }),
        FitError::FaceIndex { index: 9999, .. }
    ));
    // Far away and no alignment: no overlap.
    let far: Vec<[f64; 3]> = p.iter().map(|x| [x[0] + 50.0, x[1], x[2]]).collect();
    let none = FitOptions {
        alignment: Alignment::None,
        ..FitOptions::default()
    };
    let e = fit(
        &template,
        &Target {
            positions: &far,
            faces: &faces,
        },
        &none,
    )
    .unwrap_err();
    assert!(matches!(e, FitError::NoOverlap { .. }), "{e}");
    assert!(!e.to_string().contains('\n'));
    let zero = FitOptions {
        stages: 0,
        ..FitOptions::default()
    };
    assert!(matches!(
        fit(
            &template,
            &Target {
                positions: &p,
                faces: &faces
            },
            &zero
        ),
        Err(FitError::Option { name: "stages", .. })
    ));
    // A template with a bowtie vertex (two fans meeting at vertex 0).
    let bow = Topology::allowing_nonmanifold_vertices(5, vec![[0, 1, 2], [0, 3, 4]]).unwrap();
    let pos = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, -1.0, 0.0],
    ];
    let shape = Shape::new(bow, pos).unwrap();
    let e = fit(
        &shape,
        &Target {
            positions: &p,
            faces: &faces,
        },
        &opts,
    )
    .unwrap_err();
    assert!(
        matches!(
            e,
            FitError::Template(TemplateProblem::NotManifold { vertex: 0, fans: 2 })
        ),
        "{e}"
    );
    assert_eq!(
        e.to_string(),
        "the template cannot be fitted: it is not manifold: vertex 0 joins 2 separate fans of faces"
    );
}

/// An ellipsoid (semi-axes 1.2, 0.9, 0.8) on icosphere level `level`, turned by `turn` radians
/// about z (so that no vertex of one level sits on a vertex of another).
fn ellipsoid(level: u32, turn: f64) -> Shape {
    let s = icosphere(level);
    let (sn, cs) = turn.sin_cos();
    let p = s
        .positions
        .iter()
        .map(|p| {
            let q = [cs * p[0] - sn * p[1], sn * p[0] + cs * p[1], p[2]];
            [1.2 * q[0], 0.9 * q[1], 0.8 * q[2]]
        })
        .collect();
    Shape::new(s.topology.clone(), p).unwrap()
}

#[test]
fn a_template_sliver_fitted_onto_its_own_surface_is_not_poor() {
    // The template has a sliver: one vertex moved almost onto the opposite edge of one of its
    // triangles (an angle well below 1 degree there).
    let mut t = ellipsoid(2, 0.0);
    let [a, b, c] = t.topology.faces()[10].map(|i| i as usize);
    let mid = scale(add(t.positions[a], t.positions[b]), 0.5);
    t.positions[c] = add(mid, scale(sub(t.positions[c], mid), 0.004));
    let angle = |s: &Shape| {
        crate::mesh::geometry::corner_angles(&s.topology, &s.positions)
            .iter()
            .flatten()
            .fold(f64::INFINITY, |m, x| m.min(*x))
            .to_degrees()
    };
    assert!(angle(&t) < 1.0, "{}", angle(&t));
    // The target: the same surface, another (finer) triangulation.
    let g = ellipsoid(4, 0.3);
    for prior in [Prior::Smooth, Prior::Affine] {
        let opts = FitOptions {
            alignment: Alignment::None,
            prior,
            ..FitOptions::default()
        };
        let f = fit(
            &t,
            &Target {
                positions: &g.positions,
                faces: g.topology.faces(),
            },
            &opts,
        )
        .unwrap();
        let q = f.quality;
        // The template's own sliver is reported, not counted against the fit.
        assert!(q.template_min_angle < 1.0, "{prior:?} {q:?}");
        assert_eq!(q.new_slivers, 0, "{prior:?} {q:?}");
        assert_eq!(q.flipped, 0, "{prior:?} {q:?}");
        assert!(!q.poor, "{prior:?} {:?}", q.problems());
    }
}

#[test]
fn a_planted_slide_is_flagged_and_a_good_fit_is_not() {
    let t = ellipsoid(3, 0.0);
    let g = ellipsoid(4, 0.3);
    let target = Target {
        positions: &g.positions,
        faces: g.topology.faces(),
    };
    let opts = FitOptions {
        alignment: Alignment::None,
        ..FitOptions::default()
    };
    let f = fit(&t, &target, &opts).unwrap();
    assert!(!f.quality.poor, "{:?}", f.quality.problems());
    assert!(f.quality.slide < f.quality.slide_limit, "{:?}", f.quality);
    assert!(
        (f.quality.slide_limit - quality::POOR_SLIDE).abs() < 0.05,
        "{:?}",
        f.quality
    );
    // Slide a patch (the vertices within 0.3 of the +x pole) by 1.5 edge lengths along the
    // surface (the y direction, tangent there), then put it back on the target: the surface
    // distance stays small, the correspondence is wrong.
    let prepared = prepare(&target).unwrap();
    let lbar = f.quality.edge_length;
    let pole = [1.2, 0.0, 0.0];
    let slid: Vec<[f64; 3]> = f
        .positions
        .iter()
        .map(|p| {
            if norm(sub(*p, pole)) < 0.3 {
                prepared
                    .index
                    .closest(add(*p, [0.0, 1.5 * lbar, 0.0]))
                    .unwrap()
                    .point
            } else {
                *p
            }
        })
        .collect();
    let (q, _) = quality::measure(&t.topology, &t.positions, &slid, &prepared, quality::SAMPLES);
    assert!(q.mean < quality::POOR_MEAN, "{q:?}");
    assert!(q.slide > q.slide_limit, "{q:?}");
    assert!(q.poor, "{q:?}");
}

#[test]
fn landmarks_pull_their_vertices() {
    // A sphere fitted to a sphere: without landmarks vertex 0 stays; a landmark on another
    // point of the surface, a few edges away, moves it there.
    let t = icosphere(2);
    let g = icosphere(3);
    let target = Target {
        positions: &g.positions,
        faces: g.topology.faces(),
    };
    // Landmarks are a term of the affine prior.
    let opts = FitOptions {
        alignment: Alignment::None,
        prior: Prior::Affine,
        ..FitOptions::default()
    };
    let p0 = t.positions[0];
    let (sn, cs) = 0.25f64.sin_cos();
    let goal = [cs * p0[0] - sn * p0[1], sn * p0[0] + cs * p0[1], p0[2]];
    let free = fit(&t, &target, &opts).unwrap();
    let pulled = fit_with_landmarks(
        &t,
        &target,
        &opts,
        &[affine::Landmark {
            vertex: 0,
            point: goal,
        }],
    )
    .unwrap();
    let d = |f: &Fitted| norm(sub(f.positions[0], goal)) / f.quality.edge_length;
    assert!(d(&free) > 0.5, "{}", d(&free));
    // Measured 0.20 edge lengths from the goal (0.84 without the landmark).
    assert!(
        d(&pulled) < 0.3 && d(&pulled) < 0.5 * d(&free),
        "{} {}",
        d(&pulled),
        d(&free)
    );
    let bad = fit_with_landmarks(
        &t,
        &target,
        &opts,
        &[affine::Landmark {
            vertex: 10_000,
            point: goal,
        }],
    );
    assert!(matches!(bad, Err(FitError::Landmark { vertex: 10_000, .. })));
}

/// The exact correspondence error (template mean edge lengths) of fits of an ellipsoid onto
/// its taper (a quadratic map of space, `(x, y) (1 + 0.4 z)`) on a finer mesh, with the global
/// polynomial warp of degree `0` (none) and 2 first.
#[test]
fn a_quadratic_warp_follows_a_taper_without_sliding() {
    let template = ellipsoid(2, 0.0);
    let taper = |p: [f64; 3]| [p[0] * (1.0 + 0.4 * p[2]), p[1] * (1.0 + 0.4 * p[2]), p[2]];
    let fine = ellipsoid(4, 0.3);
    let target: Vec<[f64; 3]> = fine.positions.iter().map(|p| taper(*p)).collect();
    let truth: Vec<[f64; 3]> = template.positions.iter().map(|p| taper(*p)).collect();
    let lbar = crate::mesh::geometry::mean_edge_length(&template.topology, &template.positions);
    let error = |degree: usize| {
        let opts = FitOptions {
            prior: Prior::Affine,
            alignment: Alignment::None,
            global_degree: degree,
            ..FitOptions::default()
        };
        let f = fit(
            &template,
            &Target {
                positions: &target,
                faces: fine.topology.faces(),
            },
            &opts,
        )
        .unwrap();
        assert!(f.quality.mean < 0.1, "degree {degree}: {:?}", f.quality);
        let mut e: Vec<f64> = f
            .positions
            .iter()
            .zip(&truth)
            .map(|(a, b)| norm(sub(*a, *b)) / lbar)
            .collect();
        e.sort_by(f64::total_cmp);
        e[e.len() / 2]
    };
    let (none, quadratic) = (error(0), error(2));
    assert!(
        quadratic < 0.25,
        "median error with the warp {quadratic}, without {none}"
    );
    assert!(
        quadratic < 0.5 * none,
        "with the warp {quadratic}, without {none}"
    );
    let bad = FitOptions {
        global_degree: 6,
        ..FitOptions::default()
    };
    assert!(bad.check().is_err());
}
