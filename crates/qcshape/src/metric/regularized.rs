use super::{JacobianMut, Metric, Pattern, PatternRef, Segment, L2};
use crate::mesh::Topology;

/// `G + lambda * L2` (eq. 11): the inner metric's residuals followed by `sqrt(lambda)` times
/// the [`L2`] residuals. Makes conformal-type metrics positive definite (METHOD.md).
#[derive(Debug)]
pub struct Regularized {
    /// The metric being regularized.
    pub inner: Box<dyn Metric>,
    /// Weight `lambda >= 0` of the L2 term.
    pub lambda: f64,
}

impl Regularized {
    /// `inner + lambda * L2`.
    pub fn new(inner: Box<dyn Metric>, lambda: f64) -> Self {
        Regularized { inner, lambda }
    }
}

impl Metric for Regularized {
    fn name(&self) -> String {
        format!("{}+{}*l2", self.inner.name(), self.lambda)
    }

    fn pattern(&self, topo: &Topology) -> Pattern {
        let mut p = self.inner.pattern(topo);
        p.append(&L2.pattern(topo));
        p
    }

    fn n_residuals(&self, topo: &Topology) -> usize {
        self.inner.n_residuals(topo) + L2.n_residuals(topo)
    }

    fn n_aux(&self) -> usize {
        self.inner.n_aux()
    }

    fn best_aux(&self, topo: &Topology, seg: &Segment) -> Vec<f64> {
        self.inner.best_aux(topo, seg)
    }

    fn frozen_weights(&self, topo: &Topology, start: &[[f64; 3]], end: &[[f64; 3]]) -> Option<Vec<f64>> {
        self.inner.frozen_weights(topo, start, end)
    }

    fn residuals(
        &self,
        topo: &Topology,
        pattern: PatternRef,
        seg: &Segment,
        r: &mut [f64],
        jac: Option<JacobianMut>,
    ) {
        // The inner pattern is a prefix of the combined one (rows and entries).
        let n_in = self.inner.n_residuals(topo);
        let e_in = pattern.offsets[n_in] as usize;
        let inner_pat = PatternRef {
            offsets: &pattern.offsets[..=n_in],
            vertices: &pattern.vertices[..e_in],
        };
        let l2_offsets: Vec<u32> = pattern.offsets[n_in..].iter().map(|o| o - e_in as u32).collect();
        let l2_pat = PatternRef {
            offsets: &l2_offsets,
            vertices: &pattern.vertices[e_in..],
        };
        let (r_in, r_l2) = r.split_at_mut(n_in);
        let sl = self.lambda.max(0.0).sqrt();
        match jac {
            None => {
                self.inner.residuals(topo, inner_pat, seg, r_in, None);
                L2.residuals(topo, l2_pat, seg, r_l2, None);
            }
            Some(j) => {
                let (da_in, da_l2) = j.da.split_at_mut(e_in);
                let (db_in, db_l2) = j.db.split_at_mut(e_in);
                let n_aux = self.inner.n_aux();
                let (daux_in, daux_l2) = j.daux.split_at_mut(n_in * n_aux);
                let ji = JacobianMut {
                    da: da_in,
                    db: db_in,
                    daux: daux_in,
                };
                self.inner.residuals(topo, inner_pat, seg, r_in, Some(ji));
                let jl = JacobianMut {
                    da: da_l2,
                    db: db_l2,
                    daux: &mut [],
                };
                L2.residuals(topo, l2_pat, seg, r_l2, Some(jl));
                for d in da_l2.iter_mut().chain(db_l2.iter_mut()) {
                    *d = d.map(|v| v * sl);
                }
                // The L2 part does not depend on the auxiliary unknowns.
                daux_l2.fill(0.0);
            }
        }
        for v in r_l2.iter_mut() {
            *v *= sl;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metric::{fdcheck, Isometric};

    #[test]
    fn regularized_jacobian_matches_finite_differences() {
        fdcheck::check_metric(&Regularized::new(Box::new(Isometric), 0.3), 5);
    }
}
