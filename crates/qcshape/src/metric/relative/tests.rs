use super::*;
use crate::metric::{fdcheck, At, Metric, QcNormalize, QcWeights, QuasiConformal, Segment};
use crate::metric::{ConformalForm, Regularized};

fn qc() -> QuasiConformal {
    QuasiConformal::new(ConformalForm::Quadratic, QcWeights::Endpoints).normalized(QcNormalize {
        floor: 0.5,
        smooth: 0,
    })
}

fn metrics() -> Vec<Box<dyn Metric>> {
    vec![
        Box::new(RelativeL2),
        Box::new(RelativeIsometric),
        Box::new(RelativeConformal {
            qc: None,
            stretch: 0.0,
        }),
        Box::new(RelativeConformal {
            qc: None,
            stretch: 0.7,
        }),
        Box::new(RelativeConformal {
            qc: Some(qc()),
            stretch: 0.3,
        }),
        Box::new(Regularized::relative(
            Box::new(RelativeConformal {
                qc: Some(qc()),
                stretch: 0.3,
            }),
            0.2,
        )),
        Box::new(RelativeBending),
        Box::new(crate::metric::Bent::new(Box::new(RelativeIsometric), 0.3)),
    ]
}

#[test]
fn relative_jacobians_match_finite_differences() {
    for (i, m) in metrics().iter().enumerate() {
        fdcheck::check_metric(m.as_ref(), 40 + i as u64);
    }
}

/// A bumpy sphere and a twisted copy of it.
fn pair() -> (crate::mesh::Shape, Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let s = crate::synth::icosphere(2);
    let a: Vec<[f64; 3]> = s
        .positions
        .iter()
        .map(|p| [p[0] * 1.3, p[1] * (1.0 + 0.2 * p[0]), p[2] * 0.8])
        .collect();
    let b: Vec<[f64; 3]> = a
        .iter()
        .map(|p| {
            let t = 0.4 * p[2];
            [
                p[0] * t.cos() - p[1] * t.sin(),
                p[0] * t.sin() + p[1] * t.cos(),
                p[2] * 1.1,
            ]
        })
        .collect();
    (s, a, b)
}

/// The property the relative forms exist for: a pose scaled by `s` with its displacement
/// scaled by `s` (frozen values fixed, as on a path's interior) has the same squared norm.
#[test]
fn relative_metrics_are_scale_invariant() {
    let (s, a, b) = pair();
    let topo = &s.topology;
    for m in metrics() {
        let frozen = m.frozen_weights(topo, &a, &b);
        let pat = m.pattern(topo);
        let value = |f: f64| {
            let (sa, sb): (Vec<[f64; 3]>, Vec<[f64; 3]>) = (
                a.iter().map(|p| p.map(|c| c * f)).collect(),
                b.iter().map(|p| p.map(|c| c * f)).collect(),
            );
            [At::Start, At::End].map(|at| {
                let seg = Segment {
                    a: &sa,
                    b: &sb,
                    at,
                    aux: &[],
                    frozen: frozen.as_deref(),
                };
                m.squared_norm(topo, &pat, &seg)
            })
        };
        let v1 = value(1.0);
        assert!(v1[0] > 0.0 && v1[1] > 0.0, "{}", m.name());
        for f in [0.01, 0.3, 7.0, 100.0] {
            let vf = value(f);
            for k in 0..2 {
                assert!(
                    (vf[k] - v1[k]).abs() <= 1e-10 * v1[k],
                    "{} at scale {f}: {} vs {}",
                    m.name(),
                    vf[k],
                    v1[k]
                );
            }
        }
    }
}

/// Where the pose is the frozen geometry, the relative L2 term is the calibrated one,
/// `sum_p A_p |X_p|^2 / A^2`; a uniform scaling `X = t M` costs nothing in the conformal
/// terms and `4 t^2` in the stretch term (the area grows at twice the rate), `t^2` in the
/// isometric metric.
#[test]
fn relative_forms_measure_what_they_say() {
    let (s, a, _) = pair();
    let topo = &s.topology;
    let t = 1e-3;
    let seg_of = |b: &[[f64; 3]], frozen: Option<&[f64]>, m: &dyn Metric| {
        let seg = Segment {
            a: &a,
            b,
            at: At::Start,
            aux: &[],
            frozen,
        };
        m.squared_norm(topo, &m.pattern(topo), &seg)
    };
    let x: Vec<[f64; 3]> = a
        .iter()
        .map(|p| [0.1 * p[1], -0.05, 0.02 * p[0] * p[2]])
        .collect();
    let b: Vec<[f64; 3]> = a
        .iter()
        .zip(&x)
        .map(|(p, d)| [0, 1, 2].map(|c| p[c] + d[c]))
        .collect();
    let fr = RelativeL2.frozen_weights(topo, &a, &a).unwrap();
    let area = crate::mesh::geometry::total_area(topo, &a);
    let va = crate::mesh::geometry::vertex_areas(topo, &a);
    let want: f64 = va
        .iter()
        .zip(&x)
        .map(|(w, d)| w * crate::mesh::geometry::dot(*d, *d))
        .sum::<f64>()
        / (area * area);
    let got = seg_of(&b, Some(&fr), &RelativeL2);
    assert!((got - want).abs() <= 1e-12 * want, "{got} vs {want}");

    let scaled: Vec<[f64; 3]> = a.iter().map(|p| p.map(|c| c * (1.0 + t))).collect();
    let conformal = RelativeConformal {
        qc: None,
        stretch: 0.0,
    };
    let stretched = RelativeConformal {
        qc: None,
        stretch: 1.0,
    };
    let fr = conformal.frozen_weights(topo, &a, &a).unwrap();
    assert!(seg_of(&scaled, Some(&fr), &conformal) < 1e-24);
    let st = seg_of(&scaled, Some(&fr), &stretched);
    assert!((st - 4.0 * t * t).abs() <= 1e-9 * t * t, "{st}");
    let iso = seg_of(&scaled, Some(&fr), &RelativeIsometric);
    assert!((iso - t * t).abs() <= 1e-9 * t * t, "{iso}");
}
