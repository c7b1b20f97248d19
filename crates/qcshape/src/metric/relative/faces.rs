//! The per-face values every relative form is weighted by: each face's share of the surface
//! area and of the squared edge lengths, per pose and frozen along a path (the mean of the two
//! ends').

use std::borrow::Cow;

use crate::mesh::geometry::{cross, dot, norm, scale, sub};
use crate::mesh::Topology;
use crate::metric::segment::Segment;

/// Frozen values per face of every relative form: the area share `c_f = A_f / A` and the size
/// share `q_f = L_f / A` (`L_f` the sum of the face's squared edge lengths).
pub(crate) const PER_FACE: usize = 2;

/// The face summary of one pose (2 #F values, dimensionless): `[c_f for every face, q_f for
/// every face]` (see [`PER_FACE`]). Zeros for a pose of zero area.
pub(crate) fn face_summary(topo: &Topology, pose: &[[f64; 3]]) -> Vec<f64> {
    let nf = topo.n_faces();
    let mut out = vec![0.0; PER_FACE * nf];
    let mut total = 0.0;
    for (fi, f) in topo.faces().iter().enumerate() {
        let [p, q, r] = f.map(|i| pose[i as usize]);
        let (e0, e1, e2) = (sub(q, p), sub(r, q), sub(p, r));
        let area = 0.5 * norm(cross(e0, sub(r, p)));
        out[fi] = area;
        out[nf + fi] = dot(e0, e0) + dot(e1, e1) + dot(e2, e2);
        total += area;
    }
    let inv = if total > 0.0 && total.is_finite() {
        1.0 / total
    } else {
        0.0
    };
    for v in &mut out {
        *v *= inv;
    }
    out
}

/// The mean of two face summaries (the frozen values of a path between the two poses).
pub(crate) fn mean_summary(a: &[f64], b: &[f64]) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| 0.5 * (x + y)).collect()
}

/// The frozen face values of a path from `start` to `end` (2 #F).
pub(crate) fn path_faces(topo: &Topology, start: &[[f64; 3]], end: &[[f64; 3]]) -> Vec<f64> {
    mean_summary(&face_summary(topo, start), &face_summary(topo, end))
}

/// [`path_faces`] as a metric's [`Metric::frozen_weights`](crate::metric::Metric::frozen_weights):
/// `None` unless both ends have #V vertices.
pub(crate) fn frozen_faces(topo: &Topology, start: &[[f64; 3]], end: &[[f64; 3]]) -> Option<Vec<f64>> {
    let nv = topo.n_vertices();
    (start.len() == nv && end.len() == nv).then(|| path_faces(topo, start, end))
}

/// [`face_summary`] as a metric's [`Metric::pose_summary`](crate::metric::Metric::pose_summary):
/// `None` unless the pose has #V vertices.
pub(crate) fn pose_faces(topo: &Topology, pose: &[[f64; 3]]) -> Option<Vec<f64>> {
    (pose.len() == topo.n_vertices()).then(|| face_summary(topo, pose))
}

/// [`frozen_faces`] from the two ends' [`pose_faces`] summaries (recomputed from the poses
/// when a summary is not 2 #F values).
pub(crate) fn faces_from(
    topo: &Topology,
    start: &[[f64; 3]],
    end: &[[f64; 3]],
    [a, b]: [&[f64]; 2],
) -> Option<Vec<f64>> {
    let n = PER_FACE * topo.n_faces();
    if a.len() != n || b.len() != n {
        return frozen_faces(topo, start, end);
    }
    Some(mean_summary(a, b))
}

/// The three [`Metric`](crate::metric::Metric) methods of a relative form whose frozen values
/// are the path's face shares and nothing else (2 #F): `frozen_weights` ([`frozen_faces`]),
/// `pose_summary` ([`pose_faces`]) and `frozen_weights_from` ([`faces_from`]), written inside
/// the form's `impl Metric` block.
macro_rules! face_share_frozen_values {
    () => {
        /// The mean face shares of the two ends (2 #F).
        fn frozen_weights(
            &self,
            topo: &$crate::mesh::Topology,
            start: &[[f64; 3]],
            end: &[[f64; 3]],
        ) -> Option<Vec<f64>> {
            $crate::metric::relative::faces::frozen_faces(topo, start, end)
        }

        /// The pose's face shares (2 #F).
        fn pose_summary(&self, topo: &$crate::mesh::Topology, pose: &[[f64; 3]]) -> Option<Vec<f64>> {
            $crate::metric::relative::faces::pose_faces(topo, pose)
        }

        /// The mean of the two ends' face shares.
        fn frozen_weights_from(
            &self,
            topo: &$crate::mesh::Topology,
            start: &[[f64; 3]],
            end: &[[f64; 3]],
            summaries: [&[f64]; 2],
        ) -> Option<Vec<f64>> {
            $crate::metric::relative::faces::faces_from(topo, start, end, summaries)
        }
    };
}
pub(crate) use face_share_frozen_values;

/// The face values a segment term uses: the first 2 #F values of `seg.frozen`, or, without
/// them, those of a path between the segment's own ends.
pub(crate) fn segment_faces<'a>(topo: &Topology, seg: &Segment<'a>) -> Cow<'a, [f64]> {
    let n = PER_FACE * topo.n_faces();
    match seg.frozen {
        Some(f) if f.len() >= n => Cow::Borrowed(&f[..n]),
        _ => Cow::Owned(path_faces(topo, seg.a, seg.b)),
    }
}

/// The area share of each edge (#E): a third of each adjacent face's share `c_f`, so that the
/// shares sum to one.
pub(crate) fn edge_shares(topo: &Topology, faces: &[f64]) -> Vec<f64> {
    let mut w = vec![0.0; topo.n_edges()];
    for (fi, fe) in topo.face_edges().iter().enumerate() {
        for &e in fe {
            w[e as usize] += faces[fi] / 3.0;
        }
    }
    w
}

/// `k` times the gradient of an edge's strain rate `q = p / l` (`p = <e, d>`, `l = |e|^2`, `e`
/// the edge vector, `d` its displacement) with respect to `e` and to `d`:
/// `k (d / l - 2 p e / l^2)` and `k e / l` (eq. 3's and eq. 6's rates).
#[inline(always)]
pub(super) fn strain_rate_gradient(e: [f64; 3], d: [f64; 3], l: f64, p: f64, k: f64) -> ([f64; 3], [f64; 3]) {
    (
        scale(sub(scale(d, 1.0 / l), scale(e, 2.0 * p / (l * l))), k),
        scale(e, k / l),
    )
}
