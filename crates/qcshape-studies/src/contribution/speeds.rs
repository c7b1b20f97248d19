//! Per-vertex speeds of an interpolated sequence, as `qcshape interpolate` writes them on
//! every pose (docs/maps.md).

use super::{path_contributions, ContributionError};
use qcshape::mesh::Topology;
use qcshape::metric::Metric;

/// Per-vertex speed fields of every pose of a sequence `P_0 .. P_N` (N >= 1). Pose `i` carries
/// the segment leaving it, `i -> i + 1` (the segment entering it, `N - 1 -> N`, for the last
/// pose). Each field has one row per pose (N + 1 rows) and one entry per vertex.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseSpeeds {
    /// The vertex's share of the segment's metric length
    /// ([`super::PathContributions::segment_length`]; the metric's units).
    pub speed: Vec<Vec<f64>>,
    /// The length of [`PoseSpeeds::velocity`] (input units per step).
    pub euclidean: Vec<Vec<f64>>,
    /// The vertex's displacement over the segment (input units per step).
    pub velocity: Vec<Vec<[f64; 3]>>,
}

/// The speed fields of `poses` (each #V x 3, input units) for `metric` on `topo`, the poses
/// multiplied by `scale` for the metric (the solvers' normalization). `None` for fewer than two
/// poses (no segment).
pub fn pose_speeds(
    metric: &dyn Metric,
    topo: &Topology,
    poses: &[Vec<[f64; 3]>],
    scale: f64,
) -> Result<Option<PoseSpeeds>, ContributionError> {
    if poses.len() < 2 {
        return Ok(None);
    }
    let c = path_contributions(metric, topo, poses, scale)?;
    let mut out = PoseSpeeds {
        speed: Vec::with_capacity(poses.len()),
        euclidean: Vec::with_capacity(poses.len()),
        velocity: Vec::with_capacity(poses.len()),
    };
    for i in 0..poses.len() {
        let s = i.min(poses.len() - 2);
        let v: Vec<[f64; 3]> = poses[s]
            .iter()
            .zip(&poses[s + 1])
            .map(|(a, b)| [b[0] - a[0], b[1] - a[1], b[2] - a[2]])
            .collect();
        out.euclidean.push(
            v.iter()
                .map(|d| (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt())
                .collect(),
        );
        out.velocity.push(v);
        out.speed.push(c.segment_length[s].clone());
    }
    Ok(Some(out))
}

#[cfg(test)]
mod tests {
    use super::*;
    use qcshape::metric::Isometric;
    use qcshape::synth::icosphere;

    #[test]
    fn the_last_pose_carries_the_segment_entering_it() {
        let shape = icosphere(1);
        let (topo, v) = (shape.topology, shape.positions);
        let p1: Vec<[f64; 3]> = v.iter().map(|p| [1.1 * p[0], p[1], p[2]]).collect();
        let p2: Vec<[f64; 3]> = v.iter().map(|p| [1.3 * p[0], p[1], p[2]]).collect();
        let poses = vec![v.clone(), p1, p2];
        assert!(pose_speeds(&Isometric, &topo, &poses[..1], 1.0)
            .unwrap()
            .is_none());
        let s = pose_speeds(&Isometric, &topo, &poses, 1.0).unwrap().unwrap();
        assert_eq!(s.speed.len(), 3);
        assert_eq!(s.velocity[1], s.velocity[2]);
        assert_eq!(s.speed[1], s.speed[2]);
        let dx = 0.1 * v[0][0];
        assert!((s.velocity[0][0][0] - dx).abs() < 1e-12);
        assert!((s.euclidean[0][0] - dx.abs()).abs() < 1e-12);
        assert!(s.speed[0].iter().all(|x| x.is_finite() && *x >= 0.0));
    }
}
