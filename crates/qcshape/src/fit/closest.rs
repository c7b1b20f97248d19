//! Closest points on a triangle mesh or a point set: a bounding-volume hierarchy of axis-aligned
//! boxes (median split on the longest axis, at most `LEAF` primitives per leaf), queried by a
//! depth-first search that visits the nearer child first and prunes boxes farther than the best
//! distance found. Exact (not approximate): the answer is the closest point of all primitives,
//! ties broken by the lowest primitive index.
//!
//! Written here rather than taken from a crate: the fit needs point-to-triangle queries with
//! the barycentric coordinates of the answer (surface-to-point terms spread a pull over a
//! triangle's corners), 200 lines, deterministic, no `unsafe`.

use crate::mesh::geometry::{add, closest_point_on_triangle, dot, scale, sub};

/// Primitives per leaf.
const LEAF: usize = 4;

/// The closest point found by [`SurfaceIndex::closest`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Closest {
    /// The closest point (input units).
    pub point: [f64; 3],
    /// Its squared distance to the query (input units squared).
    pub distance_sq: f64,
    /// The primitive: a face index (meshes) or a point index (point sets).
    pub primitive: u32,
    /// Barycentric coordinates of `point` on the face's corners (`[1, 0, 0]` for a point set).
    pub bary: [f64; 3],
}

#[derive(Debug, Clone, Copy)]
struct Node {
    lo: [f64; 3],
    hi: [f64; 3],
    /// Leaf: primitives `order[start..start + count]`; inner: the children are the nodes
    /// `start` (left) and `count` (right).
    start: u32,
    count: u32,
    leaf: bool,
}

/// A bounding-volume hierarchy over triangles (faces #F x 3 into positions #V x 3) or points.
#[derive(Debug, Clone)]
pub struct SurfaceIndex {
    tris: Vec<[[f64; 3]; 3]>,
    order: Vec<u32>,
    nodes: Vec<Node>,
}

impl SurfaceIndex {
    /// The index of a triangle mesh. Faces whose indices are out of range are skipped (callers
    /// check indices first); an empty face list gives an empty index.
    pub fn triangles(positions: &[[f64; 3]], faces: &[[u32; 3]]) -> SurfaceIndex {
        let tris = faces
            .iter()
            .filter(|f| f.iter().all(|&i| (i as usize) < positions.len()))
            .map(|f| f.map(|i| positions[i as usize]))
            .collect();
        Self::build(tris)
    }

    /// The index of a point set (#P x 3): the closest point is the nearest input point.
    pub fn points(positions: &[[f64; 3]]) -> SurfaceIndex {
        Self::build(positions.iter().map(|&p| [p, p, p]).collect())
    }

    /// Number of primitives.
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    /// Whether there are no primitives.
    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    fn build(tris: Vec<[[f64; 3]; 3]>) -> SurfaceIndex {
        let n = tris.len();
        let centroids: Vec<[f64; 3]> = tris
            .iter()
            .map(|t| scale(add(add(t[0], t[1]), t[2]), 1.0 / 3.0))
            .collect();
        let mut order: Vec<u32> = (0..n as u32).collect();
        let mut nodes = Vec::with_capacity(2 * n / LEAF + 1);
        if n > 0 {
            // Explicit stack of (node index, range): no recursion depth to worry about.
            nodes.push(Node {
                lo: [0.0; 3],
                hi: [0.0; 3],
                start: 0,
                count: 0,
                leaf: true,
            });
            let mut stack = vec![(0usize, 0usize, n)];
            while let Some((node, a, b)) = stack.pop() {
                let (lo, hi) = bounds(order[a..b].iter().flat_map(|&i| tris[i as usize]));
                nodes[node].lo = lo;
                nodes[node].hi = hi;
                if b - a <= LEAF {
                    nodes[node].start = a as u32;
                    nodes[node].count = (b - a) as u32;
                    continue;
                }
                let (clo, chi) = bounds(order[a..b].iter().map(|&i| centroids[i as usize]));
                let ext = sub(chi, clo);
                let axis = (0..3).fold(0, |m, k| if ext[k] > ext[m] { k } else { m });
                let mid = (a + b) / 2;
                order[a..b].select_nth_unstable_by(mid - a, |&i, &j| {
                    let (ci, cj) = (centroids[i as usize][axis], centroids[j as usize][axis]);
                    ci.total_cmp(&cj).then(i.cmp(&j))
                });
                let left = nodes.len();
                for _ in 0..2 {
                    nodes.push(Node {
                        lo: [0.0; 3],
                        hi: [0.0; 3],
                        start: 0,
                        count: 0,
                        leaf: true,
                    });
                }
                nodes[node].leaf = false;
                nodes[node].start = left as u32;
                nodes[node].count = (left + 1) as u32;
                stack.push((left, a, mid));
                stack.push((left + 1, mid, b));
            }
        }
        SurfaceIndex { tris, order, nodes }
    }

    /// The closest point to `q` over all primitives; `None` for an empty index or a
    /// non-finite query.
    pub fn closest(&self, q: [f64; 3]) -> Option<Closest> {
        if self.nodes.is_empty() || q.iter().any(|c| !c.is_finite()) {
            return None;
        }
        let mut best: Option<Closest> = None;
        let mut best_d = f64::INFINITY;
        let mut stack: Vec<(usize, f64)> = vec![(0, box_distance_sq(&self.nodes[0], q))];
        while let Some((k, d)) = stack.pop() {
            if d > best_d {
                continue;
            }
            let node = self.nodes[k];
            if node.leaf {
                for &i in &self.order[node.start as usize..(node.start + node.count) as usize] {
                    let t = &self.tris[i as usize];
                    let (p, bary) = closest_point_on_triangle(q, t[0], t[1], t[2]);
                    let e = sub(p, q);
                    let dd = dot(e, e);
                    let better = match best {
                        None => true,
                        Some(b) => dd < b.distance_sq || (dd == b.distance_sq && i < b.primitive),
                    };
                    if better {
                        best_d = dd;
                        best = Some(Closest {
                            point: p,
                            distance_sq: dd,
                            primitive: i,
                            bary,
                        });
                    }
                }
            } else {
                let (l, r) = (node.start as usize, node.count as usize);
                let (dl, dr) = (
                    box_distance_sq(&self.nodes[l], q),
                    box_distance_sq(&self.nodes[r], q),
                );
                // Push the farther first so the nearer is searched first.
                if dl <= dr {
                    stack.push((r, dr));
                    stack.push((l, dl));
                } else {
                    stack.push((l, dl));
                    stack.push((r, dr));
                }
            }
        }
        best
    }
}

fn bounds(points: impl Iterator<Item = [f64; 3]>) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

fn box_distance_sq(n: &Node, q: [f64; 3]) -> f64 {
    (0..3)
        .map(|k| {
            let d = (n.lo[k] - q[k]).max(q[k] - n.hi[k]).max(0.0);
            d * d
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::icosphere;
    use rand::{Rng, SeedableRng};

    fn brute(pos: &[[f64; 3]], faces: &[[u32; 3]], q: [f64; 3]) -> f64 {
        faces
            .iter()
            .map(|f| {
                let (p, _) =
                    closest_point_on_triangle(q, pos[f[0] as usize], pos[f[1] as usize], pos[f[2] as usize]);
                dot(sub(p, q), sub(p, q))
            })
            .fold(f64::INFINITY, f64::min)
    }

    #[test]
    fn matches_brute_force_on_a_sphere() {
        let s = icosphere(2);
        let idx = SurfaceIndex::triangles(&s.positions, s.topology.faces());
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for _ in 0..300 {
            let q = [0; 3].map(|_| rng.random_range(-1.6..1.6));
            let c = idx.closest(q).unwrap();
            assert!((c.distance_sq - brute(&s.positions, s.topology.faces(), q)).abs() < 1e-12);
            // The barycentric coordinates reproduce the point.
            let f = s.topology.faces()[c.primitive as usize];
            let mut p = [0.0; 3];
            for (&v, &b) in f.iter().zip(&c.bary) {
                p = add(p, scale(s.positions[v as usize], b));
            }
            assert!(dot(sub(p, c.point), sub(p, c.point)) < 1e-20);
            assert!(c.bary.iter().all(|&b| (-1e-12..=1.0 + 1e-12).contains(&b)));
        }
    }

    #[test]
    fn point_sets_and_empty_input() {
        let pts = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0]];
        let idx = SurfaceIndex::points(&pts);
        let c = idx.closest([0.9, 0.2, 0.0]).unwrap();
        assert_eq!(c.primitive, 1);
        assert!((c.distance_sq - 0.05).abs() < 1e-12);
        assert!(SurfaceIndex::points(&[]).closest([0.0; 3]).is_none());
        assert!(idx.closest([f64::NAN, 0.0, 0.0]).is_none());
    }

    #[test]
    fn triangle_regions() {
        let (a, b, c) = ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        let (p, _) = closest_point_on_triangle([0.2, 0.2, 1.0], a, b, c);
        assert!(dot(sub(p, [0.2, 0.2, 0.0]), sub(p, [0.2, 0.2, 0.0])) < 1e-30);
        assert_eq!(closest_point_on_triangle([-1.0, -1.0, 0.0], a, b, c).0, a);
        assert_eq!(
            closest_point_on_triangle([0.5, -1.0, 0.0], a, b, c).0,
            [0.5, 0.0, 0.0]
        );
        let (p, w) = closest_point_on_triangle([1.0, 1.0, 0.0], a, b, c);
        assert_eq!(p, [0.5, 0.5, 0.0]);
        assert_eq!(w, [0.0, 0.5, 0.5]);
    }
}
