//! A check of a solved path: vertices of the interior poses far off the straight line between
//! their two end positions.
//!
//! The relative forms measure each rate against the current pose's own lengths and weight each
//! face by its frozen share of the ends' area (docs/method.md "Scale-invariant forms"), so the
//! cost of a vertex that leaves its surface is bounded: once its edges are long, their relative
//! rates are about 1 whatever the distance, and a vertex of small faces pays about its faces'
//! share of the area. Measured: the quasi-conformal geodesic without the bending term between
//! the horse gallop's frames 1 and 3 converged with one vertex of a flat valence-4 fan 88 mean
//! edges off its surface in every interior pose, at a path energy 0.5 % below the same path
//! with that vertex on its straight line (docs/log/bending.md "A vertex that leaves the
//! surface"). Such a path is a minimum of the energy, not a failure of the solver, so only a
//! look at the poses finds it.

use crate::mesh::{geometry, Topology};

/// A vertex is off its path when it is farther than this many times the largest end-to-end
/// move of the vertex and its neighbours (plus [`OFF_PATH_EDGES`] mean edges) from the straight
/// line between its end positions. An arc of a rigid turn by at most half a turn is at most half
/// its chord off the chord.
pub const OFF_PATH_FACTOR: f64 = 5.0;

/// The mean edge lengths added to [`OFF_PATH_FACTOR`]'s bound, so that nearly equal ends do
/// not flag the solver's own vertex-scale adjustments.
pub const OFF_PATH_EDGES: f64 = 5.0;

/// The vertex of a path farthest off its straight line between the ends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OffPath {
    /// The vertex.
    pub vertex: usize,
    /// The pose (1 .. N - 1).
    pub pose: usize,
    /// Its distance from the straight line between its end positions, in mean edge lengths
    /// of the ends.
    pub off_edges: f64,
    /// The largest end-to-end move of the vertex and its neighbours, in the same units.
    pub nearby_move_edges: f64,
}

impl OffPath {
    /// The vertex of `poses` (`P_0 .. P_N`, each #V x 3 on `topo`) farthest beyond its bound:
    /// [`OFF_PATH_FACTOR`] times the largest end-to-end move of the vertex and its neighbours
    /// plus [`OFF_PATH_EDGES`], in mean edge lengths of the ends; `None` for a path within every
    /// bound or without interior poses.
    pub fn find(topo: &Topology, poses: &[Vec<[f64; 3]>]) -> Option<OffPath> {
        let (first, last) = (poses.first()?, poses.last()?);
        let edge = 0.5 * (geometry::mean_edge_length(topo, first) + geometry::mean_edge_length(topo, last));
        if !(edge > 0.0 && edge.is_finite()) {
            return None;
        }
        let moves: Vec<[f64; 3]> = first
            .iter()
            .zip(last)
            .map(|(a, b)| geometry::sub(*b, *a))
            .collect();
        let squared: Vec<f64> = moves.iter().map(|d| geometry::dot(*d, *d)).collect();
        let own: Vec<f64> = squared.iter().map(|dd| dd.sqrt() / edge).collect();
        let mut nearby = own.clone();
        for &[i, j] in topo.edges() {
            let (i, j) = (i as usize, j as usize);
            nearby[i] = nearby[i].max(own[j]);
            nearby[j] = nearby[j].max(own[i]);
        }
        let mut worst: Option<OffPath> = None;
        for (pose, p) in poses
            .iter()
            .enumerate()
            .skip(1)
            .take(poses.len().saturating_sub(2))
        {
            for (vertex, ((x, a), d)) in p.iter().zip(first).zip(&moves).enumerate() {
                // Distance from the segment a + t d, t in [0, 1].
                let r = geometry::sub(*x, *a);
                let dd = squared[vertex];
                let t = if dd > 0.0 {
                    (geometry::dot(r, *d) / dd).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let off = geometry::sub(r, geometry::scale(*d, t));
                let found = OffPath {
                    vertex,
                    pose,
                    off_edges: geometry::dot(off, off).sqrt() / edge,
                    nearby_move_edges: nearby[vertex],
                };
                if found.excess() > worst.map_or(0.0, |w| w.excess()) {
                    worst = Some(found);
                }
            }
        }
        worst
    }

    /// The worst off-path vertex of an interpolated sequence (`poses`, with `is_key` marking the
    /// key poses, as [`super::Interpolated`]): each stretch between consecutive key poses is a
    /// path of its own ([`OffPath::find`]). Returns the two key poses' indices in `poses` with
    /// the vertex (its `pose` counted from the first of them).
    pub fn in_sequence(
        topo: &Topology,
        poses: &[Vec<[f64; 3]>],
        is_key: &[bool],
    ) -> Option<(usize, usize, OffPath)> {
        let keys: Vec<usize> = is_key
            .iter()
            .enumerate()
            .filter(|(_, &k)| k)
            .map(|(i, _)| i)
            .collect();
        keys.windows(2)
            .filter(|w| w[1] <= poses.len().saturating_sub(1))
            .filter_map(|w| OffPath::find(topo, &poses[w[0]..=w[1]]).map(|o| (w[0], w[1], o)))
            .max_by(|x, y| x.2.excess().total_cmp(&y.2.excess()))
    }

    /// How far beyond its bound the vertex lies, in mean edge lengths (positive for a found
    /// vertex).
    pub fn excess(&self) -> f64 {
        self.off_edges - (OFF_PATH_FACTOR * self.nearby_move_edges + OFF_PATH_EDGES)
    }

    /// The warning for this vertex, for a metric with the bending term (`bends`) or without
    /// (then the advice is the term: it charges such a vertex, measured on the horse).
    pub fn warning(&self, bends: bool) -> String {
        format!(
            "vertex {} of pose {} lies {:.1} mean edges off the straight line between its end \
             positions, where neither it nor a neighbour moves more than {:.1} between the ends: \
             the path leaves the surface there (a vertex of small faces costs the relative forms \
             little however far it goes) and the distance is not reliable; {}",
            self.vertex,
            self.pose,
            self.off_edges,
            self.nearby_move_edges,
            if bends {
                "check the faces around that vertex"
            } else {
                "the bending term (the default) charges such a vertex"
            }
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn path(topo_positions: &[[f64; 3]], turn: f64, steps: usize) -> Vec<Vec<[f64; 3]>> {
        (0..=steps)
            .map(|i| {
                let a = turn * i as f64 / steps as f64;
                let (c, s) = (a.cos(), a.sin());
                topo_positions
                    .iter()
                    .map(|p| [c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]])
                    .collect()
            })
            .collect()
    }

    /// A half turn's arcs are no escape; one vertex sent 100 radii away in the middle pose is.
    #[test]
    fn a_vertex_far_off_its_line_is_found_and_arcs_are_not() {
        let s = crate::synth::icosphere(2);
        let topo = s.topology.as_ref();
        let turned = path(&s.positions, std::f64::consts::PI, 8);
        assert_eq!(OffPath::find(topo, &turned), None);
        let still = path(&s.positions, 0.0, 8);
        assert_eq!(OffPath::find(topo, &still), None);
        let mut spiked = turned.clone();
        spiked[4][17] = spiked[4][17].map(|c| 100.0 * c);
        let off = OffPath::find(topo, &spiked).expect("the spike is found");
        assert_eq!((off.vertex, off.pose), (17, 4));
        assert!(off.off_edges > 100.0, "{off:?}");
        assert!(off.warning(false).contains("vertex 17 of pose 4"));
        // Two poses (no interior pose) or none: nothing to check.
        assert_eq!(OffPath::find(topo, &spiked[..1]), None);
        // A sequence of two stretches (key poses 0, 4, 8) with a spike in pose 6: found in the
        // second stretch, as its pose 2.
        let keys: Vec<bool> = (0..=8).map(|i| i % 4 == 0).collect();
        let mut sequence = turned.clone();
        sequence[6][17] = sequence[6][17].map(|c| 100.0 * c);
        let (from, to, off) = OffPath::in_sequence(topo, &sequence, &keys).expect("found");
        assert_eq!((from, to, off.vertex, off.pose), (4, 8, 17, 2));
        assert_eq!(OffPath::in_sequence(topo, &turned, &keys), None);
    }
}
