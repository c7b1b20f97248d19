//! Deformation transfer (paper section 2.2.2, docs/method.md "Deformation transfer").
//!
//! A deformation `M_0 .. M_K` (poses #V x 3) is carried to a new base `N_0`: for
//! `k = 0 .. K-1`, the discrete geodesic `gamma_k` from `M_k` to `N_k` is computed, the segment
//! `X_k = M_{k+1} - M_k` is transported along its samples to `Y_k`, and `N_{k+1} = N_k + Y_k`.
//! [`Transport::Translate`] is the baseline `N_k = N_0 + M_k - M_0`.
//!
//! All shapes are scaled by one common factor before the geodesics and the transport
//! ([`TransferOptions::normalization`]; [`Normalization::MeanEdgeOfFirst`] uses the base
//! `N_0`, so all deformations transferred to one base share it); poses are returned in the
//! input's units.
//!
//! For many deformations on one topology, build a [`TransferSetup`] once (metric, transport
//! metric, options), then one [`Transfer`] from it (its geodesic solvers, with their symbolic
//! factorizations, are built once), and call [`Transfer::run`] for each deformation; a
//! [`Transfer`] is `Sync`, so the runs can go to rayon's `par_iter`.

use std::sync::Arc;
use std::time::Instant;

use super::parallel::{parallel_transport, ParallelOptions, StepDiagnostics};
use super::schild::{schild_ladder, RungDiagnostics, SchildOptions};
use super::{difference, TransportError, TransportMetric};
use crate::geodesic::{normalization_factor, GeodesicOptions, GeodesicSolver, Normalization, SolveContext};
use crate::mesh::{Shape, Topology};
use crate::metric::{Calibration, Metric, MetricSpec};

/// How a deformation segment is carried to the new base. No `Default`: the pipeline's default
/// is [`crate::defaults::TRANSPORT`] (translation), while carrying one vector along a curve
/// means parallel transport; callers say which they want.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Transport {
    /// The paper's discrete parallel transport along the geodesic ([`parallel_transport`]).
    Parallel,
    /// Schild's ladder along the geodesic ([`schild_ladder`]).
    Schild,
    /// Translation ("Euclidean transfer"), `N_k = N_0 + (M_k - M_0)`: each displacement of the
    /// source is added to the base unchanged. This is no transport along a path (no geodesics,
    /// no metric); it is the identity map of flat space and the measured best choice for
    /// classification. Its label, serialized name and command-line value stay `euclidean` for
    /// compatibility (`translate` is accepted as well). Formerly `Transport::Euclidean`.
    #[serde(rename = "euclidean")]
    Translate,
}

impl Transport {
    /// `"parallel"`, `"schild"` or `"euclidean"` ([`Transport::Translate`]).
    pub fn label(self) -> &'static str {
        match self {
            Transport::Parallel => "parallel",
            Transport::Schild => "schild",
            Transport::Translate => "euclidean",
        }
    }
}

impl std::str::FromStr for Transport {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "parallel" => Ok(Transport::Parallel),
            "schild" => Ok(Transport::Schild),
            "euclidean" | "translate" => Ok(Transport::Translate),
            _ => Err(format!(
                "unknown transport '{s}' (expected parallel, schild or euclidean)"
            )),
        }
    }
}

/// Options of the transfer.
#[derive(Debug, Clone)]
pub struct TransferOptions {
    /// Options of the geodesics `gamma_k` (their `steps` = number of transport steps J).
    /// Schild's rungs use the same options with `steps = 2`.
    pub geodesic: GeodesicOptions,
    /// The common scale factor ([`Normalization::MeanEdgeOfFirst`]: of the base `N_0`; pass
    /// [`Normalization::Factor`] to share one factor between different bases).
    pub normalization: Normalization,
    /// Options of the parallel transport steps.
    pub parallel: ParallelOptions,
    /// Options of Schild's ladder.
    pub schild: SchildOptions,
}

impl Default for TransferOptions {
    fn default() -> Self {
        TransferOptions {
            geodesic: GeodesicOptions::default(),
            normalization: Normalization::MeanEdgeOfFirst,
            parallel: ParallelOptions::default(),
            schild: SchildOptions::default(),
        }
    }
}

/// Diagnostics of one transferred segment `X_k -> Y_k`.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct SegmentReport {
    /// Length of `gamma_k` (the metric's units; 0 for Euclidean transfer).
    pub geodesic_length: f64,
    /// Iterations of the geodesic solver.
    pub geodesic_iterations: usize,
    /// Whether the geodesic solver converged (true for Euclidean transfer).
    pub geodesic_converged: bool,
    /// `sqrt(<<X_k, X_k>>_{M_k})` (transport metric, frozen weights of `gamma_k`'s ends;
    /// normalized units).
    pub input_norm: f64,
    /// `sqrt(<<Y_k, Y_k>>_{N_k})` (same weights): equals `input_norm` for parallel transport.
    pub output_norm: f64,
    /// Largest relative inner-product residual of the parallel transport steps (0 otherwise).
    pub max_inner_residual: f64,
    /// Largest relative norm residual of the parallel transport steps (0 otherwise).
    pub max_norm_residual: f64,
    /// Per-step diagnostics (parallel transport).
    pub steps: Vec<StepDiagnostics>,
    /// Per-rung diagnostics (Schild's ladder).
    pub rungs: Vec<RungDiagnostics>,
    /// Wall-clock seconds of this segment.
    pub seconds: f64,
}

/// A transferred deformation.
#[derive(Debug, Clone)]
pub struct Transferred {
    /// The poses `N_0 .. N_K` (each #V x 3), in the input's units (`N_0` is the base, bit-exact).
    pub poses: Vec<Vec<[f64; 3]>>,
    /// One report per segment (K entries).
    pub segments: Vec<SegmentReport>,
    /// The method used.
    pub method: Transport,
    /// The factor coordinates were multiplied by for the geodesics and the transport.
    pub scale: f64,
    /// Wall-clock seconds in all.
    pub seconds: f64,
}

/// What a transfer needs for one (metric, topology, options): the metric of the geodesics, the
/// transport metric (its quadratic companion) and the options. `Send + Sync`.
#[derive(Debug)]
pub struct TransferSetup {
    metric: Arc<dyn Metric>,
    transport: TransportMetric,
    topo: Arc<Topology>,
    options: TransferOptions,
}

impl TransferSetup {
    /// Builds the metrics of `spec` on `topo` with the factors `calibration` of the analysis
    /// ([`MetricSpec::calibrate`] on the base, in the solver's coordinates of
    /// [`TransferOptions::normalization`]). Errors on invalid options (no geodesic steps,
    /// negative or NaN `lambda`).
    pub fn new(
        spec: &MetricSpec,
        calibration: &Calibration,
        topo: Arc<Topology>,
        options: TransferOptions,
    ) -> Result<Self, TransportError> {
        spec.validate()?;
        Self::with_metric(
            spec,
            Arc::from(spec.build(calibration)),
            calibration,
            topo,
            options,
        )
    }

    /// [`TransferSetup::new`] with the metric of the geodesics already built (`spec` with the
    /// factors `calibration`), so that a run that builds its metric once passes it down
    /// (`crate::similarity::prepare`). Errors on invalid geodesic options.
    pub fn with_metric(
        spec: &MetricSpec,
        metric: Arc<dyn Metric>,
        calibration: &Calibration,
        topo: Arc<Topology>,
        options: TransferOptions,
    ) -> Result<Self, TransportError> {
        options.geodesic.validate()?;
        Ok(TransferSetup {
            metric,
            transport: TransportMetric::new(spec, calibration, topo.clone()),
            topo,
            options,
        })
    }

    /// The metric of the geodesics.
    pub fn metric(&self) -> &dyn Metric {
        self.metric.as_ref()
    }

    /// The transport metric (quadratic companion).
    pub fn transport_metric(&self) -> &TransportMetric {
        &self.transport
    }

    /// The topology.
    pub fn topology(&self) -> &Arc<Topology> {
        &self.topo
    }

    /// The options.
    pub fn options(&self) -> &TransferOptions {
        &self.options
    }

    /// The reusable transfer: builds the geodesic solvers (N = `steps` for `gamma_k`, N = 2 for
    /// Schild's rungs) once.
    pub fn solver(&self) -> Result<Transfer<'_>, TransportError> {
        let geodesics = GeodesicSolver::new(self.metric(), self.topo.clone(), self.options.geodesic.clone())?;
        let rungs = GeodesicSolver::new(
            self.metric(),
            self.topo.clone(),
            GeodesicOptions {
                steps: 2,
                ..self.options.geodesic.clone()
            },
        )?;
        Ok(Transfer {
            setup: self,
            geodesics,
            rungs,
        })
    }
}

/// A reusable deformation transfer for one [`TransferSetup`] (see the [module docs](self)).
pub struct Transfer<'s> {
    setup: &'s TransferSetup,
    geodesics: GeodesicSolver<'s>,
    rungs: GeodesicSolver<'s>,
}

impl Transfer<'_> {
    /// Transfers the deformation `M_0 .. M_K` (shapes on the setup's topology) to `base`.
    /// Errors if a shape does not have the setup's connectivity.
    pub fn run_shapes(
        &self,
        deformation: &[Shape],
        base: &Shape,
        method: Transport,
    ) -> Result<Transferred, TransportError> {
        let reference = Shape {
            topology: self.setup.topo.clone(),
            positions: vec![[0.0; 3]; self.setup.topo.n_vertices()],
        };
        let check = |s: &Shape, what: String| -> Result<(), TransportError> {
            reference
                .check_same_topology(s)
                .map_err(|error| TransportError::Mismatch { what, error })
        };
        check(base, "the base".into())?;
        for (k, s) in deformation.iter().enumerate() {
            check(s, format!("pose {k} of the deformation"))?;
        }
        let poses: Vec<Vec<[f64; 3]>> = deformation.iter().map(|s| s.positions.clone()).collect();
        self.run(&poses, &base.positions, method)
    }

    /// Transfers the deformation `M_0 .. M_K` (each #V x 3 on the setup's topology) to `base`
    /// (#V x 3): returns `N_0 .. N_K`. Errors on an empty deformation, wrong vertex counts,
    /// non-finite coordinates, a failing geodesic or transport.
    pub fn run(
        &self,
        deformation: &[Vec<[f64; 3]>],
        base: &[[f64; 3]],
        method: Transport,
    ) -> Result<Transferred, TransportError> {
        let t0 = Instant::now();
        let nv = self.setup.topo.n_vertices();
        if deformation.is_empty() {
            return Err(TransportError::Empty {
                what: "deformation",
                items: "poses",
            });
        }
        for (what, p) in std::iter::once(("the base".to_string(), base)).chain(
            deformation
                .iter()
                .enumerate()
                .map(|(k, p)| (format!("pose {k}"), p.as_slice())),
        ) {
            if p.len() != nv {
                return Err(TransportError::VertexCount {
                    what,
                    got: p.len(),
                    expected: nv,
                });
            }
            if p.iter().flatten().any(|c| !c.is_finite()) {
                return Err(TransportError::NonFinite {
                    what: format!("{what}'s coordinates"),
                });
            }
        }
        let f = normalization_factor(self.setup.options.normalization, &self.setup.topo, base);
        if !(f.is_finite() && f > 0.0) {
            return Err(TransportError::Normalization { factor: f });
        }
        let scale = |p: &[[f64; 3]]| -> Vec<[f64; 3]> { p.iter().map(|v| v.map(|c| c * f)).collect() };
        let mut poses = vec![base.to_vec()];
        let mut segments = Vec::with_capacity(deformation.len() - 1);
        if method == Transport::Translate {
            for m in &deformation[1..] {
                let n: Vec<[f64; 3]> = base
                    .iter()
                    .zip(m)
                    .zip(&deformation[0])
                    .map(|((b, m), m0)| {
                        [
                            b[0] + (m[0] - m0[0]),
                            b[1] + (m[1] - m0[1]),
                            b[2] + (m[2] - m0[2]),
                        ]
                    })
                    .collect();
                poses.push(n);
            }
        }
        // The geodesics M_k -> N_k of consecutive poses share a preconditioner fit, and each
        // starts from the previous one.
        let mut ctx = SolveContext::default();
        let mut previous = None;
        for k in 0..deformation.len() - 1 {
            let ts = Instant::now();
            let (mk, mk1) = (scale(&deformation[k]), scale(&deformation[k + 1]));
            let nk = scale(&poses[k]);
            let x = difference(&mk, &mk1);
            let mut report = SegmentReport::default();
            let (y, frozen) = match method {
                Transport::Translate => {
                    report.geodesic_converged = true;
                    let frozen = self.setup.transport.frozen_weights(&mk, &nk);
                    let nk1 = scale(&poses[k + 1]);
                    (difference(&nk, &nk1), frozen)
                }
                Transport::Parallel | Transport::Schild => {
                    let g = self.geodesics.solve_near(&mut ctx, &mk, &nk, previous.as_ref())?;
                    report.geodesic_length = g.length;
                    report.geodesic_iterations = g.iterations;
                    report.geodesic_converged = g.converged;
                    let frozen = self.setup.transport.frozen_weights(&mk, &nk);
                    let y = if method == Transport::Parallel {
                        let t = parallel_transport(
                            &self.setup.transport,
                            &g.poses,
                            &x,
                            &self.setup.options.parallel,
                        )?;
                        report.max_inner_residual = t.max_inner_residual();
                        report.max_norm_residual = t.max_norm_residual();
                        report.steps = t.steps;
                        t.vector
                    } else {
                        let t = schild_ladder(&self.rungs, &g.poses, &x, &self.setup.options.schild)?;
                        report.rungs = t.rungs;
                        t.vector
                    };
                    previous = Some(g);
                    (y, frozen)
                }
            };
            let gm = self.setup.transport.at(&mk, frozen.as_deref())?;
            report.input_norm = gm.squared_norm(&x).max(0.0).sqrt();
            let gn = self.setup.transport.at(&nk, frozen.as_deref())?;
            report.output_norm = gn.squared_norm(&y).max(0.0).sqrt();
            if method != Transport::Translate {
                let next: Vec<[f64; 3]> = poses[k]
                    .iter()
                    .zip(&y)
                    .map(|(n, d)| [n[0] + d[0] / f, n[1] + d[1] / f, n[2] + d[2] / f])
                    .collect();
                poses.push(next);
            }
            report.seconds = ts.elapsed().as_secs_f64();
            segments.push(report);
        }
        Ok(Transferred {
            poses,
            segments,
            method,
            scale: f,
            seconds: t0.elapsed().as_secs_f64(),
        })
    }
}

/// Transfers the deformation `M_0 .. M_K` (shapes of one topology) to `base` with `method`
/// (convenience for one deformation: builds a [`TransferSetup`] and a [`Transfer`]). Errors if
/// the shapes do not share the base's topology.
pub fn transfer(
    spec: &MetricSpec,
    deformation: &[Shape],
    base: &Shape,
    method: Transport,
    options: &TransferOptions,
) -> Result<Transferred, TransportError> {
    let f = normalization_factor(options.normalization, &base.topology, &base.positions);
    let scaled = crate::mesh::geometry::scaled(&base.positions, f);
    let calibration = spec
        .calibrate(&base.topology, &[&scaled])
        .map_err(crate::geodesic::GeodesicError::from)?;
    let setup = TransferSetup::new(spec, &calibration, base.topology.clone(), options.clone())?;
    setup.solver()?.run_shapes(deformation, base, method)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transfer_is_shareable_across_threads() {
        fn sync<T: Sync + Send>() {}
        sync::<TransferSetup>();
        sync::<Transfer<'static>>();
    }

    #[test]
    fn transport_names_parse() {
        for t in [Transport::Parallel, Transport::Schild, Transport::Translate] {
            assert_eq!(t.label().parse::<Transport>().unwrap(), t);
        }
        assert!("bogus".parse::<Transport>().is_err());
    }
}
