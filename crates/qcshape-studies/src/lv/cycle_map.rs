//! Fig. 9: the 2-D MDS map of one heart cycle with interpolated poses, from the geodesic
//! distance `dis(P_i, P_j)` of every pair of poses.

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use serde::Serialize;

use super::analysis::{close_cycle, drop_closing_pose, pose_distance_matrix, Pose};
use super::study::{coarsen, Progress, StudyError, Tick};
use qcshape::dataset::Deformation;
use qcshape::embed::{smacof, MdsOptions};
use qcshape::geodesic::GeodesicError;
use qcshape::geodesic::{
    normalization_factor, GeodesicOptions, GeodesicSolver, InterpolationOptions, Interpolator, Normalization,
};
use qcshape::mesh::Topology;
use qcshape::metric::MetricSpec;
use qcshape::similarity::DistanceMatrix;

/// Settings of a cycle's interpolation and map (shared with the cohort study).
#[derive(Debug, Clone)]
pub struct CycleSettings {
    /// The metric.
    pub metric: MetricSpec,
    /// Geodesic solver options (`steps` = N segments).
    pub geodesic: GeodesicOptions,
    /// Poses inserted between consecutive frames (paper: 3).
    pub insert: usize,
    /// Vertex budget of meshes given as input (coarsened to a vertex subset when larger; 0:
    /// none).
    pub vertices: usize,
    /// Leave the cycle open (no gap last frame -> frame 0).
    pub open: bool,
    /// Frame number step between consecutive input poses (1; `k` when every k-th frame of a
    /// sequence was kept): pose names carry the original frame numbers (`9`, `9.75`).
    pub frame_stride: usize,
}

/// Fig. 9 of one interpolated sequence.
#[derive(Debug, Clone, Serialize)]
pub struct CycleMap {
    /// Pose names: their position in the original frame numbers (`3`, `3.25`; see
    /// [`CycleSettings::frame_stride`]).
    pub names: Vec<String>,
    /// `key` (a frame) or `interpolated`, per pose.
    pub kinds: Vec<String>,
    /// The pose-to-pose distances (n x n, the metric's units).
    #[serde(skip)]
    pub distances: DistanceMatrix,
    /// SMACOF coordinates (n x 2).
    pub coords: Vec<Vec<f64>>,
    /// Poses.
    pub n_poses: usize,
    /// Frames among them.
    pub n_keys: usize,
    /// Normalized stress of the map.
    pub stress: f64,
    /// Whether every geodesic converged.
    pub converged: bool,
    /// Seconds (geodesics and MDS).
    pub seconds: f64,
    /// Length of the closed (or open) path through the poses in order (the metric's units).
    pub path_length: f64,
    /// Largest pose-to-pose distance and its pair of pose names.
    pub diameter: (f64, String, String),
}

/// The MDS map of an interpolated sequence (poses #V x 3 in input units, `factor` the
/// normalization, `per_gap` poses per frame interval); `progress` ticks per pose pair.
#[allow(clippy::too_many_arguments)]
pub fn cycle_map(
    poses: &[Pose],
    is_key: &[bool],
    per_gap: usize,
    topo: &Arc<Topology>,
    factor: f64,
    settings: &CycleSettings,
    seed: u64,
    progress: Progress<'_>,
) -> Result<CycleMap, StudyError> {
    let t0 = Instant::now();
    let metric = settings
        .metric
        .build_scaled(topo, &poses[0], factor)
        .map_err(GeodesicError::from)?;
    let solver = GeodesicSolver::new(metric.as_ref(), topo.clone(), settings.geodesic.clone())?;
    let scaled: Vec<Pose> = poses
        .iter()
        .map(|p| p.iter().map(|v| v.map(|c| c * factor)).collect())
        .collect();
    let n = poses.len();
    let total = n * (n - 1) / 2;
    let (values, converged) = pose_distance_matrix(&solver, &scaled, None, &|| {
        progress(Tick {
            what: "pose pairs",
            total,
        })
    })?;
    progress(Tick::DONE);
    let stride = settings.frame_stride.max(1) as f64;
    let names: Vec<String> = (0..n)
        .map(|k| {
            let t = stride * k as f64 / per_gap as f64;
            if is_key[k] {
                format!("{t:.0}")
            } else {
                format!("{t:.2}").trim_end_matches('0').to_string()
            }
        })
        .collect();
    let d = DistanceMatrix::new(names.clone(), values)?;
    let e = smacof(
        &d,
        &MdsOptions {
            dims: 2,
            seed,
            ..Default::default()
        },
    )?;
    let kinds: Vec<String> = is_key
        .iter()
        .map(|&k| if k { "key" } else { "interpolated" }.to_string())
        .collect();
    let mut path_length: f64 = (0..n - 1).map(|k| d.get(k, k + 1)).sum();
    if !settings.open {
        path_length += d.get(n - 1, 0);
    }
    let mut diameter = (0.0, String::new(), String::new());
    for i in 0..n {
        for j in i + 1..n {
            if d.get(i, j) > diameter.0 {
                diameter = (d.get(i, j), names[i].clone(), names[j].clone());
            }
        }
    }
    Ok(CycleMap {
        n_poses: n,
        n_keys: is_key.iter().filter(|&&k| k).count(),
        stress: e.normalized_stress,
        converged,
        seconds: t0.elapsed().as_secs_f64(),
        path_length,
        diameter,
        names,
        kinds,
        distances: d,
        coords: e.coords,
    })
}

impl CycleMap {
    /// Writes OUT/fig9_distances.csv, OUT/fig9_mds.csv and OUT/fig9_mds.svg|png.
    pub fn write_files(&self, out: &Path, title: &str) -> Result<(), StudyError> {
        self.distances.write_csv(&out.join("fig9_distances.csv"))?;
        // Only the frames are named (interpolated poses would crowd the path).
        let frames = self.kinds.iter().map(|k| k == "key").collect();
        let names = crate::plot::PointNames::Some(frames);
        for ext in ["svg", "png"] {
            crate::plot::scatter_map_with(
                &out.join(format!("fig9_mds.{ext}")),
                &self.coords,
                &self.names,
                Some(&self.kinds),
                title,
                Some(self.stress),
                &names,
            )?;
        }
        let mut csv = String::from("pose,frame_position,kind,x,y\n");
        for k in 0..self.n_poses {
            csv.push_str(&format!(
                "{k},{},{},{:?},{:?}\n",
                self.names[k], self.kinds[k], self.coords[k][0], self.coords[k][1]
            ));
        }
        qcshape::io::write_atomically(&out.join("fig9_mds.csv"), |w| w.write_all(csv.as_bytes()))?;
        Ok(())
    }
}

/// One sequence interpolated and mapped (the single-subject path of `lv run`, and `lv cycle`).
#[derive(Debug, Clone, Serialize)]
pub struct CycleStudy {
    /// The sequence's name.
    pub name: String,
    /// Its frames.
    pub frames: usize,
    /// Vertices of the input meshes.
    pub raw_vertices: usize,
    /// Vertices analysed.
    pub vertices: usize,
    /// What coarsening did, if anything.
    pub note: Option<String>,
    /// Seconds of the interpolation.
    pub interpolation_seconds: f64,
    /// Whether every interpolation geodesic converged.
    pub interpolation_converged: bool,
    /// The map.
    pub map: CycleMap,
}

/// Coarsens, closes (unless `settings.open`), interpolates and maps one sequence of at least
/// two frames. `progress` ticks per interpolated gap, then per pose pair.
pub fn study_cycle(
    def: Deformation,
    settings: &CycleSettings,
    seed: u64,
    progress: Progress<'_>,
) -> Result<CycleStudy, StudyError> {
    if def.poses.len() < 2 {
        return Err(StudyError::ShortCycle(def.poses.len()));
    }
    let frames = def.poses.len();
    let raw_vertices = def.topology.n_vertices();
    let mut defs = vec![def];
    let note = coarsen(&mut defs, settings.vertices)?;
    let def = defs.pop().expect("one deformation");
    let topo = def.topology.clone();
    let factor = normalization_factor(Normalization::MeanEdgeOfFirst, &topo, &def.poses[0]);
    let metric = settings
        .metric
        .build_scaled(&topo, &def.poses[0], factor)
        .map_err(GeodesicError::from)?;
    let keys = if settings.open {
        def.poses.clone()
    } else {
        close_cycle(&def.poses)
    };
    let t0 = Instant::now();
    let interp = Interpolator::new(
        metric.as_ref(),
        &topo,
        &def.poses[0],
        InterpolationOptions {
            insert: settings.insert,
            levels: 1,
            geodesic: settings.geodesic.clone(),
            normalization: Normalization::Factor(factor),
            ..Default::default()
        },
    )?;
    let total = keys.len() - 1;
    let mut r = interp.interpolate_sequence(&keys, &|| {
        progress(Tick {
            what: "interpolating",
            total,
        })
    })?;
    progress(Tick::DONE);
    let interpolation_seconds = t0.elapsed().as_secs_f64();
    let interpolation_converged = r.pairs.iter().all(|p| p.converged);
    if !settings.open {
        drop_closing_pose(&mut r.poses);
        drop_closing_pose(&mut r.is_key);
    }
    let map = cycle_map(
        &r.poses,
        &r.is_key,
        settings.insert + 1,
        &topo,
        factor,
        settings,
        seed,
        progress,
    )?;
    Ok(CycleStudy {
        name: def.name,
        frames,
        raw_vertices,
        vertices: topo.n_vertices(),
        note,
        interpolation_seconds,
        interpolation_converged,
        map,
    })
}

/// The default title of a cycle's figure.
pub fn cycle_title(name: &str, frames: usize) -> String {
    format!("{name}: cycle of {frames} frames + interpolated poses")
}
