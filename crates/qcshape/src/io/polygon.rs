//! Triangulation of the polygons of OBJ, PLY, OFF and VTK files: convex polygons as a fan from
//! their first corner, others by ear clipping in the polygon's best-fit plane.

/// Triangles (`n - 2` of them) of the polygon with corner indices `poly` (`n > 3`) into
/// `positions` (#V x 3): the fan `[p0, pk, pk+1]` when the polygon is convex, ear clipping
/// otherwise. `None` when the polygon cannot be triangulated (self-intersecting, or all its
/// corners on one line).
pub(crate) fn triangulate(poly: &[u32], positions: &[[f64; 3]]) -> Option<Vec<[u32; 3]>> {
    let n = poly.len();
    let fan = || (1..n - 1).map(|k| [poly[0], poly[k], poly[k + 1]]).collect();
    let pts = project(poly, positions)?;
    let area2: f64 = (0..n)
        .map(|i| {
            let (a, b) = (pts[i], pts[(i + 1) % n]);
            a[0] * b[1] - a[1] * b[0]
        })
        .sum();
    if !(area2.is_finite() && area2 > 0.0) {
        return None;
    }
    let turn =
        |a: [f64; 2], b: [f64; 2], c: [f64; 2]| (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
    let eps = 1e-12 * area2;
    if (0..n).all(|i| turn(pts[i], pts[(i + 1) % n], pts[(i + 2) % n]) >= -eps) {
        return Some(fan());
    }
    // Ear clipping (counter-clockwise after projection).
    let mut rest: Vec<usize> = (0..n).collect();
    let mut out = Vec::with_capacity(n - 2);
    while rest.len() > 3 {
        let m = rest.len();
        let ear = (0..m).find(|&i| {
            let (a, b, c) = (rest[(i + m - 1) % m], rest[i], rest[(i + 1) % m]);
            if turn(pts[a], pts[b], pts[c]) <= eps {
                return false;
            }
            rest.iter()
                .filter(|&&q| q != a && q != b && q != c)
                .all(|&q| !inside(pts[q], pts[a], pts[b], pts[c]))
        })?;
        let (a, b, c) = (rest[(ear + m - 1) % m], rest[ear], rest[(ear + 1) % m]);
        out.push([poly[a], poly[b], poly[c]]);
        rest.remove(ear);
    }
    out.push([poly[rest[0]], poly[rest[1]], poly[rest[2]]]);
    Some(out)
}

/// Whether `p` lies in the closed counter-clockwise triangle `(a, b, c)`.
fn inside(p: [f64; 2], a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> bool {
    let s = |u: [f64; 2], v: [f64; 2]| (v[0] - u[0]) * (p[1] - u[1]) - (v[1] - u[1]) * (p[0] - u[0]);
    s(a, b) >= 0.0 && s(b, c) >= 0.0 && s(c, a) >= 0.0
}

/// The corners in 2D, in the plane normal to the polygon's Newell normal (dropping its largest
/// component, oriented so that the polygon turns counter-clockwise).
fn project(poly: &[u32], positions: &[[f64; 3]]) -> Option<Vec<[f64; 2]>> {
    let p: Vec<[f64; 3]> = poly
        .iter()
        .map(|&i| positions.get(i as usize).copied())
        .collect::<Option<_>>()?;
    let n = p.len();
    let mut normal = [0.0f64; 3];
    for i in 0..n {
        let (a, b) = (p[i], p[(i + 1) % n]);
        normal[0] += (a[1] - b[1]) * (a[2] + b[2]);
        normal[1] += (a[2] - b[2]) * (a[0] + b[0]);
        normal[2] += (a[0] - b[0]) * (a[1] + b[1]);
    }
    let k = (0..3).max_by(|&i, &j| normal[i].abs().total_cmp(&normal[j].abs()))?;
    if normal[k] == 0.0 || !normal[k].is_finite() {
        return None;
    }
    let (u, v) = ((k + 1) % 3, (k + 2) % 3);
    let sign = normal[k].signum();
    Some(p.iter().map(|q| [q[u], sign * q[v]]).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn convex_polygons_are_fans_and_concave_ones_are_clipped_without_folds() {
        let square = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
        assert_eq!(
            triangulate(&[0, 1, 2, 3], &square).unwrap(),
            vec![[0, 1, 2], [0, 2, 3]]
        );
        // A dart A B C D (counter-clockwise, reflex at C) written from B: the fan from B
        // would hold the clockwise (folded) triangle [B, C, D].
        let dart = [
            [0.0, 0.0, 0.0],
            [2.0, -1.0, 0.0],
            [1.0, 0.0, 0.0],
            [2.0, 1.0, 0.0],
        ];
        let t = triangulate(&[1, 2, 3, 0], &dart).unwrap();
        let area2 = |f: &[u32; 3]| {
            let (a, b, c) = (dart[f[0] as usize], dart[f[1] as usize], dart[f[2] as usize]);
            (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        };
        assert!(area2(&[1, 2, 3]) < 0.0);
        assert_eq!(t.len(), 2);
        assert!(t.iter().all(|f| area2(f) > 0.0), "{t:?}");
        assert!((t.iter().map(area2).sum::<f64>() - 2.0).abs() < 1e-12);
        // Collinear corners cannot be triangulated.
        let line = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [3.0, 0.0, 0.0]];
        assert!(triangulate(&[0, 1, 2, 3], &line).is_none());
    }
}
