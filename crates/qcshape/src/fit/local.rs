//! The local step of the non-rigid fit: one linear map `A_i` (3 x 3) per template vertex, which
//! the prior's edge term `|x_i - x_j - A_i (p_i - p_j)|^2` compares the fitted edge vectors
//! with ([`super::nonrigid`]).
//!
//! - [`Prior::Arap`]: `A_i` is the rotation best aligning the vertex's rest edge fan with the
//!   fitted one (Horn's method): the prior charges every edge strain.
//! - [`Prior::Asap`]: the rotation times the fan's best uniform scale (in `[0.5, 2]`): local
//!   scaling is free.
//! - [`Prior::Smooth`] (the default): the maps minimizing `SmoothMaps`' energy, a field of
//!   local affine maps that fit each fan, stay near the fan's best similarity and vary smoothly
//!   from vertex to vertex. Smooth large-scale deformations (stretches, shears, tapers, bends)
//!   cost little, so the fit does not trade them for tangential sliding, which the data cannot
//!   see (docs/fit.md has the measured comparison).
//!
//! Units: `p`, `x` in any one length unit; the smoothness weight is scaled by the squared mean
//! rest edge length `lbar^2`, so the maps do not depend on the unit.

use rayon::prelude::*;

use super::options::Prior;
use crate::align::{horn_rotation, Motion};
use crate::mesh::geometry::{dot, sub};
use crate::mesh::Topology;

/// A 3 x 3 matrix, row-major.
pub(crate) type Mat3 = [[f64; 3]; 3];

/// Weight `beta` of the pull of each affine map towards its fan's best similarity, relative
/// to the fan's data (`sum_j |u_ij|^2`). Chosen on the fit's ground-truth fixtures (docs/fit.md).
pub const SIMILARITY_WEIGHT: f64 = 0.1;
/// Weight `gamma` of the smoothness `|A_i - A_j|^2` per edge, in units of `lbar^2`.
pub const SMOOTHNESS: f64 = 0.3;
/// Block-Jacobi sweeps of the smooth maps per local step (from the fans' rotations; the maps
/// change by less than 1e-3 of the result's scale after 10 on the fixtures).
pub const SWEEPS: usize = 10;

/// One vertex's edge fan: the rest edges `u_j = p_i - p_j` against the fitted ones
/// `v_j = x_i - x_j`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Fan {
    /// Horn's best rotation (`v ~ R u`).
    rotation: Mat3,
    /// `sum_j |u_j|^2`.
    uu: f64,
    /// `sum_j <R u_j, v_j>`.
    trace: f64,
    /// `sum_j u_j u_j^T`.
    cov: Mat3,
    /// `sum_j v_j u_j^T`.
    cross: Mat3,
}

impl Fan {
    /// The best similarity `s R`, `s` bounded to `[0.5, 2]` so that a fan cannot collapse or
    /// explode.
    fn similarity(&self) -> Mat3 {
        let s = if self.uu > 0.0 {
            (self.trace / self.uu).clamp(0.5, 2.0)
        } else {
            1.0
        };
        self.rotation.map(|row| row.map(|c| c * s))
    }
}

/// The fans of every vertex of `topo` (rest `p`, fitted `x`, #V x 3 each).
pub(crate) fn fans(topo: &Topology, p: &[[f64; 3]], x: &[[f64; 3]]) -> Vec<Fan> {
    (0..x.len())
        .into_par_iter()
        .map(|i| {
            let (mut cov, mut cross, mut uu) = ([[0.0; 3]; 3], [[0.0; 3]; 3], 0.0);
            for &j in topo.neighbors(i) {
                let (u, v) = (sub(p[i], p[j as usize]), sub(x[i], x[j as usize]));
                uu += dot(u, u);
                for a in 0..3 {
                    for b in 0..3 {
                        cov[a][b] += u[a] * u[b];
                        cross[a][b] += v[a] * u[b];
                    }
                }
            }
            // Horn's method takes m[a][b] = sum u_a v_b, the transpose of `cross`.
            let m = transpose(cross);
            let rotation = horn_rotation(&m).unwrap_or(Motion::IDENTITY.rotation);
            let trace = (0..3)
                .map(|a| (0..3).map(|b| rotation[b][a] * m[a][b]).sum::<f64>())
                .sum();
            Fan {
                rotation,
                uu,
                trace,
                cov,
                cross,
            }
        })
        .collect()
}

/// The prior's maps `A_i` (#V of 3 x 3) at the fitted positions `x` against the rest shape `p`.
pub(crate) fn maps(topo: &Topology, p: &[[f64; 3]], x: &[[f64; 3]], prior: Prior, lbar: f64) -> Vec<Mat3> {
    let fans = fans(topo, p, x);
    match prior {
        Prior::Arap => fans.iter().map(|f| f.rotation).collect(),
        Prior::Asap => fans.iter().map(Fan::similarity).collect(),
        // The affine prior has its own solver (`super::affine`); its maps are never asked for.
        Prior::Smooth | Prior::Affine => SmoothMaps::new(topo, &fans, lbar).solve(SWEEPS),
    }
}

/// The energy of the smooth maps ([`Prior::Smooth`]), for fixed fitted positions:
///
/// `F(A) = sum_i sum_{j in N(i)} |v_ij - A_i u_ij|^2 + beta sum_i uu_i |A_i - S_i|_F^2
///       + gamma lbar^2 sum_{edges ij} |A_i - A_j|_F^2`
///
/// with `S_i` fan `i`'s best similarity ([`SIMILARITY_WEIGHT`] `= beta`, [`SMOOTHNESS`]
/// `= gamma`). Its minimizer is a sparse linear system in the maps; [`SmoothMaps::solve`]
/// runs block-Jacobi sweeps on it (one 3 x 3 solve per vertex and sweep, parallel and
/// deterministic), which converge because the system is symmetric positive definite and the
/// block diagonal dominates.
pub(crate) struct SmoothMaps<'a> {
    topo: &'a Topology,
    fans: &'a [Fan],
    /// `gamma lbar^2`.
    g: f64,
}

impl<'a> SmoothMaps<'a> {
    /// The energy of `fans` (from [`fans`]) on `topo`, rest mean edge length `lbar`.
    pub fn new(topo: &'a Topology, fans: &'a [Fan], lbar: f64) -> Self {
        SmoothMaps {
            topo,
            fans,
            g: SMOOTHNESS * lbar * lbar,
        }
    }

    /// `F(A)` (see the type's docs).
    #[cfg_attr(not(test), allow(dead_code))]
    pub fn energy(&self, a: &[Mat3]) -> f64 {
        let mut e = 0.0;
        for (i, (f, ai)) in self.fans.iter().zip(a).enumerate() {
            // sum_j |v - A u|^2 = sum |v|^2 - 2 tr(A^T cross) + tr(A cov A^T); the constant
            // sum |v|^2 is left out.
            let s = f.similarity();
            for r in 0..3 {
                let acov: f64 = (0..3)
                    .map(|k| ai[r][k] * (0..3).map(|l| f.cov[k][l] * ai[r][l]).sum::<f64>())
                    .sum();
                e += acov - 2.0 * dot(ai[r], f.cross[r]);
                let d = sub(ai[r], s[r]);
                e += SIMILARITY_WEIGHT * f.uu * dot(d, d);
            }
            for &j in self.topo.neighbors(i) {
                if (j as usize) > i {
                    e += self.g * frobenius2(sub3(*ai, a[j as usize]));
                }
            }
        }
        e
    }

    /// `dF/dA` (#V of 3 x 3).
    #[cfg_attr(not(test), allow(dead_code))]
    pub fn gradient(&self, a: &[Mat3]) -> Vec<Mat3> {
        (0..a.len())
            .map(|i| {
                let f = &self.fans[i];
                let s = f.similarity();
                let mut g = [[0.0; 3]; 3];
                for r in 0..3 {
                    for k in 0..3 {
                        let acov: f64 = (0..3).map(|l| a[i][r][l] * f.cov[l][k]).sum();
                        g[r][k] = 2.0 * (acov - f.cross[r][k])
                            + 2.0 * SIMILARITY_WEIGHT * f.uu * (a[i][r][k] - s[r][k]);
                    }
                }
                for &j in self.topo.neighbors(i) {
                    let d = sub3(a[i], a[j as usize]);
                    for r in 0..3 {
                        for k in 0..3 {
                            g[r][k] += 2.0 * self.g * d[r][k];
                        }
                    }
                }
                g
            })
            .collect()
    }

    /// The maps after `sweeps` block-Jacobi sweeps from the fans' rotations: each sweep sets
    /// every `A_i` to the minimizer of `F` with its neighbours' maps fixed,
    /// `A_i (cov_i + (beta uu_i + gamma lbar^2 deg_i) I) = cross_i + beta uu_i S_i
    /// + gamma lbar^2 sum_j A_j`.
    pub fn solve(&self, sweeps: usize) -> Vec<Mat3> {
        let blocks: Vec<(Mat3, Mat3)> = self
            .fans
            .par_iter()
            .enumerate()
            .map(|(i, f)| {
                let d = SIMILARITY_WEIGHT * f.uu + self.g * self.topo.neighbors(i).len() as f64;
                let s = f.similarity();
                let mut m = f.cov;
                let mut rhs = f.cross;
                for r in 0..3 {
                    m[r][r] += d;
                    for k in 0..3 {
                        rhs[r][k] += SIMILARITY_WEIGHT * f.uu * s[r][k];
                    }
                }
                (inverse_spd(m), rhs)
            })
            .collect();
        let mut a: Vec<Mat3> = self.fans.iter().map(|f| f.rotation).collect();
        for _ in 0..sweeps {
            a = blocks
                .par_iter()
                .enumerate()
                .map(|(i, (minv, rhs))| {
                    let mut b = *rhs;
                    for &j in self.topo.neighbors(i) {
                        for r in 0..3 {
                            for k in 0..3 {
                                b[r][k] += self.g * a[j as usize][r][k];
                            }
                        }
                    }
                    // Row r of A solves (cov + d I) a_r = b_r; the matrix is symmetric.
                    b.map(|row| minv.map(|m| dot(m, row)))
                })
                .collect();
        }
        a
    }
}

fn transpose(m: Mat3) -> Mat3 {
    [0, 1, 2].map(|a| [0, 1, 2].map(|b| m[b][a]))
}

fn sub3(a: Mat3, b: Mat3) -> Mat3 {
    [0, 1, 2].map(|r| sub(a[r], b[r]))
}

fn frobenius2(m: Mat3) -> f64 {
    m.iter().map(|r| dot(*r, *r)).sum()
}

/// The inverse of a symmetric positive definite 3 x 3 matrix (by cofactors; the callers' matrices
/// have a positive diagonal shift, so the determinant is positive).
fn inverse_spd(m: Mat3) -> Mat3 {
    let c = |r: usize, k: usize| {
        let (r1, r2, k1, k2) = ((r + 1) % 3, (r + 2) % 3, (k + 1) % 3, (k + 2) % 3);
        m[r1][k1] * m[r2][k2] - m[r1][k2] * m[r2][k1]
    };
    let det = m[0][0] * c(0, 0) + m[0][1] * c(0, 1) + m[0][2] * c(0, 2);
    [0, 1, 2].map(|r| [0, 1, 2].map(|k| c(k, r) / det))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::geometry::mean_edge_length;
    use crate::synth::icosphere;

    /// A level-1 sphere and a smooth non-rigid deformation of it.
    fn case() -> (crate::mesh::Shape, Vec<[f64; 3]>) {
        let s = icosphere(1);
        let x = s
            .positions
            .iter()
            .map(|q| {
                [
                    1.2 * q[0] + 0.1 * q[2],
                    q[1] * (1.0 + 0.3 * q[2]),
                    0.8 * q[2] + 0.05,
                ]
            })
            .collect();
        (s, x)
    }

    #[test]
    fn smooth_maps_gradient_matches_finite_differences() {
        let (s, x) = case();
        let fans = fans(&s.topology, &s.positions, &x);
        let lbar = mean_edge_length(&s.topology, &s.positions);
        let f = SmoothMaps::new(&s.topology, &fans, lbar);
        let a: Vec<Mat3> = f.solve(2);
        let g = f.gradient(&a);
        let h = 1e-6;
        for (v, r, k) in [(0, 0, 0), (3, 1, 2), (17, 2, 1), (41, 0, 2)] {
            let (mut ap, mut am) = (a.clone(), a.clone());
            ap[v][r][k] += h;
            am[v][r][k] -= h;
            let fd = (f.energy(&ap) - f.energy(&am)) / (2.0 * h);
            assert!(
                (fd - g[v][r][k]).abs() < 1e-6 * (1.0 + fd.abs()),
                "{v} {r} {k}: {fd} vs {}",
                g[v][r][k]
            );
        }
    }

    #[test]
    fn sweeps_descend_to_the_minimizer() {
        let (s, x) = case();
        let fans = fans(&s.topology, &s.positions, &x);
        let lbar = mean_edge_length(&s.topology, &s.positions);
        let f = SmoothMaps::new(&s.topology, &fans, lbar);
        let gmax = |a: &[Mat3]| {
            f.gradient(a)
                .iter()
                .flatten()
                .flatten()
                .fold(0.0f64, |m, v| m.max(v.abs()))
        };
        let e: Vec<f64> = [0, 1, SWEEPS, 400]
            .iter()
            .map(|&n| f.energy(&f.solve(n)))
            .collect();
        assert!(e.windows(2).all(|w| w[1] <= w[0] + 1e-12), "{e:?}");
        let scale = fans.iter().map(|f| f.uu).fold(0.0f64, f64::max);
        assert!(gmax(&f.solve(400)) < 1e-9 * scale, "{}", gmax(&f.solve(400)));
        // The default sweeps get within 1 % of the way from the start's energy to the minimum.
        assert!((e[2] - e[3]) < 0.01 * (e[0] - e[3]), "{e:?}");
    }

    #[test]
    fn an_affine_deformation_is_free_and_a_rigid_one_keeps_rotations() {
        let s = icosphere(2);
        let lbar = mean_edge_length(&s.topology, &s.positions);
        // A uniform stretch along z: the smooth maps reproduce the stretched edges, rotations
        // and similarities cannot (all three agree on a rotation, below).
        let x: Vec<[f64; 3]> = s.positions.iter().map(|q| [q[0], q[1], 1.4 * q[2]]).collect();
        // The relative residual of the edge fans, sum |v - A u|^2 / sum |v|^2 (measured:
        // smooth 0.0014, arap 0.035, asap 0.018).
        let residual = |prior| {
            let a = maps(&s.topology, &s.positions, &x, prior, lbar);
            let (mut r, mut n) = (0.0, 0.0);
            for (i, ai) in a.iter().enumerate() {
                for &j in s.topology.neighbors(i) {
                    let u = sub(s.positions[i], s.positions[j as usize]);
                    let v = sub(x[i], x[j as usize]);
                    let d = sub(v, ai.map(|row| dot(row, u)));
                    r += dot(d, d);
                    n += dot(v, v);
                }
            }
            r / n
        };
        let (smooth, arap, asap) = (
            residual(Prior::Smooth),
            residual(Prior::Arap),
            residual(Prior::Asap),
        );
        assert!(
            smooth < 3e-3 && arap > 2e-2 && asap > 1e-2,
            "{smooth} {arap} {asap}"
        );
        // A rotation: every prior returns it.
        let rot = crate::align::rotation_about([0.3, -0.5, 0.8], 0.9);
        let y: Vec<[f64; 3]> = s.positions.iter().map(|q| rot.map(|row| dot(row, *q))).collect();
        for prior in [Prior::Arap, Prior::Asap, Prior::Smooth] {
            for a in maps(&s.topology, &s.positions, &y, prior, lbar) {
                assert!(frobenius2(sub3(a, rot)) < 1e-20, "{prior:?}");
            }
        }
    }
}
