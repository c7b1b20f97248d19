use std::collections::HashMap;
use std::sync::Arc;

use crate::mesh::{geometry, Shape, Topology};

/// Unit icosphere: an icosahedron subdivided `level` times and projected to the unit sphere.
///
/// Vertex counts: level 0: 12, 1: 42, 2: 162, 3: 642, 4: 2,562, 5: 10,242
/// (`10 * 4^level + 2`). Faces are oriented outwards. Genus 0, no boundary.
pub fn icosphere(level: u32) -> Shape {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut pos: Vec<[f64; 3]> = vec![
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ];
    let mut faces: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for p in &mut pos {
        *p = geometry::scale(*p, 1.0 / geometry::norm(*p));
    }
    for _ in 0..level {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut next = Vec::with_capacity(faces.len() * 4);
        let mut midpoint = |a: u32, b: u32, pos: &mut Vec<[f64; 3]>| -> u32 {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let m = geometry::scale(geometry::add(pos[a as usize], pos[b as usize]), 0.5);
                pos.push(geometry::scale(m, 1.0 / geometry::norm(m)));
                (pos.len() - 1) as u32
            })
        };
        for f in &faces {
            let a = midpoint(f[0], f[1], &mut pos);
            let b = midpoint(f[1], f[2], &mut pos);
            let c = midpoint(f[2], f[0], &mut pos);
            next.extend_from_slice(&[[f[0], a, c], [f[1], b, a], [f[2], c, b], [a, b, c]]);
        }
        faces = next;
    }
    let topo = Topology::new(pos.len(), faces).expect("icosphere topology is valid");
    Shape::new(topo, pos).expect("icosphere positions are finite")
}

/// Torus with major radius `major` and minor radius `minor`, sampled on an `nu x nv` grid
/// (around the axis x around the tube). Genus 1, no boundary, faces oriented outwards.
pub fn torus(nu: usize, nv: usize, major: f64, minor: f64) -> Shape {
    assert!(nu >= 3 && nv >= 3, "torus needs at least 3 x 3 samples");
    let mut pos = Vec::with_capacity(nu * nv);
    for i in 0..nu {
        let u = 2.0 * std::f64::consts::PI * i as f64 / nu as f64;
        for j in 0..nv {
            let v = 2.0 * std::f64::consts::PI * j as f64 / nv as f64;
            let r = major + minor * v.cos();
            pos.push([r * u.cos(), r * u.sin(), minor * v.sin()]);
        }
    }
    let id = |i: usize, j: usize| ((i % nu) * nv + (j % nv)) as u32;
    let mut faces = Vec::with_capacity(2 * nu * nv);
    for i in 0..nu {
        for j in 0..nv {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            faces.push([a, b, c]);
            faces.push([a, c, d]);
        }
    }
    let topo = Topology::new(pos.len(), faces).expect("torus topology is valid");
    Shape::new(topo, pos).expect("torus positions are finite")
}

/// Open tube (a cylinder without caps) along the x axis from 0 to `length`, of radius `radius`,
/// with `n_along` rings of `n_around` vertices (`n_along * n_around` vertices, two boundary
/// loops). Ring `i` is at `x = length * i / (n_along - 1)`; faces are oriented outwards.
/// Vertex `i * n_around + j` is ring `i`, angle `2 pi j / n_around`.
pub fn tube(length: f64, radius: f64, n_around: usize, n_along: usize) -> Shape {
    assert!(n_around >= 3 && n_along >= 2, "tube needs at least 3 x 2 samples");
    let mut pos = Vec::with_capacity(n_around * n_along);
    for i in 0..n_along {
        let x = length * i as f64 / (n_along - 1) as f64;
        for j in 0..n_around {
            let a = 2.0 * std::f64::consts::PI * j as f64 / n_around as f64;
            pos.push([x, radius * a.cos(), radius * a.sin()]);
        }
    }
    let id = |i: usize, j: usize| (i * n_around + j % n_around) as u32;
    let mut faces = Vec::with_capacity(2 * n_around * (n_along - 1));
    for i in 0..n_along - 1 {
        for j in 0..n_around {
            let (a, b, c, d) = (id(i, j), id(i, j + 1), id(i + 1, j + 1), id(i + 1, j));
            faces.push([a, b, c]);
            faces.push([a, c, d]);
        }
    }
    let topo = Topology::new(pos.len(), faces).expect("tube topology is valid");
    Shape::new(topo, pos).expect("tube positions are finite")
}

/// The positions of a straight shape along the x axis (such as [`tube`], centre line on the x
/// axis from 0) bent in the x-y plane so that the x axis becomes a circular arc of the same
/// length turning by `angle` radians (`pi`: a half circle): the point `(x, y, z)` goes to
/// `c(x) + y n(x) + (0, 0, z)` with `c` the arc and `n` its in-plane normal. Cross-sections
/// stay rigid and perpendicular to the centre line, whose length is kept. `angle` 0 leaves
/// the positions unchanged.
pub fn bend_along_x(positions: &[[f64; 3]], angle: f64) -> Vec<[f64; 3]> {
    if angle == 0.0 {
        return positions.to_vec();
    }
    let length = positions.iter().fold(0.0f64, |m, p| m.max(p[0]));
    let r = length / angle;
    positions
        .iter()
        .map(|p| {
            let phi = p[0] / r;
            let (s, c) = phi.sin_cos();
            [r * s - p[1] * s, r * (1.0 - c) + p[1] * c, p[2]]
        })
        .collect()
}

/// Positions twisted about the z axis by `rate * z` radians and stretched by `stretch` along z:
/// `(x, y, z)` goes to `(R(rate z) (x, y), stretch z)`.
pub fn twist_along_z(positions: &[[f64; 3]], rate: f64, stretch: f64) -> Vec<[f64; 3]> {
    positions
        .iter()
        .map(|p| {
            let (s, c) = (rate * p[2]).sin_cos();
            [c * p[0] - s * p[1], s * p[0] + c * p[1], stretch * p[2]]
        })
        .collect()
}

/// The twisted sphere: the unit icosphere of `level` and the same smooth deformation of it at
/// every level, a twist about z by 1.2 z radians and a stretch by 1.5 along z
/// ([`twist_along_z`]); `qcshape geodesic --demo`, the resolution study of
/// `qcshape experiment geometry` and the geodesic benches.
pub fn twisted_sphere(level: u32) -> (Shape, Shape) {
    let a = icosphere(level);
    let b = Shape::new(a.topology.clone(), twist_along_z(&a.positions, 1.2, 1.5))
        .expect("twisted sphere is valid");
    (a, b)
}

/// Open planar grid on `[0, 1]^2` (z = 0) with `n x n` vertices: a disk with one boundary loop.
pub fn grid(n: usize) -> Shape {
    assert!(n >= 2, "grid needs at least 2 x 2 vertices");
    let h = 1.0 / (n - 1) as f64;
    let pos: Vec<[f64; 3]> = (0..n * n)
        .map(|k| [(k % n) as f64 * h, (k / n) as f64 * h, 0.0])
        .collect();
    let mut faces = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = (j * n + i) as u32;
            let (b, c, d) = (a + 1, a + 1 + n as u32, a + n as u32);
            faces.push([a, b, c]);
            faces.push([a, c, d]);
        }
    }
    let topo: Arc<Topology> = Topology::new(pos.len(), faces).expect("grid topology is valid");
    Shape::new(topo, pos).expect("grid positions are finite")
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_bent_tube_keeps_its_centre_line_length_and_cross_sections() {
        let t = super::tube(10.0, 0.6, 24, 60);
        assert_eq!(t.n_vertices(), 1440);
        let b = super::bend_along_x(&t.positions, std::f64::consts::PI);
        // Ring centroids lie on a half circle of length 10; rings keep their radius.
        let centroid = |p: &[[f64; 3]], i: usize| {
            let ring = &p[i * 24..(i + 1) * 24];
            [0, 1, 2].map(|c| ring.iter().map(|v| v[c]).sum::<f64>() / 24.0)
        };
        let mut len = 0.0;
        for i in 1..60 {
            let (a, c) = (centroid(&b, i - 1), centroid(&b, i));
            len += crate::mesh::geometry::norm(crate::mesh::geometry::sub(c, a));
            let ring = &b[i * 24..(i + 1) * 24];
            for v in ring {
                let r = crate::mesh::geometry::norm(crate::mesh::geometry::sub(*v, c));
                assert!((r - 0.6).abs() < 1e-9 * 0.6 + 1e-3, "{r}");
            }
        }
        // The chord polyline of a half circle sampled at 60 rings is within 0.1 % of 10.
        assert!((len - 10.0).abs() < 0.01, "{len}");
        // The far end comes back: x of the last ring's centroid is 0, y = 2 R = 20 / pi.
        let end = centroid(&b, 59);
        assert!(end[0].abs() < 1e-9 && (end[1] - 20.0 / std::f64::consts::PI).abs() < 1e-9);
    }

    use super::*;
    use crate::mesh::geometry::{corner_angle, corner_angle_gradient};
    use std::f64::consts::PI;

    #[test]
    fn icosphere_counts_and_genus() {
        for (level, nv) in [(0, 12), (1, 42), (2, 162), (3, 642)] {
            let s = icosphere(level);
            assert_eq!(s.n_vertices(), nv);
            assert_eq!(s.topology.genus(), Some(0));
            assert!(s.topology.boundary_loops().is_empty());
            // Gauss-Bonnet: total angle defect = 2 pi chi = 4 pi.
            let k: f64 = geometry::angle_defect(&s.topology, &s.positions).iter().sum();
            assert!((k - 4.0 * PI).abs() < 1e-9, "level {level}: {k}");
            // Outward orientation: signed volume positive.
            let vol: f64 = s
                .topology
                .faces()
                .iter()
                .map(|f| {
                    let [p, q, r] = f.map(|i| s.positions[i as usize]);
                    geometry::dot(p, geometry::cross(q, r)) / 6.0
                })
                .sum();
            assert!(vol > 0.0);
        }
    }

    #[test]
    fn torus_and_grid_topology() {
        let t = torus(12, 8, 2.0, 0.5);
        assert_eq!(t.topology.genus(), Some(1));
        assert_eq!(t.topology.euler_characteristic(), 0);
        let k: f64 = geometry::angle_defect(&t.topology, &t.positions).iter().sum();
        assert!(k.abs() < 1e-9);
        let g = grid(5);
        assert_eq!(g.topology.boundary_loops().len(), 1);
        assert_eq!(g.topology.boundary_loops()[0].len(), 16);
        assert_eq!(g.topology.genus(), Some(0));
        // Flat disk: boundary rule pi - sum; Gauss-Bonnet with geodesic curvature gives 2 pi.
        let k: f64 = geometry::angle_defect(&g.topology, &g.positions).iter().sum();
        assert!((k - 2.0 * PI).abs() < 1e-9, "{k}");
        let a: f64 = geometry::vertex_areas(&g.topology, &g.positions).iter().sum();
        assert!((a - 1.0).abs() < 1e-12);
    }

    #[test]
    fn corner_angle_gradient_matches_finite_differences() {
        let p = [0.1, 0.2, -0.3];
        let q = [1.0, 0.3, 0.2];
        let r = [0.2, 1.1, 0.4];
        let g = corner_angle_gradient(p, q, r);
        let h = 1e-6;
        for (k, base) in [p, q, r].iter().enumerate() {
            for c in 0..3 {
                let mut pts = [p, q, r];
                pts[k] = *base;
                pts[k][c] += h;
                let fp = corner_angle(pts[0], pts[1], pts[2]);
                pts[k][c] -= 2.0 * h;
                let fm = corner_angle(pts[0], pts[1], pts[2]);
                let fd = (fp - fm) / (2.0 * h);
                assert!(
                    (fd - g[k][c]).abs() < 1e-7,
                    "corner {k} coord {c}: {fd} vs {}",
                    g[k][c]
                );
            }
        }
    }
}
