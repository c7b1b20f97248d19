//! The deformation-similarity pipeline of the paper (Fig. 1, eq. 13): temporal interpolation,
//! transfer to one common base, pairwise similarity.

use std::sync::Arc;

use rayon::prelude::*;
use thiserror::Error;

use crate::align::{align_deformation, Alignment};
use crate::dataset::Deformation;
use crate::geodesic::{
    normalization_factor, GeodesicError, GeodesicOptions, InterpolationError, InterpolationOptions,
    Interpolator, Normalization,
};
use crate::mesh::{MeshError, Topology};
use crate::metric::{Calibration, Metric, MetricSpec};
use crate::transport::{TransferOptions, TransferSetup, Transport, TransportError};

use super::error::SimilarityError;
use super::matrix::MatrixError;
use super::types::{Approx, Event, Pose, Stage};
use crate::mesh::smooth::Smoothing;

/// Options of the whole pipeline.
#[derive(Debug, Clone)]
pub struct PipelineOptions {
    /// The metric (with its variants and `lambda`).
    pub metric: MetricSpec,
    /// Geodesic solver options of the transfer and similarity geodesics (`steps` = N).
    pub geodesic: GeodesicOptions,
    /// Poses inserted between consecutive key poses (section 2.2.1); 0 = none.
    pub insert: usize,
    /// Spatial levels of the interpolation (1 = none; see the README for the measurement that
    /// made 1 the default).
    pub levels: usize,
    /// How deformations are carried to the common base (section 2.2.2). Default
    /// [`Transport::Translate`]: it gave lower transfer errors and better classification than
    /// parallel transport in the measurements (README).
    pub transport: Transport,
    /// Index of the reference deformation whose first pose is the common base (docs/method.md).
    pub base: usize,
    /// The low-pass filter applied to every pose of every deformation (the base included)
    /// before anything else, one linear operator for every pose, that takes vertex noise out of
    /// real data ([`Smoothing`]). Default: the length filter
    /// ([`crate::mesh::smooth::smooth_to_length`]) with the length
    /// [`super::defaults::SMOOTH_LENGTH`] = 0.18 of the area radius, its cutoff taken from the
    /// first pose of the base deformation, so that it smooths the same share of the surface at
    /// every resolution; [`Smoothing::Iterations`] is the previous default (10 Taubin
    /// iterations, [`crate::mesh::smooth::taubin`]), which smooths a quarter as much of the
    /// surface per subdivision of the mesh; `Iterations(0)` or `Length(0.0)` is none (the
    /// paper's pipeline). Smoothing was chosen on the robustness benchmark
    /// (`qcshape experiment robustness`, docs/robustness.md): without it vertex noise of 2 % of
    /// the bounding-box diagonal drives the quasi-conformal 1-NN accuracy to chance (0.13), with
    /// 10 iterations 1.00, and clean data loses nothing.
    pub smoothing: Smoothing,
    /// How each deformation is placed on the base before interpolation and transfer
    /// ([`Alignment::Rigid`] by default: the area-weighted Procrustes motion of its first pose
    /// onto the base, applied to all of its poses; see [`crate::align::align_deformation`]).
    pub align: Alignment,
    /// Geodesic lengths (the default) or a cheaper approximation of the pose distances
    /// ([`Approx`]); the interpolation and transfer are always exact.
    pub approx: Approx,
}

impl Default for PipelineOptions {
    fn default() -> Self {
        PipelineOptions {
            metric: MetricSpec::new(crate::metric::defaults::METRIC),
            geodesic: GeodesicOptions::default(),
            insert: super::defaults::INSERT,
            levels: crate::geodesic::defaults::LEVELS,
            transport: crate::transport::defaults::TRANSPORT,
            base: 0,
            align: crate::transport::defaults::ALIGN,
            smoothing: Smoothing::Length(super::defaults::SMOOTH_LENGTH),
            approx: Approx::Exact,
        }
    }
}

impl PipelineOptions {
    /// Checks the values a user sets, for a data set of `n` deformations (the one validation
    /// of the pipeline settings; [`prepare`] calls it): the metric's
    /// ([`MetricSpec::validate`]) and the solver's ([`GeodesicOptions::validate`]) values,
    /// `insert` at most [`crate::limits::MAX_INSERT`], `levels` in
    /// 1..=[`crate::limits::MAX_LEVELS`], `smoothing` by [`Smoothing::validate`] (iterations at
    /// most [`crate::limits::MAX_SWEEPS`], a length finite in
    /// 0..=[`crate::limits::MAX_SMOOTH_LENGTH`]), the base one of the deformations. The error
    /// names the setting by its key in [`crate::settings::SETTINGS`].
    pub fn validate(&self, n: usize) -> Result<(), crate::limits::LimitError> {
        use crate::limits::{count, MAX_INSERT, MAX_LEVELS};
        self.metric.validate()?;
        self.geodesic.validate()?;
        count("insert", self.insert, 0, MAX_INSERT)?;
        count("levels", self.levels, 1, MAX_LEVELS)?;
        self.smoothing.validate()?;
        if n > 0 && self.base >= n {
            return Err(crate::limits::LimitError::TooLarge {
                what: format!("base (the index of the base deformation among {n})"),
                max: n as u128 - 1,
                value: self.base as u128,
            });
        }
        Ok(())
    }
}

/// Why the pipeline failed.
#[derive(Debug, Error)]
pub enum PipelineError {
    /// The base deformation's index is not one of the data set's.
    #[error("base deformation {base} does not exist ({count} deformations)")]
    NoBase {
        /// The index asked for.
        base: usize,
        /// Number of deformations.
        count: usize,
    },
    /// A deformation's pose count differs from the base's.
    #[error("deformation '{name}' has {poses} poses but '{base}' has {base_poses}: all deformations need the same number of key poses")]
    PoseCount {
        /// The deformation.
        name: String,
        /// Its pose count.
        poses: usize,
        /// The base deformation.
        base: String,
        /// The base's pose count.
        base_poses: usize,
    },
    /// A deformation has fewer than two poses.
    #[error("deformation '{name}' has fewer than two poses")]
    TooFewPoses {
        /// The deformation.
        name: String,
    },
    /// A deformation's pose does not have the connectivity of the base.
    #[error("deformation '{name}': {error}")]
    Mesh {
        /// The deformation.
        name: String,
        /// What differs.
        error: MeshError,
    },
    /// The interpolation of a deformation failed.
    #[error("interpolating '{name}': {error}")]
    Interpolation {
        /// The deformation.
        name: String,
        /// The error.
        error: InterpolationError,
    },
    /// The transfer of a deformation failed.
    #[error("transferring '{name}': {error}")]
    Transfer {
        /// The deformation.
        name: String,
        /// The error.
        error: TransportError,
    },
    /// A geodesic solver could not be set up.
    #[error(transparent)]
    Geodesic(#[from] GeodesicError),
    /// The similarity computation failed.
    #[error(transparent)]
    Similarity(#[from] SimilarityError),
    /// A setting is out of its range ([`PipelineOptions::validate`]).
    #[error(transparent)]
    Setting(#[from] crate::limits::LimitError),
    /// The distances do not make a distance matrix (a non-finite or negative distance).
    #[error(transparent)]
    Matrix(#[from] MatrixError),
}

/// Deformations ready for comparison: interpolated and transferred to one base.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// Names, in input order.
    pub names: Vec<String>,
    /// Class labels, if known.
    pub labels: Vec<Option<String>>,
    /// The shared connectivity.
    pub topology: Arc<Topology>,
    /// The common factor coordinates are multiplied by for every geodesic (1 / mean edge length
    /// of the base pose): the solver's coordinates.
    pub factor: f64,
    /// The metric's factors, calibrated once on the base pose (in the solver's coordinates):
    /// every geodesic of the data set uses the metric [`Prepared::metric`] builds with them,
    /// so distances are in the metric's units ([`crate::metric::MetricScale`]).
    pub calibration: Calibration,
    /// The metric of [`PipelineOptions::metric`] with [`Prepared::calibration`], built once by
    /// [`prepare`]: the interpolation, the transfer and the pairs of [`Prepared::comparison`]
    /// all use it.
    pub run_metric: Arc<dyn Metric>,
    /// Interpolated deformations before transfer, after the alignment of
    /// [`PipelineOptions::align`] (#deformations x #poses x #V x 3; input units).
    pub interpolated: Vec<Vec<Pose>>,
    /// Whether each pose of the interpolated sequences is a key (input) pose.
    pub is_key: Vec<bool>,
    /// Transferred deformations (same shape; every one starts at the base pose, after the
    /// smoothing of [`PipelineOptions::smoothing`]).
    pub transferred: Vec<Vec<Pose>>,
    /// Seconds spent interpolating each deformation.
    pub interpolation_seconds: Vec<f64>,
    /// Seconds spent transferring each deformation.
    pub transfer_seconds: Vec<f64>,
    /// Whether every geodesic of interpolation and transfer converged.
    pub converged: bool,
}

impl Prepared {
    /// The metric `spec` with this data set's [`Prepared::calibration`] (a new one; the run's
    /// own is [`Prepared::run_metric`]).
    pub fn metric(&self, spec: &MetricSpec) -> Box<dyn Metric> {
        spec.build(&self.calibration)
    }

    /// The transferred deformations multiplied by [`Prepared::factor`] (solver units).
    pub fn scaled(&self) -> Vec<Vec<Pose>> {
        let f = self.factor;
        self.transferred
            .iter()
            .map(|d| d.iter().map(|p| crate::mesh::geometry::scaled(p, f)).collect())
            .collect()
    }
}

/// Checks that the deformations can be compared (one connectivity, one pose count, at least
/// two poses) and returns the shared topology.
fn check(defs: &[Deformation], base: usize) -> Result<Arc<Topology>, PipelineError> {
    let Some(b) = defs.get(base) else {
        return Err(PipelineError::NoBase {
            base,
            count: defs.len(),
        });
    };
    let topo = b.topology.clone();
    let reference = b.shape(0);
    for d in defs {
        if d.poses.len() != b.poses.len() {
            return Err(PipelineError::PoseCount {
                name: d.name.clone(),
                poses: d.poses.len(),
                base: b.name.clone(),
                base_poses: b.poses.len(),
            });
        }
        if d.poses.len() < 2 {
            return Err(PipelineError::TooFewPoses { name: d.name.clone() });
        }
        if !Arc::ptr_eq(&d.topology, &topo) {
            reference
                .check_same_topology(&d.shape(0))
                .map_err(|error| PipelineError::Mesh {
                    name: d.name.clone(),
                    error,
                })?;
        }
    }
    Ok(topo)
}

/// Smooths every pose ([`PipelineOptions::smoothing`]: one operator for all, the length
/// filter's cutoff from the first pose of deformation `opts.base`), aligns each deformation to
/// the first pose of deformation `opts.base` ([`PipelineOptions::align`]), interpolates it
/// (`opts.insert` poses between key poses) and transfers it to that base, deformations in
/// parallel.
/// `events` sees an [`Event::Prepared`] as each deformation finishes a stage.
pub fn prepare(
    defs: &[Deformation],
    opts: &PipelineOptions,
    events: &(dyn Fn(Event<'_>) + Sync),
) -> Result<Prepared, PipelineError> {
    let progress = |stage: Stage, name: &str| events(Event::Prepared { stage, name });
    let topo = check(defs, opts.base)?;
    opts.validate(defs.len())?;
    // One linear operator for every pose: the length filter's cutoff from the base's first pose.
    let smoother = opts.smoothing.smoother(&topo, &defs[opts.base].poses[0]);
    let smoothed: Vec<Vec<Pose>> = if smoother.is_identity() {
        Vec::new()
    } else {
        defs.par_iter()
            .map(|d| d.poses.iter().map(|p| smoother.apply(&topo, p)).collect())
            .collect()
    };
    let poses_of = |i: usize| -> &[Pose] {
        if smoother.is_identity() {
            &defs[i].poses
        } else {
            &smoothed[i]
        }
    };
    let base_pose = &poses_of(opts.base)[0];
    let factor = normalization_factor(Normalization::MeanEdgeOfFirst, &topo, base_pose);
    let scaled_base: Pose = base_pose.iter().map(|p| p.map(|c| c * factor)).collect();
    let calibration = opts
        .metric
        .calibrate(&topo, &[&scaled_base])
        .map_err(GeodesicError::from)?;
    // The run's one metric: interpolation, transfer and the pairs ([`Prepared::comparison`]).
    let metric: Arc<dyn Metric> = Arc::from(opts.metric.build(&calibration));
    let mut converged = true;

    // Placement on the base (the deformation's own motion is kept).
    let aligned: Vec<Vec<Pose>> = (0..defs.len())
        .into_par_iter()
        .map(|i| align_deformation(&topo, poses_of(i), base_pose, opts.align).0)
        .collect();

    // Interpolation.
    let interp = Interpolator::new(
        metric.as_ref(),
        &topo,
        base_pose,
        InterpolationOptions {
            insert: opts.insert,
            levels: opts.levels.max(1),
            geodesic: opts.geodesic.clone(),
            normalization: Normalization::Factor(factor),
            ..Default::default()
        },
    )
    .map_err(|error| PipelineError::Interpolation {
        name: defs[opts.base].name.clone(),
        error,
    })?;
    let interpolated: Vec<(Vec<Pose>, Vec<bool>, f64, bool)> =
        defs.par_iter()
            .zip(&aligned)
            .map(|(d, poses)| {
                let t0 = std::time::Instant::now();
                let r = interp.interpolate_sequence(poses, &|| {}).map_err(|error| {
                    PipelineError::Interpolation {
                        name: d.name.clone(),
                        error,
                    }
                })?;
                progress(Stage::Interpolation, &d.name);
                let ok = r.pairs.iter().all(|p| p.converged);
                Ok((r.poses, r.is_key, t0.elapsed().as_secs_f64(), ok))
            })
            .collect::<Result<_, PipelineError>>()?;
    let is_key = interpolated[0].1.clone();
    converged &= interpolated.iter().all(|x| x.3);

    // Transfer to the base.
    let setup = TransferSetup::with_metric(
        &opts.metric,
        metric.clone(),
        &calibration,
        topo.clone(),
        TransferOptions {
            geodesic: opts.geodesic.clone(),
            normalization: Normalization::Factor(factor),
            ..Default::default()
        },
    )
    .map_err(|error| PipelineError::Transfer {
        name: defs[opts.base].name.clone(),
        error,
    })?;
    let transfer = setup.solver().map_err(|error| PipelineError::Transfer {
        name: defs[opts.base].name.clone(),
        error,
    })?;
    let transferred: Vec<(Vec<Pose>, f64, bool)> =
        defs.par_iter()
            .zip(&interpolated)
            .map(|(d, (poses, _, _, _))| {
                let t0 = std::time::Instant::now();
                let r = transfer.run(poses, base_pose, opts.transport).map_err(|error| {
                    PipelineError::Transfer {
                        name: d.name.clone(),
                        error,
                    }
                })?;
                progress(Stage::Transfer, &d.name);
                let ok = r.segments.iter().all(|s| s.geodesic_converged);
                Ok((r.poses, t0.elapsed().as_secs_f64(), ok))
            })
            .collect::<Result<_, PipelineError>>()?;
    converged &= transferred.iter().all(|x| x.2);

    Ok(Prepared {
        names: defs.iter().map(|d| d.name.clone()).collect(),
        labels: defs.iter().map(|d| d.label.clone()).collect(),
        topology: topo,
        factor,
        calibration,
        run_metric: metric,
        interpolation_seconds: interpolated.iter().map(|x| x.2).collect(),
        interpolated: interpolated.into_iter().map(|x| x.0).collect(),
        is_key,
        transfer_seconds: transferred.iter().map(|x| x.1).collect(),
        transferred: transferred.into_iter().map(|x| x.0).collect(),
        converged,
    })
}

/// A settings string for [`super::fingerprint`]: everything that changes the distances.
pub fn settings_key(opts: &PipelineOptions) -> String {
    let g = &opts.geodesic;
    format!(
        "{:?}|steps={}|solver={:?}|gtol={:e}|etol={:e}|ltol={:e}|maxit={}|mem={}|refresh={}|omega={:e}|insert={}|levels={}|transport={:?}|base={}|align={:?}|smoothing={}{}",
        opts.metric,
        g.steps,
        g.solver,
        g.gradient_tolerance,
        g.energy_tolerance,
        g.length_tolerance,
        g.max_iterations.map_or_else(|| "default".to_string(), |n| n.to_string()),
        g.lbfgs_memory,
        g.preconditioner_refresh,
        g.vertex_block_weight,
        opts.insert,
        opts.levels,
        opts.transport,
        opts.base,
        opts.align,
        opts.smoothing.key(),
        // Exact runs keep the settings strings (and journal keys) they had before `approx`.
        match opts.approx {
            Approx::Exact => String::new(),
            a => format!("|approx={a}"),
        }
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metric::MetricKind;

    use crate::synth::{genus0_benchmark, SynthOptions};

    #[test]
    fn the_settings_key_tells_the_smoothings_apart() {
        let key = |smoothing| {
            settings_key(&PipelineOptions {
                smoothing,
                ..Default::default()
            })
        };
        // Taubin iterations keep the settings strings (and journals) of the releases before.
        assert!(key(Smoothing::Iterations(10)).contains("|smoothing=10"));
        assert!(key(Smoothing::Length(0.18)).contains("|smoothing=length:0.18"));
        assert_ne!(key(Smoothing::Length(0.18)), key(Smoothing::Length(0.2)));
        assert_eq!(
            key(Smoothing::Length(0.18)),
            settings_key(&PipelineOptions::default())
        );
    }

    #[test]
    fn synthetic_pipeline_gives_a_symmetric_matrix_that_groups_deformations() {
        let defs = genus0_benchmark(&SynthOptions {
            level: 1,
            ..Default::default()
        })
        .unwrap();
        // Two deformation types on three shapes each.
        let pick: Vec<Deformation> = defs
            .into_iter()
            .filter(|d| {
                (d.label.as_deref() == Some("twist") || d.label.as_deref() == Some("bulge"))
                    && ["sphere-", "ellipsoid-", "pear-"]
                        .iter()
                        .any(|s| d.name.starts_with(s))
            })
            .collect();
        assert_eq!(pick.len(), 6);
        let opts = PipelineOptions {
            metric: MetricSpec::new(MetricKind::Isometric),
            geodesic: GeodesicOptions {
                steps: 3,
                ..Default::default()
            },
            insert: 1,
            transport: Transport::Parallel,
            ..Default::default()
        };
        let calls = std::sync::Mutex::new(Vec::new());
        let prepared = prepare(&pick, &opts, &|e| {
            if let crate::similarity::Event::Prepared { stage, name } = e {
                calls.lock().unwrap().push((stage, name.to_string()))
            }
        })
        .unwrap();
        assert_eq!(calls.lock().unwrap().len(), 12);
        // 3 key poses + 1 inserted between each pair.
        assert_eq!(prepared.is_key, vec![true, false, true, false, true]);
        // The base: the reference's first pose after the default smoothing.
        let base = crate::mesh::smooth::smooth_to_length(
            &pick[0].topology,
            &pick[0].poses[0],
            crate::similarity::defaults::SMOOTH_LENGTH,
        );
        assert_ne!(base, pick[0].poses[0]);
        for (d, t) in pick.iter().zip(&prepared.transferred) {
            assert_eq!(t.len(), 5);
            // Every transferred deformation starts at the base.
            assert_eq!(t[0], base, "{}", d.name);
        }
        // The reference deformation transferred to its own first pose is itself.
        for (a, b) in prepared.transferred[0].iter().zip(&prepared.interpolated[0]) {
            for (p, q) in a.iter().zip(b) {
                for c in 0..3 {
                    assert!((p[c] - q[c]).abs() < 1e-9, "{p:?} vs {q:?}");
                }
            }
        }
        let outcome = super::super::run::compute(&prepared.comparison(), &opts, &Default::default()).unwrap();
        let d = outcome.matrix.unwrap().values().to_vec();
        // Same-type pairs are closer on average than cross-type pairs.
        let label = |i: usize| pick[i].label.clone();
        let (mut same, mut ns, mut cross, mut nc) = (0.0, 0, 0.0, 0);
        for i in 0..6 {
            for j in i + 1..6 {
                if label(i) == label(j) {
                    same += d[i * 6 + j];
                    ns += 1;
                } else {
                    cross += d[i * 6 + j];
                    nc += 1;
                }
            }
        }
        assert!(same / (ns as f64) < cross / (nc as f64), "{d:?}");
    }

    #[test]
    fn mismatched_inputs_are_named() {
        let defs = genus0_benchmark(&SynthOptions {
            level: 0,
            ..Default::default()
        })
        .unwrap();
        let mut short = defs[1].clone();
        short.poses.pop();
        let e = prepare(&[defs[0].clone(), short], &PipelineOptions::default(), &|_| {}).unwrap_err();
        assert!(e.to_string().contains("has 2 poses"), "{e}");
        let e = prepare(
            &defs[..2],
            &PipelineOptions {
                base: 5,
                ..Default::default()
            },
            &|_| {},
        )
        .unwrap_err();
        assert!(e.to_string().contains("base deformation 5"), "{e}");
    }
}

#[cfg(test)]
mod alignment_tests {
    use super::*;
    use crate::metric::MetricKind;

    use crate::align::{rotation_about, Motion};
    use crate::synth::{genus0_benchmark, SynthOptions};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn matrix(defs: &[Deformation], opts: &PipelineOptions) -> Vec<f64> {
        let (_, outcome) = crate::similarity::similarity_matrix(defs, opts, &Default::default()).unwrap();
        outcome.matrix.unwrap().values().to_vec()
    }

    /// Every deformation but the base moved by its own random rigid motion (up to 60 degrees,
    /// translations of the shape's size): with rigid alignment the matrix is the original's.
    #[test]
    fn randomly_posed_deformations_give_the_same_matrix_after_rigid_alignment() {
        let defs: Vec<Deformation> = genus0_benchmark(&SynthOptions {
            level: 1,
            ..Default::default()
        })
        .unwrap()
        .into_iter()
        .step_by(7)
        .take(5)
        .collect();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut posed = defs.clone();
        for d in posed.iter_mut().skip(1) {
            let axis = [0, 1, 2].map(|_| rng.random_range(-1.0..1.0));
            let m = Motion {
                rotation: rotation_about(axis, rng.random_range(0.3..1.05)),
                scale: 1.0,
                translation: [0, 1, 2].map(|_| rng.random_range(-2.0..2.0)),
            };
            for p in d.poses.iter_mut() {
                p.iter_mut().for_each(|x| *x = m.apply(*x));
            }
        }
        // The calibrated conformal metrics are left out: their geodesics run through the
        // conformal null space, pinned only by the small regularizer, and their solves stop
        // at the iteration limit, so two poses of one problem agree to 0.3 %, not 1e-6
        // (docs/geometry.md). The paper's raw quasi-conformal metric is checked instead.
        for spec in [
            MetricSpec::new(MetricKind::Isometric),
            MetricSpec::new(MetricKind::Rigid),
            MetricSpec::previous(MetricKind::QuasiConformal),
        ] {
            let kind = spec.kind;
            let mut opts = PipelineOptions {
                metric: spec,
                geodesic: GeodesicOptions {
                    steps: 3,
                    ..Default::default()
                },
                ..Default::default()
            };
            let clean = matrix(&defs, &opts);
            let moved = matrix(&posed, &opts);
            let scale = clean.iter().fold(0.0f64, |a, b| a.max(*b));
            for (a, b) in clean.iter().zip(&moved) {
                assert!((a - b).abs() <= 1e-6 * scale, "{kind:?}: {a} vs {b}");
            }
            // Without the alignment the posed set gives another matrix (the test can fail).
            opts.align = Alignment::None;
            let unaligned = matrix(&posed, &opts);
            let worst = clean
                .iter()
                .zip(&unaligned)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            assert!(worst > 0.05 * scale, "{kind:?}: {worst}");
        }
    }
}
