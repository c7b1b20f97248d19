//! Temporal interpolation between key poses with spatial multiresolution (paper section 2.2.1,
//! docs/method.md "Temporal interpolation").
//!
//! Between key poses `A` and `B`, `n` poses are inserted. On the coarsest level of a
//! [`Hierarchy`]: start from the midpoint (a path with `N = 2` segments, started linear) and
//! optimize; then insert new poses by averaging neighbours (the midpoint of every segment, or,
//! when fewer than a full doubling is needed, of the longest segments in the metric's length)
//! and re-optimize all interior poses, until `n` are in. The coarse path is then carried up
//! level by level ([`Prolongation::prolong_path`](crate::multires::Prolongation::prolong_path))
//! as the starting point of the solve with `N = n + 1` on the next finer level.

use std::sync::Arc;
use std::time::Instant;

use rayon::prelude::*;
use thiserror::Error;

use super::{normalization_factor, Geodesic, GeodesicError, GeodesicOptions, GeodesicSolver, Normalization};
use crate::mesh::{geometry, MeshError, Shape, Topology};
use crate::metric::Metric;
use crate::multires::{Hierarchy, HierarchyError, DEFAULT_RATIO};

/// Options of the temporal interpolation.
#[derive(Debug, Clone)]
pub struct InterpolationOptions {
    /// Number `n` of poses inserted between two key poses. Default
    /// [`super::defaults::PAPER_INSERT`] (3, as in paper sections 3.3 and 4).
    pub insert: usize,
    /// Number of spatial levels, the input mesh included (1 = no multiresolution). Default
    /// [`super::defaults::LEVELS`] (1: the multiresolution solve was not faster, README).
    pub levels: usize,
    /// Share of vertices kept by each coarsening step. Default [`DEFAULT_RATIO`] (0.25).
    pub ratio: f64,
    /// Solver options; `steps` is ignored (set by the insertion schedule).
    pub geodesic: GeodesicOptions,
    /// Common scale of the poses while solving. Default [`Normalization::MeanEdgeOfFirst`]:
    /// the first key pose of a sequence (of the pair, for [`Interpolator::interpolate`]). Pass
    /// [`Normalization::Factor`] computed once to put a whole data set in one scale.
    pub normalization: Normalization,
}

impl Default for InterpolationOptions {
    fn default() -> Self {
        InterpolationOptions {
            insert: super::defaults::PAPER_INSERT,
            levels: super::defaults::LEVELS,
            ratio: DEFAULT_RATIO,
            geodesic: GeodesicOptions::default(),
            normalization: Normalization::MeanEdgeOfFirst,
        }
    }
}

/// Errors of the temporal interpolation.
#[derive(Debug, Error)]
pub enum InterpolationError {
    /// A geodesic solve failed.
    #[error(transparent)]
    Geodesic(#[from] GeodesicError),
    /// The mesh hierarchy could not be built.
    #[error("mesh hierarchy: {0}")]
    Hierarchy(#[from] HierarchyError),
    /// A pose does not fit the topology.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// A setting out of its range (`levels` 0, `insert` above [`crate::limits::MAX_INSERT`]).
    #[error(transparent)]
    Setting(Box<crate::limits::LimitError>),
    /// The sequence to interpolate has no poses.
    #[error("invalid input: the sequence has no poses")]
    EmptySequence,
    /// Interpolating between key poses `pair` and `pair + 1` failed.
    #[error("between key poses {pair} and {}: {source}", pair + 1)]
    Pair {
        /// Index of the first key pose.
        pair: usize,
        /// What failed.
        source: Box<InterpolationError>,
    },
}

/// A setting's limit error (boxed: it holds the setting's names, and this error travels in
/// larger ones).
impl From<crate::limits::LimitError> for InterpolationError {
    fn from(e: crate::limits::LimitError) -> Self {
        InterpolationError::Setting(Box::new(e))
    }
}

/// What happened on one level of the hierarchy for one pair.
#[derive(Debug, Clone, PartialEq)]
pub struct LevelStats {
    /// Vertices of the level.
    pub vertices: usize,
    /// Number of segments `N` of each solve on this level, in order.
    pub steps: Vec<usize>,
    /// Path energy (eq. 12) of the start of the level's last solve (the prolonged coarse path,
    /// or the refined path of the insertion schedule), in the level's own normalized units
    /// (coordinates scaled so that its mean edge on `a` equals the finest level's).
    pub start_energy: f64,
    /// Path energy (eq. 12, the level's normalized units) after the level's last solve.
    pub energy: f64,
    /// Iterations summed over the level's solves.
    pub iterations: usize,
    /// Wall-clock seconds on this level.
    pub seconds: f64,
}

/// Statistics of one interpolated pair.
#[derive(Debug, Clone, PartialEq)]
pub struct PairStats {
    /// Path energy (eq. 12, normalized units) of the final path on the finest level.
    pub energy: f64,
    /// Length of the final path (normalized units).
    pub length: f64,
    /// Iterations summed over all solves and levels.
    pub iterations: usize,
    /// Whether the final (finest-level) solve converged.
    pub converged: bool,
    /// Wall-clock seconds for the pair.
    pub seconds: f64,
    /// Per level, coarsest first.
    pub levels: Vec<LevelStats>,
}

/// The poses interpolated between two key poses.
#[derive(Debug, Clone)]
pub struct PairInterpolation {
    /// `A`, the `n` inserted poses, `B` (n + 2 poses, each #V x 3, input units); the ends are
    /// the inputs bit for bit.
    pub poses: Vec<Vec<[f64; 3]>>,
    /// Length of each of the n + 1 segments, `sqrt((G_{P_i}(X_i) + G_{P_{i+1}}(X_i)) / 2)`
    /// (normalized units).
    pub segment_lengths: Vec<f64>,
    /// The factor coordinates were multiplied by while solving.
    pub scale: f64,
    /// Solver statistics.
    pub stats: PairStats,
}

/// A densified deformation.
#[derive(Debug, Clone)]
pub struct Interpolated {
    /// All poses in order: `K (n + 1) + 1` for `K + 1` key poses (each #V x 3, input units).
    pub poses: Vec<Vec<[f64; 3]>>,
    /// Whether each pose is a key pose (returned bit for bit).
    pub is_key: Vec<bool>,
    /// Length of each segment between consecutive poses (`K (n + 1)`, normalized units).
    pub segment_lengths: Vec<f64>,
    /// Statistics per pair of consecutive key poses.
    pub pairs: Vec<PairStats>,
    /// The common factor coordinates were multiplied by while solving.
    pub scale: f64,
}

/// The error of interpolating a known middle pose from the first and last (paper section 3.1).
#[derive(Debug, Clone)]
pub struct MiddleError {
    /// The interpolated middle pose (#V x 3, input units).
    pub predicted: Vec<[f64; 3]>,
    /// Per vertex, the distance between predicted and true middle pose (input units).
    pub errors: Vec<f64>,
    /// Mean of [`MiddleError::errors`].
    pub mean: f64,
    /// Root mean square of the errors.
    pub rms: f64,
    /// Largest error.
    pub max: f64,
    /// Mean edge length of the true middle pose (to make the errors relative).
    pub mean_edge: f64,
    /// Bounding-box diagonal of the true middle pose.
    pub diagonal: f64,
    /// Solver statistics.
    pub stats: PairStats,
}

/// Interpolates between key poses of one topology: holds the mesh hierarchy, and one
/// [`GeodesicSolver`] per (level, N) needed by the insertion schedule, all built once and reused
/// for every pair.
pub struct Interpolator<'m> {
    hierarchy: Hierarchy,
    options: InterpolationOptions,
    /// Solvers of the coarsest level, one per `N` of the insertion schedule.
    schedule: Vec<GeodesicSolver<'m>>,
    /// `finals[l]`: the `N = n + 1` solver of level `l` (every level but the coarsest).
    finals: Vec<GeodesicSolver<'m>>,
}

/// The numbers of segments `N` of the successive solves: 2, 4, 8, ... capped at `n + 1` (just
/// `[1]` for `n = 0`).
pub fn insertion_schedule(insert: usize) -> Vec<usize> {
    if insert == 0 {
        return vec![1];
    }
    let mut s = vec![2];
    while *s.last().expect("non-empty") < insert + 1 {
        let n = *s.last().expect("non-empty");
        s.push((2 * n).min(insert + 1));
    }
    s
}

impl<'m> Interpolator<'m> {
    /// Builds the hierarchy of `topo` at the rest pose `rest` (#V x 3; usually the first key
    /// pose) and the solvers. With `insert = 0` no hierarchy or optimization is needed.
    pub fn new(
        metric: &'m dyn Metric,
        topo: &Arc<Topology>,
        rest: &[[f64; 3]],
        options: InterpolationOptions,
    ) -> Result<Self, InterpolationError> {
        crate::limits::count("levels", options.levels, 1, usize::MAX)?;
        let levels = if options.insert == 0 { 1 } else { options.levels };
        let hierarchy = Hierarchy::new(topo, rest, levels, options.ratio)?;
        Self::with_hierarchy(metric, hierarchy, options)
    }

    /// Uses a hierarchy already built (with the number of levels it has).
    pub fn with_hierarchy(
        metric: &'m dyn Metric,
        hierarchy: Hierarchy,
        options: InterpolationOptions,
    ) -> Result<Self, InterpolationError> {
        // Before the insertion schedule is built: `insert + 1` must not wrap.
        crate::limits::count("insert", options.insert, 0, crate::limits::MAX_INSERT)?;
        let top = hierarchy.n_levels() - 1;
        let solver = |level: usize, steps: usize| {
            GeodesicSolver::new(
                metric,
                hierarchy.level(level).topology.clone(),
                GeodesicOptions {
                    steps,
                    ..options.geodesic.clone()
                },
            )
        };
        let schedule = insertion_schedule(options.insert)
            .into_iter()
            .map(|n| solver(top, n))
            .collect::<Result<Vec<_>, _>>()?;
        let finals = (0..top)
            .map(|l| solver(l, options.insert + 1))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Interpolator {
            hierarchy,
            options,
            schedule,
            finals,
        })
    }

    /// The mesh hierarchy.
    pub fn hierarchy(&self) -> &Hierarchy {
        &self.hierarchy
    }
    /// The options.
    pub fn options(&self) -> &InterpolationOptions {
        &self.options
    }

    /// Inserts `n` poses between `a` and `b` (each #V x 3, input units), scaling both by the
    /// options' normalization (of `a`).
    pub fn interpolate(
        &self,
        a: &[[f64; 3]],
        b: &[[f64; 3]],
    ) -> Result<PairInterpolation, InterpolationError> {
        let topo = &self.hierarchy.level(0).topology;
        if a.len() != topo.n_vertices() {
            return Err(MeshError::VertexCountMismatch {
                expected: topo.n_vertices(),
                got: a.len(),
            }
            .into());
        }
        let f = normalization_factor(self.options.normalization, topo, a);
        self.interpolate_scaled(a, b, f)
    }

    /// Inserts `n` poses between `a` and `b` (each #V x 3), multiplying the coordinates by
    /// `factor` while solving.
    pub fn interpolate_scaled(
        &self,
        a: &[[f64; 3]],
        b: &[[f64; 3]],
        factor: f64,
    ) -> Result<PairInterpolation, InterpolationError> {
        let t0 = Instant::now();
        let topo = &self.hierarchy.level(0).topology;
        Shape::new(topo.clone(), a.to_vec())?;
        Shape::new(topo.clone(), b.to_vec())?;
        if !(factor.is_finite() && factor > 0.0) {
            return Err(GeodesicError::Normalization { factor }.into());
        }
        let scaled = |p: &[[f64; 3]]| -> Vec<[f64; 3]> { p.iter().map(|v| v.map(|c| c * factor)).collect() };
        let (sa, sb) = (scaled(a), scaled(b));
        let top = self.hierarchy.n_levels() - 1;
        let level = self.hierarchy.level(top);
        // Each coarser level is solved in its own normalized units (its mean edge on `a` equal
        // to the finest level's): the metrics' terms scale with different powers of length, so
        // in the finest level's units a coarse level would weigh the L2 part differently.
        let fine_edge = geometry::mean_edge_length(&self.hierarchy.level(0).topology, &sa);
        let level_scale = |l: usize, ra: &[[f64; 3]]| -> f64 {
            if l == 0 {
                1.0
            } else {
                let e = geometry::mean_edge_length(&self.hierarchy.level(l).topology, ra);
                if e > 0.0 {
                    fine_edge / e
                } else {
                    1.0
                }
            }
        };
        let scale_by = crate::mesh::geometry::scaled;
        let (ra, rb) = (level.restrict(&sa), level.restrict(&sb));
        let mut s_coarse = level_scale(top, &ra);
        let (mut ca, mut cb) = (scale_by(&ra, s_coarse), scale_by(&rb, s_coarse));

        // Coarsest level: the insertion schedule.
        let t_level = Instant::now();
        let mut path: Option<Geodesic> = None;
        let mut iterations = 0;
        for solver in &self.schedule {
            let g = match &path {
                None => solver.solve(&ca, &cb)?,
                Some(prev) => {
                    solver.solve_with_start(&ca, &cb, &refine(prev, solver.path_energy().steps()))?
                }
            };
            iterations += g.iterations;
            path = Some(g);
        }
        let mut g = path.expect("the schedule has at least one solve");
        let mut levels = vec![LevelStats {
            vertices: level.n_vertices(),
            steps: self.schedule.iter().map(|s| s.path_energy().steps()).collect(),
            start_energy: g.initial_energy,
            energy: g.energy,
            iterations,
            seconds: t_level.elapsed().as_secs_f64(),
        }];

        // Finer levels: prolong the path and re-optimize it.
        for l in (0..top).rev() {
            let t_level = Instant::now();
            let fine = self.hierarchy.level(l);
            let (fa, fb) = if l == 0 {
                (sa.clone(), sb.clone())
            } else {
                (fine.restrict(&sa), fine.restrict(&sb))
            };
            let n = g.poses.len() - 1;
            // Back to the finer level's units: the coarse path at the finer level's scale.
            let s_fine = level_scale(l, &fa);
            let (fa, fb) = (scale_by(&fa, s_fine), scale_by(&fb, s_fine));
            let back = s_fine / s_coarse;
            let coarse_poses: Vec<Vec<[f64; 3]>> = g.poses[1..n].iter().map(|p| scale_by(p, back)).collect();
            let start = self.hierarchy.prolongation(l).prolong_path(
                &fa,
                &fb,
                &scale_by(&ca, back),
                &scale_by(&cb, back),
                &coarse_poses,
            );
            g = self.finals[l].solve_with_start(&fa, &fb, &start)?;
            levels.push(LevelStats {
                vertices: fine.n_vertices(),
                steps: vec![n],
                start_energy: g.initial_energy,
                energy: g.energy,
                iterations: g.iterations,
                seconds: t_level.elapsed().as_secs_f64(),
            });
            (ca, cb) = (fa, fb);
            s_coarse = s_fine;
        }

        let mut poses: Vec<Vec<[f64; 3]>> = g
            .poses
            .iter()
            .map(|p| p.iter().map(|v| v.map(|c| c / factor)).collect())
            .collect();
        let last = poses.len() - 1;
        poses[0] = a.to_vec();
        poses[last] = b.to_vec();
        Ok(PairInterpolation {
            poses,
            stats: PairStats {
                energy: g.energy,
                length: g.length,
                iterations: levels.iter().map(|s| s.iterations).sum(),
                converged: g.converged,
                seconds: t0.elapsed().as_secs_f64(),
                levels,
            },
            segment_lengths: g.segment_lengths,
            scale: factor,
        })
    }

    /// Densifies a sequence of key poses `M_0 .. M_K` (each #V x 3): `n` poses between each
    /// consecutive pair, all pairs in one common scale (the options' normalization of `M_0`).
    /// Pairs are solved in parallel; `progress` is called once per finished pair.
    pub fn interpolate_sequence(
        &self,
        poses: &[Vec<[f64; 3]>],
        progress: &(dyn Fn() + Sync),
    ) -> Result<Interpolated, InterpolationError> {
        let Some(first) = poses.first() else {
            return Err(InterpolationError::EmptySequence);
        };
        let topo = &self.hierarchy.level(0).topology;
        Shape::new(topo.clone(), first.clone())?;
        let factor = normalization_factor(self.options.normalization, topo, first);
        let pairs: Vec<PairInterpolation> = (0..poses.len() - 1)
            .into_par_iter()
            .map(|k| {
                let r = self
                    .interpolate_scaled(&poses[k], &poses[k + 1], factor)
                    .map_err(|e| InterpolationError::Pair {
                        pair: k,
                        source: Box::new(e),
                    });
                progress();
                r
            })
            .collect::<Result<_, _>>()?;
        let mut out = Interpolated {
            poses: vec![first.clone()],
            is_key: vec![true],
            segment_lengths: Vec::new(),
            pairs: Vec::with_capacity(pairs.len()),
            scale: factor,
        };
        for p in pairs {
            let n = p.poses.len();
            for (i, pose) in p.poses.into_iter().enumerate().skip(1) {
                out.poses.push(pose);
                out.is_key.push(i == n - 1);
            }
            out.segment_lengths.extend(p.segment_lengths);
            out.pairs.push(p.stats);
        }
        Ok(out)
    }
}

/// The next start of the insertion schedule: the interior poses of `prev` with the midpoints of
/// its segments inserted (all of them, or the `steps - N` longest in the metric's length).
fn refine(prev: &Geodesic, steps: usize) -> Vec<Vec<[f64; 3]>> {
    let n = prev.poses.len() - 1;
    let extra = steps - n;
    let mut split = vec![extra >= n; n];
    if extra < n {
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&i, &j| {
            prev.segment_lengths[j]
                .total_cmp(&prev.segment_lengths[i])
                .then(i.cmp(&j))
        });
        for &i in &order[..extra] {
            split[i] = true;
        }
    }
    let mut out = Vec::with_capacity(steps - 1);
    for (i, &halve) in split.iter().enumerate() {
        if i > 0 {
            out.push(prev.poses[i].clone());
        }
        if halve {
            out.push(
                prev.poses[i]
                    .iter()
                    .zip(&prev.poses[i + 1])
                    .map(|(p, q)| geometry::scale(geometry::add(*p, *q), 0.5))
                    .collect(),
            );
        }
    }
    out
}

/// Densifies the key poses `poses` (each #V x 3) of one topology: builds an [`Interpolator`]
/// at the first pose and runs [`Interpolator::interpolate_sequence`].
pub fn interpolate_sequence(
    metric: &dyn Metric,
    topo: &Arc<Topology>,
    poses: &[Vec<[f64; 3]>],
    options: &InterpolationOptions,
) -> Result<Interpolated, InterpolationError> {
    let Some(first) = poses.first() else {
        return Err(InterpolationError::EmptySequence);
    };
    Shape::new(topo.clone(), first.clone())?;
    Interpolator::new(metric, topo, first, options.clone())?.interpolate_sequence(poses, &|| {})
}

/// Interpolates the middle of `first` and `last` (one inserted pose, whatever
/// `options.insert` says) and compares it with the known `middle` (each #V x 3): the
/// interpolation-accuracy experiment of paper section 3.1 (Fig. 4).
pub fn interpolate_middle(
    metric: &dyn Metric,
    topo: &Arc<Topology>,
    first: &[[f64; 3]],
    middle: &[[f64; 3]],
    last: &[[f64; 3]],
    options: &InterpolationOptions,
) -> Result<MiddleError, InterpolationError> {
    let truth = Shape::new(topo.clone(), middle.to_vec())?;
    Shape::new(topo.clone(), first.to_vec())?;
    let options = InterpolationOptions {
        insert: 1,
        ..options.clone()
    };
    let p = Interpolator::new(metric, topo, first, options)?.interpolate(first, last)?;
    let predicted = p.poses[1].clone();
    let errors: Vec<f64> = predicted
        .iter()
        .zip(middle)
        .map(|(x, y)| geometry::norm(geometry::sub(*x, *y)))
        .collect();
    let nv = errors.len().max(1) as f64;
    let (lo, hi) = geometry::bounding_box(&truth.positions);
    Ok(MiddleError {
        mean: errors.iter().sum::<f64>() / nv,
        rms: (errors.iter().map(|e| e * e).sum::<f64>() / nv).sqrt(),
        max: errors.iter().copied().fold(0.0, f64::max),
        mean_edge: geometry::mean_edge_length(topo, middle),
        diagonal: geometry::norm(geometry::sub(hi, lo)),
        predicted,
        errors,
        stats: p.stats,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schedule_doubles_then_caps() {
        assert_eq!(insertion_schedule(0), vec![1]);
        assert_eq!(insertion_schedule(1), vec![2]);
        assert_eq!(insertion_schedule(2), vec![2, 3]);
        assert_eq!(insertion_schedule(3), vec![2, 4]);
        assert_eq!(insertion_schedule(5), vec![2, 4, 6]);
        assert_eq!(insertion_schedule(7), vec![2, 4, 8]);
        assert_eq!(insertion_schedule(10), vec![2, 4, 8, 11]);
    }

    #[test]
    fn refine_splits_the_longest_segments() {
        let pose = |x: f64| vec![[x, 0.0, 0.0]];
        let prev = Geodesic {
            poses: vec![pose(0.0), pose(1.0), pose(3.0), pose(4.0)],
            energy: 0.0,
            initial_energy: 0.0,
            geometric_energy: 0.0,
            regularizer_energy: 0.0,
            bending_energy: 0.0,
            length: 4.0,
            segment_lengths: vec![1.0, 2.0, 1.0],
            iterations: 0,
            converged: true,
            stop: super::super::StopReason::GradientTolerance,
            gradient_norm: 0.0,
            scale: 1.0,
            seconds: 0.0,
        };
        let xs = |v: Vec<Vec<[f64; 3]>>| v.iter().map(|p| p[0][0]).collect::<Vec<_>>();
        assert_eq!(xs(refine(&prev, 4)), vec![1.0, 2.0, 3.0]);
        assert_eq!(xs(refine(&prev, 5)), vec![0.5, 1.0, 2.0, 3.0]);
        assert_eq!(xs(refine(&prev, 6)), vec![0.5, 1.0, 2.0, 3.0, 3.5]);
    }
}
