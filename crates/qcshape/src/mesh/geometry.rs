//! Derived geometry of a shape: functions of (topology, positions #V x 3), recomputed on demand.
//!
//! Also the small 3-vector helpers the metrics share.

use super::Topology;

/// Difference `a - b`.
#[inline]
pub fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
/// Sum `a + b`.
#[inline]
pub fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
/// Scaling `s * a`.
#[inline]
pub fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}
/// The points `p` (#V x 3) with every coordinate multiplied by `f` (a shape scaled about the
/// origin, e.g. by a normalization factor).
pub fn scaled(p: &[[f64; 3]], f: f64) -> Vec<[f64; 3]> {
    p.iter().map(|v| scale(*v, f)).collect()
}
/// The largest distance between corresponding points of `a` and `b` (#V x 3 each; same units):
/// how far a fit's iteration moved any vertex.
pub fn largest_move(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(p, q)| dot(sub(*p, *q), sub(*p, *q)))
        .fold(0.0, f64::max)
        .sqrt()
}
/// The centroid of the points `p` (#V x 3) and their rms distance from it (at least the
/// smallest positive number): the frame in which a fit normalizes a template to centroid 0
/// and rms radius 1.
pub fn centroid_and_rms_radius(p: &[[f64; 3]]) -> ([f64; 3], f64) {
    let n = p.len() as f64;
    let mut center = [0.0; 3];
    for q in p {
        for k in 0..3 {
            center[k] += q[k] / n;
        }
    }
    let radius = (p
        .iter()
        .map(|q| dot(sub(*q, center), sub(*q, center)))
        .sum::<f64>()
        / n)
        .sqrt()
        .max(f64::MIN_POSITIVE);
    (center, radius)
}
/// Dot product.
#[inline]
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
/// Cross product.
#[inline]
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
/// Euclidean norm.
#[inline]
pub fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// Length of every edge (#E), in the unit of the positions.
pub fn edge_lengths(topo: &Topology, pos: &[[f64; 3]]) -> Vec<f64> {
    topo.edges()
        .iter()
        .map(|e| norm(sub(pos[e[0] as usize], pos[e[1] as usize])))
        .collect()
}

/// Mean edge length `lbar` (the scale used for normalization and noise, docs/method.md "Metrics" and
/// "Noise").
pub fn mean_edge_length(topo: &Topology, pos: &[[f64; 3]]) -> f64 {
    let l = edge_lengths(topo, pos);
    l.iter().sum::<f64>() / l.len().max(1) as f64
}

/// Area of every face (#F), in squared units.
pub fn face_areas(topo: &Topology, pos: &[[f64; 3]]) -> Vec<f64> {
    topo.faces()
        .iter()
        .map(|f| {
            let [p, q, r] = f.map(|i| pos[i as usize]);
            0.5 * norm(cross(sub(q, p), sub(r, p)))
        })
        .collect()
}

/// Total surface area.
pub fn total_area(topo: &Topology, pos: &[[f64; 3]]) -> f64 {
    face_areas(topo, pos).iter().sum()
}

/// Unit normal of every face (#F x 3), oriented by the face's vertex order; zero for a
/// degenerate face.
pub fn face_normals(topo: &Topology, pos: &[[f64; 3]]) -> Vec<[f64; 3]> {
    topo.faces()
        .iter()
        .map(|f| {
            let [p, q, r] = f.map(|i| pos[i as usize]);
            let n = cross(sub(q, p), sub(r, p));
            let l = norm(n);
            if l > 0.0 {
                scale(n, 1.0 / l)
            } else {
                [0.0; 3]
            }
        })
        .collect()
}

/// Area-weighted unit vertex normals (#V x 3); zero for isolated vertices.
pub fn vertex_normals(topo: &Topology, pos: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let mut n = vec![[0.0; 3]; topo.n_vertices()];
    for f in topo.faces() {
        let [p, q, r] = f.map(|i| pos[i as usize]);
        let w = cross(sub(q, p), sub(r, p)); // 2 * area * unit normal
        for &i in f {
            n[i as usize] = add(n[i as usize], w);
        }
    }
    for v in &mut n {
        let l = norm(*v);
        if l > 0.0 {
            *v = scale(*v, 1.0 / l);
        }
    }
    n
}

/// Interior angle at the corner `p` of triangle `(p, q, r)`, in radians, computed stably as
/// `atan2(|u x v|, u . v)` with `u = q - p`, `v = r - p`.
#[inline]
pub fn corner_angle(p: [f64; 3], q: [f64; 3], r: [f64; 3]) -> f64 {
    let (u, v) = (sub(q, p), sub(r, p));
    norm(cross(u, v)).atan2(dot(u, v))
}

/// Gradient of [`corner_angle`] with respect to `(p, q, r)`.
///
/// With `n` the unit normal of `(p, q, r)`: `d/dq = -(n x u)/|u|^2`, `d/dr = (n x v)/|v|^2`,
/// `d/dp = -(d/dq + d/dr)`. Zero for a degenerate triangle.
#[inline]
pub fn corner_angle_gradient(p: [f64; 3], q: [f64; 3], r: [f64; 3]) -> [[f64; 3]; 3] {
    let (u, v) = (sub(q, p), sub(r, p));
    let c = cross(u, v);
    let lc = norm(c);
    let (uu, vv) = (dot(u, u), dot(v, v));
    if lc <= 0.0 || uu <= 0.0 || vv <= 0.0 {
        return [[0.0; 3]; 3];
    }
    let n = scale(c, 1.0 / lc);
    let dq = scale(cross(n, u), -1.0 / uu);
    let dr = scale(cross(n, v), 1.0 / vv);
    [scale(add(dq, dr), -1.0), dq, dr]
}

/// Corner angles (#F x 3): `angles[f][k]` is the angle at corner `k` of face `f`, radians.
pub fn corner_angles(topo: &Topology, pos: &[[f64; 3]]) -> Vec<[f64; 3]> {
    topo.faces()
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(|i| pos[i as usize]);
            [
                corner_angle(a, b, c),
                corner_angle(b, c, a),
                corner_angle(c, a, b),
            ]
        })
        .collect()
}

/// Vertex areas `A_p` (#V): one third of the area of the faces at `p` (paper eq. 11).
pub fn vertex_areas(topo: &Topology, pos: &[[f64; 3]]) -> Vec<f64> {
    let mut a = vec![0.0; topo.n_vertices()];
    for (f, area) in topo.faces().iter().zip(face_areas(topo, pos)) {
        for &i in f {
            a[i as usize] += area / 3.0;
        }
    }
    a
}

/// Angle-defect (discrete Gaussian) curvature `K_p` (#V), radians: `2 pi - sum of corner
/// angles` at an interior vertex, `pi - sum` at a boundary vertex (docs/method.md
/// "Metrics"; paper section 2.1). Zero at isolated vertices.
pub fn angle_defect(topo: &Topology, pos: &[[f64; 3]]) -> Vec<f64> {
    let mut k: Vec<f64> = (0..topo.n_vertices())
        .map(|v| {
            if topo.vertex_faces(v).is_empty() {
                0.0
            } else if topo.is_boundary_vertex(v) {
                std::f64::consts::PI
            } else {
                2.0 * std::f64::consts::PI
            }
        })
        .collect();
    for (f, ang) in topo.faces().iter().zip(corner_angles(topo, pos)) {
        for c in 0..3 {
            k[f[c] as usize] -= ang[c];
        }
    }
    k
}

/// Axis-aligned bounding box `(min, max)` of the positions.
pub fn bounding_box(pos: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in pos {
        for c in 0..3 {
            lo[c] = lo[c].min(p[c]);
            hi[c] = hi[c].max(p[c]);
        }
    }
    (lo, hi)
}

/// `s = sqrt(area / 3)` of triangle `(p, q, r)` (the per-corner L2 weight of eq. 11) and its
/// gradient with respect to `(p, q, r)`, from `d area / d p = 0.5 (q - r) x n` (cyclic).
/// The gradient is zero for a degenerate triangle.
#[inline]
pub fn sqrt_third_area_gradient(p: [f64; 3], q: [f64; 3], r: [f64; 3]) -> (f64, [[f64; 3]; 3]) {
    let c = cross(sub(q, p), sub(r, p));
    let lc = norm(c);
    let s = (0.5 * lc / 3.0).sqrt();
    if lc <= 0.0 || s <= 0.0 {
        return (s, [[0.0; 3]; 3]);
    }
    let n = scale(c, 1.0 / lc);
    // ds = darea / (6 s).
    let k = 0.5 / (6.0 * s);
    (
        s,
        [cross(sub(q, r), n), cross(sub(r, p), n), cross(sub(p, q), n)].map(|v| scale(v, k)),
    )
}

/// The closest point of triangle `(a, b, c)` to `p` and its barycentric coordinates (Ericson,
/// Real-Time Collision Detection, 5.1.5: Voronoi regions of the corners, edges and face).
/// Degenerate triangles (a point or a segment) are handled by the same region tests, falling
/// back to the nearest corner: never a NaN. Used by the mesh hierarchy's prolongation and the
/// fit's closest-point queries.
pub fn closest_point_on_triangle(p: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, [1.0, 0.0, 0.0]);
    }
    let bp = sub(p, b);
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (b, [0.0, 1.0, 0.0]);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 && d1 - d3 > 0.0 {
        let v = d1 / (d1 - d3);
        return (add(a, scale(ab, v)), [1.0 - v, v, 0.0]);
    }
    let cp = sub(p, c);
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (c, [0.0, 0.0, 1.0]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 && d2 - d6 > 0.0 {
        let w = d2 / (d2 - d6);
        return (add(a, scale(ac, w)), [1.0 - w, 0.0, w]);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 && (d4 - d3) + (d5 - d6) > 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (add(b, scale(sub(c, b), w)), [0.0, 1.0 - w, w]);
    }
    let den = va + vb + vc;
    if den == 0.0 || !den.is_finite() {
        // Degenerate (collinear) triangle not caught above: the nearest corner.
        let da = dot(ap, ap);
        let (db, dc) = (dot(bp, bp), dot(cp, cp));
        return if da <= db && da <= dc {
            (a, [1.0, 0.0, 0.0])
        } else if db <= dc {
            (b, [0.0, 1.0, 0.0])
        } else {
            (c, [0.0, 0.0, 1.0])
        };
    }
    let v = vb / den;
    let w = vc / den;
    (add(a, add(scale(ab, v), scale(ac, w))), [1.0 - v - w, v, w])
}
