//! A path segment as the metrics see it: its two poses, which end supplies the geometry
//! ([`At`]), and the chain rule from `(geometry, displacement)` derivatives to the two ends'.

/// Which end of a path segment supplies the metric's geometry: `G_{P_i}(X_i)` is
/// [`At::Start`], `G_{P_{i+1}}(X_i)` is [`At::End`] (eq. 12).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum At {
    /// Geometry of the segment's first pose `a = P_i`.
    Start,
    /// Geometry of the segment's second pose `b = P_{i+1}`.
    End,
}

/// One evaluation of a metric on a path segment: `X = b - a` measured at `a` or `b`.
#[derive(Debug, Clone, Copy)]
pub struct Segment<'a> {
    /// First pose `P_i` (#V x 3).
    pub a: &'a [[f64; 3]],
    /// Second pose `P_{i+1}` (#V x 3).
    pub b: &'a [[f64; 3]],
    /// Which pose supplies the geometry.
    pub at: At,
    /// Auxiliary unknowns of this term ([`Metric::n_aux`](super::Metric::n_aux) values; the rigid motion
    /// for [`Rigid`](super::Rigid)); empty for the other metrics.
    pub aux: &'a [f64],
    /// Per-vertex weights frozen for a whole path
    /// ([`Metric::frozen_weights`](super::Metric::frozen_weights)), if any.
    pub frozen: Option<&'a [f64]>,
}

/// Chain rule from `(geometry g, displacement X)` derivatives to `(a, b)` derivatives for a
/// segment with `X = b - a` and `g = a` or `g = b`: `dr/da = -dr/dX + [g = a] dr/dg`,
/// `dr/db = dr/dX + [g = b] dr/dg`.
#[inline]
pub(crate) fn split_segment(at: At, dg: [f64; 3], dx: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    match at {
        At::Start => ([dg[0] - dx[0], dg[1] - dx[1], dg[2] - dx[2]], dx),
        At::End => (
            [-dx[0], -dx[1], -dx[2]],
            [dg[0] + dx[0], dg[1] + dx[1], dg[2] + dx[2]],
        ),
    }
}

/// The pose that supplies a segment term's geometry (#V x 3): `a` for `At::Start`, `b` for
/// `At::End`.
pub(crate) fn geometry<'a>(seg: &Segment<'a>) -> &'a [[f64; 3]] {
    match seg.at {
        At::Start => seg.a,
        At::End => seg.b,
    }
}

/// The geometry pose and the displacement `X = b - a` (#V x 3) of a segment.
pub(crate) fn geometry_and_displacement<'a>(seg: &Segment<'a>) -> (&'a [[f64; 3]], Vec<[f64; 3]>) {
    let g = geometry(seg);
    let x = seg
        .a
        .iter()
        .zip(seg.b)
        .map(|(p, q)| [q[0] - p[0], q[1] - p[1], q[2] - p[2]])
        .collect();
    (g, x)
}
