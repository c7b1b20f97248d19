//! The shape space as one value: a [`ShapeSpace`] owns its topology, its metric and the geodesic
//! options, and offers the operations a geomstats user expects (`squared_norm`, `inner`,
//! `geodesic`, `dist`, `log`, `transport`, `karcher_mean`, `interpolate`, `transfer`, pairwise
//! distances), each a thin call into [`crate::geodesic`], [`crate::transport`] and
//! [`crate::similarity`]. It holds no borrowed lifetimes (the metric is an `Arc`), so a binding
//! (Python) can keep it, clone it cheaply and share it between threads.
//!
//! Shapes (poses) are #V x 3 position arrays on the space's topology, tangent vectors #V x 3
//! displacement arrays, both in the caller's length unit. Each call works in [`Units`]: its
//! coordinates multiplied by the factor of the space's [`Normalization`] (default: 1 / the mean
//! edge length of the call's reference shapes) and the metric calibrated on those shapes
//! ([`MetricSpec::calibrate`]). The reference shapes of `geodesic`, `dist` and `log` are both
//! ends, as for `qcshape geodesic`, so `dist(a, b) = dist(b, a)`; of the other calls, the first
//! shape (or the base). Lengths, squared norms and energies are in the metric's units
//! ([`crate::metric::MetricScale`]), poses and vectors in the caller's units.
//! [`ShapeSpace::normalized_to`] fixes one set of units for every call.

use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use thiserror::Error;

use crate::cluster::{
    intrinsic_kmeans, karcher_mean, log_map, IntrinsicClustering, IntrinsicError, IntrinsicOptions,
    KarcherMean, KarcherOptions,
};
use crate::dataset::Deformation;
use crate::geodesic::{
    self, normalization_factor, Geodesic, GeodesicError, GeodesicOptions, GeodesicSolver, Interpolated,
    InterpolationError, InterpolationOptions, Interpolator, Normalization, SolveContext,
};
use crate::limits::LimitError;
use crate::mesh::geometry::scaled;
use crate::mesh::{MeshError, Shape, Topology};
use crate::metric::{At, Calibration, Metric, MetricSpec, Segment};
use crate::similarity::{
    compute, similarity_matrix, Comparison, DistanceMatrix, Event, MatrixError, PairDistance, PipelineError,
    PipelineOptions, Pose, Prepared, Run, Selection, SimilarityError,
};
use crate::transport::{
    euclidean_transport, parallel_transport, schild_ladder, ParallelOptions, SchildOptions, TransferOptions,
    TransferSetup, Transferred, Transport, TransportError, TransportMetric,
};

/// Why a shape-space operation failed; each variant keeps the library error it wraps.
#[derive(Debug, Error)]
pub enum SpaceError {
    /// A shape does not fit the topology (vertex count, non-finite coordinates).
    #[error("{what}: {error}")]
    Shape {
        /// Which argument.
        what: String,
        /// What is wrong with it.
        error: MeshError,
    },
    /// A metric setting out of its range (`lambda`, `stretch`) or not available with the
    /// metric's scale.
    #[error(transparent)]
    Setting(#[from] LimitError),
    /// An empty input: `what` has no `items`.
    #[error("the {what} has no {items}")]
    Empty {
        /// The argument: "curve", "sequence", "Karcher mean's input", "reference list".
        what: &'static str,
        /// What it lacks: "samples", "poses", "shapes".
        items: &'static str,
    },
    /// [`ShapeSpace::similarity_matrix`] was given a shard of the pairs.
    #[error("similarity_matrix computes every pair (use crate::similarity::compute for a shard)")]
    Shard,
    /// A geodesic could not be set up or solved.
    #[error(transparent)]
    Geodesic(#[from] GeodesicError),
    /// A transport or transfer failed.
    #[error(transparent)]
    Transport(#[from] TransportError),
    /// The temporal interpolation failed.
    #[error(transparent)]
    Interpolation(#[from] InterpolationError),
    /// The similarity pipeline failed.
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
    /// A pairwise computation failed (or was cancelled).
    #[error(transparent)]
    Similarity(#[from] SimilarityError),
    /// The distance matrix could not be formed.
    #[error(transparent)]
    Matrix(#[from] MatrixError),
    /// The intrinsic k-means failed.
    #[error(transparent)]
    Intrinsic(#[from] IntrinsicError),
}

/// The ends `(start, end)` of a curve, each #V x 3 (they fix the frozen weights of an inner
/// product, [`ShapeSpace::inner`]).
pub type CurveEnds<'a> = (&'a [[f64; 3]], &'a [[f64; 3]]);

/// The similarity matrix of a data set and everything the pipeline computed on the way.
#[derive(Debug, Clone)]
pub struct SimilarityResult {
    /// Interpolated and transferred deformations ([`crate::similarity::prepare`]).
    pub prepared: Prepared,
    /// Every pair `i < j` in row order, with its per-pose distances.
    pub pairs: Vec<PairDistance>,
    /// The symmetric n x n matrix of eq. 13 (dimensionless on the default invariant scale; on the
    /// calibrated and raw scales in mean-edge units, coordinates divided by the mean edge length
    /// of the base pose).
    pub matrix: DistanceMatrix,
}

/// The units of one shape-space call: the factor coordinates are multiplied by before solving
/// and the metric's calibrated factors in those coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Units {
    /// Coordinates are multiplied by this factor (> 0).
    pub factor: f64,
    /// The metric's factors ([`MetricSpec::calibrate`] on the call's reference shapes).
    pub calibration: Calibration,
}

/// A shape space on one topology with one metric (paper section 2; see the [module docs](self)).
/// Cheap to clone (shared `Arc`s) and `Send + Sync`.
#[derive(Debug, Clone)]
pub struct ShapeSpace {
    topology: Arc<Topology>,
    spec: MetricSpec,
    geodesic: GeodesicOptions,
    normalization: Normalization,
    /// One set of units for every call ([`ShapeSpace::normalized_to`]).
    fixed: Option<Units>,
}

impl ShapeSpace {
    /// The shape space of `topology` (F, #F x 3) with the metric `spec` (`G + lambda L2`,
    /// eqs. 1-11) and the geodesic options (eq. 12). Errors on a negative or NaN `lambda` and on
    /// options the geodesic solver rejects (no steps, negative tolerances).
    pub fn new(
        topology: Arc<Topology>,
        spec: MetricSpec,
        geodesic: GeodesicOptions,
    ) -> Result<Self, SpaceError> {
        spec.validate()?;
        geodesic.check()?;
        Ok(ShapeSpace {
            topology,
            spec,
            geodesic,
            normalization: Normalization::MeanEdgeOfBoth,
            fixed: None,
        })
    }

    /// The same space with another normalization of the coordinates (the metric is still
    /// calibrated on each call's reference shapes).
    pub fn with_normalization(mut self, normalization: Normalization) -> Self {
        self.normalization = normalization;
        self.fixed = None;
        self
    }

    /// The same space with one set of units for every call: the factor 1 / the mean edge
    /// length of `reference` (#V x 3) and the metric calibrated on it. Then `dist` is a true
    /// metric (symmetric for any pair) and equals [`ShapeSpace::pairwise_distances`]. Errors
    /// if `reference` does not fit the topology.
    pub fn normalized_to(mut self, reference: &[[f64; 3]]) -> Result<Self, SpaceError> {
        self.shape("the reference", reference)?;
        self.fixed = None;
        let units = self.units(&[reference])?;
        self.fixed = Some(units);
        Ok(self)
    }

    /// The same space with other geodesic options (checked as in [`ShapeSpace::new`]).
    pub fn with_geodesic(mut self, geodesic: GeodesicOptions) -> Result<Self, SpaceError> {
        geodesic.check()?;
        self.geodesic = geodesic;
        Ok(self)
    }

    /// The units of a call whose reference shapes are `refs` (each #V x 3, input units): the
    /// fixed units of [`ShapeSpace::normalized_to`], else the factor of the space's
    /// [`Normalization`] (mean-edge normalizations: 1 / the mean of the references' mean edge
    /// lengths) and the metric calibrated on the scaled references.
    pub fn units(&self, refs: &[&[[f64; 3]]]) -> Result<Units, SpaceError> {
        if let Some(u) = self.fixed {
            return Ok(u);
        }
        let Some(first) = refs.first() else {
            return Err(SpaceError::Empty {
                what: "reference list",
                items: "shapes",
            });
        };
        let factor = match self.normalization {
            Normalization::MeanEdgeOfFirst | Normalization::MeanEdgeOfBoth => {
                let mean = refs
                    .iter()
                    .map(|r| crate::mesh::geometry::mean_edge_length(&self.topology, r))
                    .sum::<f64>()
                    / refs.len() as f64;
                1.0 / mean.max(f64::MIN_POSITIVE)
            }
            n => normalization_factor(n, &self.topology, first),
        };
        if !(factor.is_finite() && factor > 0.0) {
            return Err(GeodesicError::Normalization { factor }.into());
        }
        let scaled_refs: Vec<Pose> = refs.iter().map(|r| scaled(r, factor)).collect();
        let views: Vec<&[[f64; 3]]> = scaled_refs.iter().map(Vec::as_slice).collect();
        let calibration = self
            .spec
            .calibrate(&self.topology, &views)
            .map_err(GeodesicError::from)?;
        Ok(Units { factor, calibration })
    }

    /// The space's metric in `units`.
    pub fn metric(&self, units: &Units) -> Box<dyn Metric> {
        self.spec.build(&units.calibration)
    }

    /// The topology (#V vertices, #F faces).
    pub fn topology(&self) -> &Arc<Topology> {
        &self.topology
    }

    /// The metric specification.
    pub fn spec(&self) -> &MetricSpec {
        &self.spec
    }

    /// The metric's description ([`MetricSpec::label`]).
    pub fn metric_label(&self) -> String {
        self.spec.label()
    }

    /// The geodesic options (`steps` = N segments of every geodesic).
    pub fn geodesic_options(&self) -> &GeodesicOptions {
        &self.geodesic
    }

    /// The normalization of coordinates before solving.
    pub fn normalization(&self) -> Normalization {
        self.normalization
    }

    /// A reusable geodesic solver of `metric` (from [`ShapeSpace::metric`]) with `steps`
    /// segments (its symbolic factorization is built once; use it for many pairs of poses
    /// already scaled to the metric's units).
    pub fn solver<'m>(&self, metric: &'m dyn Metric, steps: usize) -> Result<GeodesicSolver<'m>, SpaceError> {
        let opts = GeodesicOptions {
            steps,
            ..self.geodesic.clone()
        };
        Ok(GeodesicSolver::new(metric, self.topology.clone(), opts)?)
    }

    /// The pipeline options of this space: its metric and geodesic options, every other field
    /// from `template` (e.g. [`PipelineOptions::default`] with `insert` set).
    pub fn pipeline_options(&self, template: PipelineOptions) -> PipelineOptions {
        PipelineOptions {
            metric: self.spec,
            geodesic: self.geodesic.clone(),
            ..template
        }
    }

    /// `G_M(X) = <<X, X>>_M`, the metric's squared norm of the tangent vector `v` (#V x 3) at
    /// `base` = M (#V x 3): the first term of eq. 12 for the segment from `M` to `M + X`, with
    /// the weights that segment freezes (quasi-conformal endpoint weights, L2 areas). Normalized
    /// units squared.
    pub fn squared_norm(&self, base: &[[f64; 3]], v: &[[f64; 3]]) -> Result<f64, SpaceError> {
        self.shape("the base", base)?;
        self.vector("the tangent vector", v)?;
        let u = self.units(&[base])?;
        let f = u.factor;
        let metric = self.metric(&u);
        let a = scaled(base, f);
        let b: Vec<[f64; 3]> = a
            .iter()
            .zip(v)
            .map(|(p, d)| [0, 1, 2].map(|c| p[c] + f * d[c]))
            .collect();
        let frozen = metric.frozen_weights(&self.topology, &a, &b);
        let seg = Segment {
            a: &a,
            b: &b,
            at: At::Start,
            aux: &[],
            frozen: frozen.as_deref(),
        };
        Ok(metric.squared_norm(&self.topology, &metric.pattern(&self.topology), &seg))
    }

    /// The inner product `<<u, v>>_M` at `base` = M (each #V x 3): the polarization of the
    /// transport metric (the quadratic companion of the metric, [`TransportMetric`]), with the
    /// weights frozen by the curve `ends` = (start, end) (default: the constant curve at `base`,
    /// on which the quasi-conformal curvature change vanishes). `inner(M, v, v, (M, M + v))`
    /// equals [`ShapeSpace::squared_norm`]`(M, v)` for the quadratic forms. Normalized units
    /// squared.
    pub fn inner(
        &self,
        base: &[[f64; 3]],
        u: &[[f64; 3]],
        v: &[[f64; 3]],
        ends: Option<CurveEnds<'_>>,
    ) -> Result<f64, SpaceError> {
        self.shape("the base", base)?;
        self.vector("u", u)?;
        self.vector("v", v)?;
        let units = self.units(&[base])?;
        let f = units.factor;
        let (s, e) = ends.unwrap_or((base, base));
        self.shape("the curve's start", s)?;
        self.shape("the curve's end", e)?;
        let transport = TransportMetric::new(&self.spec, &units.calibration, self.topology.clone());
        let frozen = transport.frozen_weights(&scaled(s, f), &scaled(e, f));
        let g = transport.at(&scaled(base, f), frozen.as_deref())?;
        Ok(g.inner(&scaled(u, f), &scaled(v, f)))
    }

    /// The discrete geodesic from `a` to `b` (each #V x 3) with `N` = `steps` segments (eq.
    /// 12): poses `(N + 1) x #V x 3` in input units (ends bit-exact), length = `dis(a, b)`,
    /// energy (with its geometric and regularizer parts), iterations, convergence, in the units
    /// of both ends ([`ShapeSpace::units`]; the same geodesic as [`geodesic::geodesic_between`]).
    pub fn geodesic(&self, a: &[[f64; 3]], b: &[[f64; 3]]) -> Result<Geodesic, SpaceError> {
        let (sa, sb) = (
            self.shape("the first shape", a)?,
            self.shape("the second shape", b)?,
        );
        let u = self.units(&[a, b])?;
        let metric = self.metric(&u);
        Ok(geodesic::geodesic(
            metric.as_ref(),
            &sa,
            &sb,
            &self.geodesic,
            Normalization::Factor(u.factor),
        )?)
    }

    /// `dis(a, b)`: the length of the discrete geodesic (eq. 12, `L = sum_i sqrt((G_{P_i}(X_i) +
    /// G_{P_{i+1}}(X_i)) / 2)`), in the metric's units; exactly 0 for identical shapes (no solve,
    /// as in [`crate::similarity::pose_distances`]). A distance solve
    /// ([`GeodesicSolver::distance_near_with`]: stopped once the length has settled), the
    /// same number as [`Self::pairwise_distances`] gives for the pair.
    pub fn dist(&self, a: &[[f64; 3]], b: &[[f64; 3]]) -> Result<f64, SpaceError> {
        self.shape("the first shape", a)?;
        self.shape("the second shape", b)?;
        if a == b {
            return Ok(0.0);
        }
        let u = self.units(&[a, b])?;
        let f = u.factor;
        let metric = self.metric(&u);
        let solver = self.solver(metric.as_ref(), self.geodesic.steps)?;
        let g = solver.distance_near_with(
            &mut SolveContext::default(),
            &scaled(a, f),
            &scaled(b, f),
            None,
            None,
        )?;
        Ok(g.length)
    }

    /// The discrete log map `log_M(P) = N (P_1 - M)` (#V x 3, input units), `P_1` the first
    /// interior pose of the geodesic from `base` = M to `p` ([`log_map`]), and `dis(M, P)`
    /// (the metric's units).
    pub fn log(&self, base: &[[f64; 3]], p: &[[f64; 3]]) -> Result<(Pose, f64), SpaceError> {
        self.shape("the base", base)?;
        self.shape("the shape", p)?;
        let u = self.units(&[base, p])?;
        let f = u.factor;
        let metric = self.metric(&u);
        let solver = self.solver(metric.as_ref(), self.geodesic.steps)?;
        let (log, d) = log_map(&solver, &scaled(base, f), &scaled(p, f))?;
        Ok((scaled(&log, 1.0 / f), d))
    }

    /// Transports the tangent vector `v` (#V x 3, at `curve[0]`) along the samples of `curve`
    /// (each #V x 3; e.g. a geodesic's poses) to its last sample (input units): the paper's
    /// discrete parallel transport (section 2.2.2, [`parallel_transport`]), Schild's ladder
    /// ([`schild_ladder`]) or the Euclidean baseline (`v` unchanged).
    pub fn transport(&self, curve: &[Pose], v: &[[f64; 3]], method: Transport) -> Result<Pose, SpaceError> {
        let Some(first) = curve.first() else {
            return Err(SpaceError::Empty {
                what: "curve",
                items: "samples",
            });
        };
        for (j, s) in curve.iter().enumerate() {
            self.shape(&format!("curve sample {j}"), s)?;
        }
        self.vector("the vector", v)?;
        if method == Transport::Translate {
            // No scale needed: the vector comes back bit for bit.
            return Ok(euclidean_transport(curve, v).vector);
        }
        let u = self.units(&[first])?;
        let f = u.factor;
        let c: Vec<Pose> = curve.iter().map(|s| scaled(s, f)).collect();
        let w = scaled(v, f);
        let out = if method == Transport::Parallel {
            let transport = TransportMetric::new(&self.spec, &u.calibration, self.topology.clone());
            parallel_transport(&transport, &c, &w, &ParallelOptions::default())?.vector
        } else {
            let metric = self.metric(&u);
            schild_ladder(
                &self.solver(metric.as_ref(), 2)?,
                &c,
                &w,
                &SchildOptions::default(),
            )?
            .vector
        };
        Ok(scaled(&out, 1.0 / f))
    }

    /// The Karcher mean of `poses` (each #V x 3), started from `init` (default the first pose):
    /// `mu <- mu + step mean_k log_mu(P_k)`, damped ([`karcher_mean`], docs/method.md
    /// "Clustering"). The mean is in input
    /// units, the variance `sum_k dis(mu, P_k)^2` in the metric's units squared.
    pub fn karcher_mean(
        &self,
        poses: &[Pose],
        init: Option<&[[f64; 3]]>,
        opts: &KarcherOptions,
    ) -> Result<KarcherMean, SpaceError> {
        let Some(first) = poses.first() else {
            return Err(SpaceError::Empty {
                what: "Karcher mean's input",
                items: "poses",
            });
        };
        for (k, p) in poses.iter().enumerate() {
            self.shape(&format!("pose {k}"), p)?;
        }
        let init = init.unwrap_or(first);
        self.shape("the start", init)?;
        let u = self.units(&[first])?;
        let f = u.factor;
        let metric = self.metric(&u);
        let s: Vec<Pose> = poses.iter().map(|p| scaled(p, f)).collect();
        let refs: Vec<&[[f64; 3]]> = s.iter().map(Vec::as_slice).collect();
        let solver = self.solver(metric.as_ref(), self.geodesic.steps)?;
        let mut m = karcher_mean(&solver, &refs, &scaled(init, f), opts)?;
        m.mean = scaled(&m.mean, 1.0 / f);
        Ok(m)
    }

    /// Temporal interpolation (section 2.2.1): `insert` poses between each pair of consecutive
    /// key poses `poses` (K + 1, each #V x 3), on `levels` spatial levels (1 = none), all pairs
    /// in the factor of the first pose ([`Interpolator::interpolate_sequence`]). Returns
    /// `K (insert + 1) + 1` poses in input units. `progress` is called once per finished pair.
    pub fn interpolate(
        &self,
        poses: &[Pose],
        insert: usize,
        levels: usize,
        progress: &(dyn Fn() + Sync),
    ) -> Result<Interpolated, SpaceError> {
        let Some(first) = poses.first() else {
            return Err(SpaceError::Empty {
                what: "sequence",
                items: "poses",
            });
        };
        for (k, p) in poses.iter().enumerate() {
            self.shape(&format!("pose {k}"), p)?;
        }
        let u = self.units(&[first])?;
        let metric = self.metric(&u);
        let opts = InterpolationOptions {
            insert,
            levels,
            geodesic: self.geodesic.clone(),
            normalization: Normalization::Factor(u.factor),
            ..Default::default()
        };
        let interp = Interpolator::new(metric.as_ref(), &self.topology, first, opts)?;
        Ok(interp.interpolate_sequence(poses, progress)?)
    }

    /// Deformation transfer (section 2.2.2): carries `poses` = `M_0 .. M_K` (each #V x 3) to
    /// `base` = `N_0`, returning `N_0 .. N_K` (input units; `N_0` bit-exact) with per-segment
    /// diagnostics ([`TransferSetup`], [`crate::transport::Transfer::run`]), in the factor of `base`.
    pub fn transfer(
        &self,
        poses: &[Pose],
        base: &[[f64; 3]],
        method: Transport,
    ) -> Result<Transferred, SpaceError> {
        self.shape("the base", base)?;
        let u = self.units(&[base])?;
        let opts = TransferOptions {
            geodesic: self.geodesic.clone(),
            normalization: Normalization::Factor(u.factor),
            ..Default::default()
        };
        let setup = TransferSetup::new(&self.spec, &u.calibration, self.topology.clone(), opts)?;
        Ok(setup.solver()?.run(poses, base, method)?)
    }

    /// The n x n matrix (row-major, zero diagonal) of `dis(P_i, P_j)` between the shapes
    /// `poses` (each #V x 3), pairs in parallel on the current rayon pool, all in the factor of
    /// the first shape. `cancel`, when set, stops between pairs.
    pub fn pairwise_distances(
        &self,
        poses: &[Pose],
        cancel: Option<&AtomicBool>,
    ) -> Result<Vec<f64>, SpaceError> {
        let singles: Vec<Vec<Pose>> = poses.iter().map(|p| vec![p.clone()]).collect();
        self.similarity(&singles, cancel, &|_| {})
    }

    /// Eq. 13 for deformations already at one common base: the n x n matrix (row-major) of
    /// `similarity(M, N) = sum_k dis(M_k, N_k)` of `deformations` (n x #poses x #V x 3, one pose
    /// count), all in the factor of the first pose of the first deformation ([`compute`]).
    /// `on_pair` sees each finished pair (from worker threads).
    pub fn similarity(
        &self,
        deformations: &[Vec<Pose>],
        cancel: Option<&AtomicBool>,
        on_pair: &(dyn Fn(&PairDistance) + Sync),
    ) -> Result<Vec<f64>, SpaceError> {
        let Some(first) = deformations.first().and_then(|d| d.first()) else {
            return Ok(vec![0.0; 0]);
        };
        for (i, d) in deformations.iter().enumerate() {
            for (k, p) in d.iter().enumerate() {
                self.shape(&format!("deformation {i}, pose {k}"), p)?;
            }
        }
        let u = self.units(&[first])?;
        let names: Vec<String> = (0..deformations.len()).map(|i| i.to_string()).collect();
        let metric = self.metric(&u);
        let input = Comparison {
            names: &names,
            topology: self.topology.clone(),
            metric: metric.as_ref(),
            factor: u.factor,
            poses: deformations,
        };
        let run = Run {
            cancel,
            events: &|e| {
                if let Event::Pair(p) = e {
                    on_pair(p)
                }
            },
            ..Default::default()
        };
        let outcome = compute(&input, &self.pipeline_options(PipelineOptions::default()), &run)?;
        Ok(outcome.matrix.expect("all pairs").values().to_vec())
    }

    /// The whole pipeline of the paper (Fig. 1, eq. 13) on raw deformations, as `qcshape
    /// similarity` runs it: [`similarity_matrix`] (interpolation, transfer to the first pose of
    /// `template.base`, then every pair through the one similarity engine) with this space's
    /// metric and geodesic options and every other option from `template`. The normalization is
    /// the pipeline's (mean edge of the base pose), not the space's. `run` chooses the pairs'
    /// sink (memory, or a journal that a killed run resumes from with `resume`), the cancel flag
    /// and the progress events; a journal is removed once the matrix is returned.
    pub fn similarity_matrix(
        &self,
        deformations: &[Deformation],
        template: PipelineOptions,
        run: &Run<'_>,
    ) -> Result<SimilarityResult, SpaceError> {
        if run.selection != Selection::All {
            return Err(SpaceError::Shard);
        }
        let opts = self.pipeline_options(template);
        let (prepared, mut outcome) = similarity_matrix(deformations, &opts, run)?;
        outcome.finish()?;
        Ok(SimilarityResult {
            prepared,
            pairs: outcome.pairs,
            matrix: outcome.matrix.expect("all pairs"),
        })
    }

    /// k-means with intrinsic means (eq. 14) of prepared deformations, started from the
    /// partition `start` (n values in 0..k, e.g. kernel k-means of their matrix):
    /// [`intrinsic_kmeans`] on [`Prepared::scaled`] with this space's metric.
    pub fn intrinsic_kmeans(
        &self,
        prepared: &Prepared,
        start: &[usize],
        k: usize,
        opts: &IntrinsicOptions,
    ) -> Result<IntrinsicClustering, SpaceError> {
        let metric = prepared.metric(&self.spec);
        let solver = self.solver(metric.as_ref(), self.geodesic.steps)?;
        Ok(intrinsic_kmeans(&solver, &prepared.scaled(), start, k, opts)?)
    }

    /// `p` as a shape of this space, with the checks the mesh readers make (finite, bounded
    /// coordinates, no zero-area face: [`crate::io::DEGENERATE_REL_TOL`]), so arrays and files
    /// are held to one standard.
    fn shape(&self, what: &str, p: &[[f64; 3]]) -> Result<Shape, SpaceError> {
        Shape::new_checked(self.topology.clone(), p.to_vec(), crate::io::DEGENERATE_REL_TOL).map_err(
            |error| SpaceError::Shape {
                what: what.to_string(),
                error,
            },
        )
    }

    /// `v` as a tangent vector (#V x 3, finite and bounded; zero is a valid vector).
    fn vector(&self, what: &str, v: &[[f64; 3]]) -> Result<(), SpaceError> {
        Shape::new(self.topology.clone(), v.to_vec())
            .map(|_| ())
            .map_err(|error| SpaceError::Shape {
                what: what.to_string(),
                error,
            })
    }
}

/// Two poses whose mean edge lengths differ by more than this factor get a warning from
/// `qcshape geodesic` and the Python `geodesic` / `dist` (issue 60): the solver scales both by
/// one factor, the inverse of the mean of their two mean edge lengths, so one of them becomes
/// nearly a point, which usually means the files are in different units (millimetres against
/// metres); the
/// quasi-conformal geodesic between a pose and the same pose scaled 1,000 x stopped at its
/// iteration limit both ways, 2 % apart.
pub const SIZE_RATIO_WARNING: f64 = 10.0;

/// The mean edge lengths of `a` and `b` (input units) when they differ by more than
/// [`SIZE_RATIO_WARNING`], `None` otherwise.
pub fn size_mismatch(topology: &Topology, a: &[[f64; 3]], b: &[[f64; 3]]) -> Option<(f64, f64)> {
    let la = crate::mesh::geometry::mean_edge_length(topology, a);
    let lb = crate::mesh::geometry::mean_edge_length(topology, b);
    let (lo, hi) = if la < lb { (la, lb) } else { (lb, la) };
    (lo > 0.0 && hi / lo > SIZE_RATIO_WARNING).then_some((la, lb))
}

#[cfg(test)]
mod tests;
