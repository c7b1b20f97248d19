//! The accumulators of the gradient of one segment term, `weight * 2 J^T r`, which the metrics'
//! fused kernels fill without storing the Jacobian ([`Metric::gradient`](super::Metric::gradient)),
//! and the residual and Jacobian storage of the generic form ([`Scratch`],
//! [`gradient_from_jacobian`](super::gradient_from_jacobian)).

use super::pattern::{Jacobian, Pattern};
use super::segment::Segment;

/// Accumulators of `weight * 2 J^T r` for one segment term.
pub struct GradientSink<'a> {
    /// Derivative with respect to the first pose `a` (#V x 3).
    pub ga: &'a mut [[f64; 3]],
    /// Derivative with respect to the second pose `b` (#V x 3).
    pub gb: &'a mut [[f64; 3]],
    /// Derivative with respect to the term's auxiliary unknowns ([`Metric::n_aux`](super::Metric::n_aux)).
    pub gaux: &'a mut [f64],
    /// Factor applied to the value and the gradient.
    pub weight: f64,
}

impl GradientSink<'_> {
    /// Adds `2 weight r (dr/da_v, dr/db_v)` for vertex `v`.
    #[inline]
    pub fn add(&mut self, v: usize, r: f64, da: [f64; 3], db: [f64; 3]) {
        let s = 2.0 * self.weight * r;
        let (pa, pb) = (&mut self.ga[v], &mut self.gb[v]);
        for c in 0..3 {
            pa[c] += s * da[c];
            pb[c] += s * db[c];
        }
    }
}

/// Accumulators of `weight * 2 J^T r` for both terms of one segment
/// ([`Metric::segment_gradient`](super::Metric::segment_gradient)): the two terms share the poses `a`, `b`.
pub struct SegmentSink<'a> {
    /// Derivative with respect to the first pose `a` (#V x 3).
    pub ga: &'a mut [[f64; 3]],
    /// Derivative with respect to the second pose `b` (#V x 3).
    pub gb: &'a mut [[f64; 3]],
    /// Derivative with respect to both terms' auxiliary unknowns (2
    /// [`Metric::n_aux`](super::Metric::n_aux): the `At::Start` term's first).
    pub gaux: &'a mut [f64],
    /// Factor applied to the value and the gradient.
    pub weight: f64,
}

/// What the path energy shares between a segment and its two poses
/// ([`Metric::segment_gradient_with`](super::Metric::segment_gradient_with)): the
/// [`Metric::pose_values`](super::Metric::pose_values) of the segment's first and last pose,
/// and the segment's coefficients for each (sized and written by the metric), from which
/// [`Metric::pose_gradient`](super::Metric::pose_gradient) gives the rest of the gradient at
/// each pose.
pub struct PoseShare<'a> {
    /// The pose values of `a` and `b` (empty: none).
    pub values: [&'a [f64]; 2],
    /// The segment's coefficients for `a` and `b`, resized and written by the metric.
    pub coeffs: [&'a mut Vec<f64>; 2],
}

impl<'a> PoseShare<'a> {
    /// Nothing shared (no values; `unused` stays empty):
    /// [`Metric::segment_gradient_with`](super::Metric::segment_gradient_with) is
    /// [`Metric::segment_gradient`](super::Metric::segment_gradient).
    pub fn none(unused: [&'a mut Vec<f64>; 2]) -> Self {
        PoseShare {
            values: [&[], &[]],
            coeffs: unused,
        }
    }
}

/// Whether a segment's two terms carry the same frozen values (the path energy's always do):
/// fused kernels share per-element weights between the terms only then.
pub(crate) fn same_frozen(segs: [&Segment; 2]) -> bool {
    match (segs[0].frozen, segs[1].frozen) {
        (None, None) => true,
        (Some(f), Some(g)) => std::ptr::eq(f, g) || f == g,
        _ => false,
    }
}

/// Residual and Jacobian storage for a metric pattern, reused across evaluations.
#[derive(Debug, Clone, Default)]
pub struct Scratch {
    /// Residuals (#residuals).
    pub r: Vec<f64>,
    /// Jacobian in pattern order.
    pub jac: Jacobian,
}

impl Scratch {
    /// Storage for `pattern` with `n_aux` auxiliary unknowns per term.
    pub fn new(pattern: &Pattern, n_aux: usize) -> Self {
        Scratch {
            r: vec![0.0; pattern.n_residuals()],
            jac: Jacobian::zeros(pattern, n_aux),
        }
    }

    /// Grows the storage to at least `n_res` residuals, `n_ent` entries and `n_res x n_aux`
    /// auxiliary derivatives (an empty [`Scratch::default`] is grown on first use, so metrics
    /// with fused kernels never allocate it).
    pub fn reserve(&mut self, n_res: usize, n_ent: usize, n_aux: usize) {
        if self.r.len() < n_res {
            self.r.resize(n_res, 0.0);
        }
        if self.jac.da.len() < n_ent {
            self.jac.da.resize(n_ent, [0.0; 3]);
            self.jac.db.resize(n_ent, [0.0; 3]);
        }
        if self.jac.daux.len() < n_res * n_aux {
            self.jac.daux.resize(n_res * n_aux, 0.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metric::{
        gradient_from_jacobian, At, Conformal, ConformalForm, FrozenL2, FrozenRigid, Isometric, Metric,
        QcWeights, QuasiConformal, Regularized, Rigid, Segment, L2,
    };
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn all_metrics() -> Vec<Box<dyn Metric>> {
        vec![
            Box::new(Isometric),
            Box::new(FrozenL2),
            Box::new(L2),
            Box::new(Conformal::new(ConformalForm::Quadratic)),
            Box::new(Conformal::new(ConformalForm::Paper)),
            Box::new(QuasiConformal::new(
                ConformalForm::Quadratic,
                QcWeights::Endpoints,
            )),
            Box::new(Regularized::new(Box::new(Isometric), 0.3)),
            Box::new(Regularized::new(
                Box::new(Conformal::new(ConformalForm::Quadratic)),
                0.3,
            )),
            Box::new(Regularized::with_pose_areas(Box::new(Isometric), 0.3)),
            Box::new(Regularized::new(Box::new(Rigid), 0.3)),
            Box::new(Regularized::new(Box::new(FrozenRigid), 0.3)),
            Box::new(Regularized::new(
                Box::new(QuasiConformal::new(
                    ConformalForm::Quadratic,
                    QcWeights::Endpoints,
                )),
                0.3,
            )),
            Box::new(Regularized::new(
                Box::new(QuasiConformal::new(ConformalForm::Paper, QcWeights::Segment)),
                0.3,
            )),
            Box::new(crate::metric::RelativeIsometric),
            Box::new(crate::metric::RelativeConformal {
                qc: None,
                stretch: 0.0,
            }),
            Box::new(crate::metric::RelativeConformal {
                qc: Some(
                    QuasiConformal::new(ConformalForm::Quadratic, QcWeights::Endpoints).normalized(
                        crate::metric::QcNormalize {
                            floor: 0.5,
                            smooth: 0,
                        },
                    ),
                ),
                stretch: 0.3,
            }),
            Box::new(crate::metric::RelativeBending),
            Box::new(Regularized::relative(
                Box::new(crate::metric::Bent::new(
                    Box::new(crate::metric::RelativeIsometric),
                    0.3,
                )),
                0.3,
            )),
        ]
    }

    fn pair() -> (crate::mesh::Shape, Vec<[f64; 3]>) {
        let s = crate::synth::icosphere(1);
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let b: Vec<[f64; 3]> = s
            .positions
            .iter()
            .map(|p| p.map(|c| c * 1.2 + rng.random_range(-0.1..0.1)))
            .collect();
        (s, b)
    }

    /// Every metric's [`Metric::gradient`] (fused where overridden) equals the generic form.
    #[test]
    fn fused_gradients_match_the_jacobian_form() {
        let (s, b) = pair();
        let topo = &s.topology;
        for m in &all_metrics() {
            let pat = m.pattern(topo);
            let frozen = m.frozen_weights(topo, &s.positions, &b);
            let aux: Vec<f64> = (0..m.n_aux()).map(|k| 0.01 * k as f64).collect();
            for at in [At::Start, At::End] {
                let seg = Segment {
                    a: &s.positions,
                    b: &b,
                    at,
                    aux: &aux,
                    frozen: frozen.as_deref(),
                };
                let run = |fused: bool| {
                    let nv = topo.n_vertices();
                    let (mut ga, mut gb) = (vec![[0.0; 3]; nv], vec![[0.0; 3]; nv]);
                    let mut gaux = vec![0.0; m.n_aux()];
                    let mut scratch = Scratch::new(&pat, m.n_aux());
                    let mut sink = GradientSink {
                        ga: &mut ga,
                        gb: &mut gb,
                        gaux: &mut gaux,
                        weight: 0.7,
                    };
                    let v = if fused {
                        m.gradient(topo, pat.as_ref(), &seg, &mut scratch, &mut sink)
                    } else {
                        gradient_from_jacobian(m.as_ref(), topo, pat.as_ref(), &seg, &mut scratch, &mut sink)
                    };
                    (v, ga, gb, gaux)
                };
                let (v0, ga0, gb0, gx0) = run(false);
                let (v1, ga1, gb1, gx1) = run(true);
                let tol = |x: f64| 1e-10 * (1.0 + x.abs());
                assert!((v0 - v1).abs() < tol(v0), "{} {at:?}: {v0} vs {v1}", m.name());
                let flat = |g: &[[f64; 3]]| g.iter().flatten().copied().collect::<Vec<f64>>();
                let scale = flat(&ga0)
                    .iter()
                    .chain(&flat(&gb0))
                    .fold(0.0f64, |a, b| a.max(b.abs()));
                for (x, y) in flat(&ga0)
                    .iter()
                    .chain(&flat(&gb0))
                    .chain(&gx0)
                    .zip(flat(&ga1).iter().chain(&flat(&gb1)).chain(&gx1))
                {
                    assert!(
                        (x - y).abs() < 1e-10 * (1.0 + scale),
                        "{} {at:?}: {x} vs {y}",
                        m.name()
                    );
                }
            }
        }
    }

    /// Every metric's [`Metric::segment_gradient`] (one fused pass for both terms where
    /// overridden) equals the generic per-term form summed over the two terms, with distinct
    /// frozen weights per term where the metric has them.
    #[test]
    fn segment_gradients_match_the_per_term_jacobian_form() {
        let (s, b) = pair();
        let topo = &s.topology;
        let nv = topo.n_vertices();
        for m in &all_metrics() {
            let pat = m.pattern(topo);
            let n_aux = m.n_aux();
            // Term weights: the frozen weights of the pair and of a perturbed pair.
            let f0 = m.frozen_weights(topo, &s.positions, &b);
            let b2: Vec<[f64; 3]> = b.iter().map(|p| [p[0] * 1.1, p[1], p[2] * 0.9]).collect();
            let f1 = m.frozen_weights(topo, &s.positions, &b2);
            let aux: Vec<f64> = (0..n_aux).map(|k| 0.01 * k as f64).collect();
            // Both terms with the same frozen values (as the path energy's: fused kernels
            // share them) and with different ones.
            for f1 in [f0.clone(), f1.clone()] {
                let segs =
                    [(At::Start, f0.as_deref()), (At::End, f1.as_deref())].map(|(at, frozen)| Segment {
                        a: &s.positions,
                        b: &b,
                        at,
                        aux: &aux,
                        frozen,
                    });
                let mut scratch = Scratch::new(&pat, n_aux);
                let (mut ga0, mut gb0) = (vec![[0.0; 3]; nv], vec![[0.0; 3]; nv]);
                let mut gx0 = vec![0.0; 2 * n_aux];
                let mut v0 = 0.0;
                for (k, seg) in segs.iter().enumerate() {
                    let mut sink = GradientSink {
                        ga: &mut ga0,
                        gb: &mut gb0,
                        gaux: &mut gx0[k * n_aux..(k + 1) * n_aux],
                        weight: 0.7,
                    };
                    v0 +=
                        gradient_from_jacobian(m.as_ref(), topo, pat.as_ref(), seg, &mut scratch, &mut sink);
                }
                let (mut ga1, mut gb1) = (vec![[0.0; 3]; nv], vec![[0.0; 3]; nv]);
                let mut gx1 = vec![0.0; 2 * n_aux];
                let mut sink = SegmentSink {
                    ga: &mut ga1,
                    gb: &mut gb1,
                    gaux: &mut gx1,
                    weight: 0.7,
                };
                let v1 =
                    m.segment_gradient(topo, pat.as_ref(), [&segs[0], &segs[1]], &mut scratch, &mut sink);
                assert!(v0 > 0.0);
                assert!((v0 - v1).abs() < 1e-10 * v0, "{}: {v0} vs {v1}", m.name());
                let flat = |g: &[[f64; 3]]| g.iter().flatten().copied().collect::<Vec<f64>>();
                let want: Vec<f64> = flat(&ga0).into_iter().chain(flat(&gb0)).chain(gx0).collect();
                let got: Vec<f64> = flat(&ga1).into_iter().chain(flat(&gb1)).chain(gx1).collect();
                let scale = want.iter().fold(0.0f64, |a, b| a.max(b.abs()));
                assert!(scale > 0.0);
                for (x, y) in want.iter().zip(&got) {
                    assert!((x - y).abs() < 1e-10 * scale, "{}: {x} vs {y}", m.name());
                }
            }
        }
    }
}
