//! Iso-surfaces of a volume: marching tetrahedra, threshold calibration (Otsu) and the
//! clean-up that makes the result a valid closed [`Topology`].
//!
//! The paper uses marching cubes (section 4.2, ref. 48). Classic marching-cubes tables have
//! ambiguous cases that can leave cracks, so this is the marching-cubes variant on the
//! Freudenthal (Kuhn) split of each cube into six tetrahedra along its main diagonal: the
//! split is consistent across neighbouring cubes, the interpolated field is piecewise
//! linear, and its level set is therefore a closed 2-manifold with no ambiguity. Vertices lie
//! on grid edges (welded by edge), the volume is padded by one "outside" layer so every
//! component is closed, and voxels equal to the threshold count as outside.

use std::collections::HashMap;

use thiserror::Error;

use qcshape::io::nifti::{apply_affine, det3, Volume};
use qcshape::mesh::{geometry, MeshError, Topology};

/// Why no usable surface came out.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SurfaceError {
    /// No voxel lies above the threshold (or all do): the level set is empty.
    #[error("threshold {threshold} yields no surface (intensities range from {min} to {max})")]
    Empty {
        /// The threshold.
        threshold: f64,
        /// Smallest intensity.
        min: f64,
        /// Largest intensity.
        max: f64,
    },
    /// The threshold is NaN or infinite.
    #[error("threshold {0} is not finite")]
    BadThreshold(f64),
    /// The intensities are all equal (no histogram to calibrate on).
    #[error("cannot calibrate a threshold: the volume is constant ({0})")]
    Constant(f64),
    /// The surface after clean-up or decimation is not a valid closed mesh.
    #[error("the extracted surface is not a valid mesh: {0}")]
    Mesh(#[from] MeshError),
    /// The surface is not a single closed genus-0 surface after decimation (or has isolated
    /// vertices).
    #[error("the surface is not a closed sphere-like surface: {components} component(s), {loops} boundary loop(s), Euler characteristic {euler}")]
    Topology {
        /// Connected components.
        components: usize,
        /// Boundary loops.
        loops: usize,
        /// Euler characteristic.
        euler: i64,
    },
    /// The closed surface encloses no volume (it is inside out or flat).
    #[error("the surface is not a closed sphere-like surface: the surface encloses no volume")]
    NoVolume,
}

/// A triangle mesh: positions (#V x 3) and faces (#F x 3, counter-clockwise seen from outside).
#[derive(Debug, Clone, PartialEq)]
pub struct TriMesh {
    /// Vertex positions.
    pub positions: Vec<[f64; 3]>,
    /// Faces.
    pub faces: Vec<[u32; 3]>,
}

impl TriMesh {
    /// Signed enclosed volume `(1/6) sum_f p0 . (p1 x p2)` (positive when normals point out).
    pub fn signed_volume(&self) -> f64 {
        self.faces
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|i| self.positions[i as usize]);
                geometry::dot(a, geometry::cross(b, c)) / 6.0
            })
            .sum()
    }

    /// Keeps the faces of the connected component (through shared vertices) with the most
    /// faces, and drops unused vertices.
    pub fn largest_component(&self) -> TriMesh {
        let n = self.positions.len();
        let mut parent: Vec<u32> = (0..n as u32).collect();
        fn find(p: &mut [u32], mut x: u32) -> u32 {
            while p[x as usize] != x {
                p[x as usize] = p[p[x as usize] as usize];
                x = p[x as usize];
            }
            x
        }
        for f in &self.faces {
            for k in 1..3 {
                let (a, b) = (find(&mut parent, f[0]), find(&mut parent, f[k]));
                if a != b {
                    parent[a as usize] = b;
                }
            }
        }
        let mut count: HashMap<u32, usize> = HashMap::new();
        for f in &self.faces {
            *count.entry(find(&mut parent, f[0])).or_default() += 1;
        }
        let Some(best) = count
            .iter()
            .max_by_key(|(r, c)| (**c, std::cmp::Reverse(**r)))
            .map(|(r, _)| *r)
        else {
            return self.clone();
        };
        let faces: Vec<[u32; 3]> = self
            .faces
            .iter()
            .filter(|f| find(&mut parent, f[0]) == best)
            .copied()
            .collect();
        compact(&self.positions, &faces)
    }

    /// Reverses every face (flips the normals).
    pub fn flip(&mut self) {
        for f in &mut self.faces {
            f.swap(1, 2);
        }
    }

    /// Validated shared topology of the faces.
    pub fn topology(&self) -> Result<std::sync::Arc<Topology>, MeshError> {
        Topology::new(self.positions.len(), self.faces.clone())
    }
}

/// Drops vertices no face uses and renumbers the faces (order of first use is kept by id).
pub fn compact(positions: &[[f64; 3]], faces: &[[u32; 3]]) -> TriMesh {
    let mut map = vec![u32::MAX; positions.len()];
    let mut used: Vec<u32> = faces.iter().flatten().copied().collect();
    used.sort_unstable();
    used.dedup();
    let mut out = Vec::with_capacity(used.len());
    for &v in &used {
        map[v as usize] = out.len() as u32;
        out.push(positions[v as usize]);
    }
    TriMesh {
        positions: out,
        faces: faces.iter().map(|f| f.map(|v| map[v as usize])).collect(),
    }
}

/// The six tetrahedra of the Freudenthal split: corner bits (x = 1, y = 2, z = 4) along the
/// monotone paths from corner 0 to corner 7.
const TETS: [[u8; 4]; 6] = [
    [0, 1, 3, 7],
    [0, 1, 5, 7],
    [0, 2, 3, 7],
    [0, 2, 6, 7],
    [0, 4, 5, 7],
    [0, 4, 6, 7],
];

/// The surface `{ value = threshold }` enclosing the voxels brighter than `threshold`, in
/// world mm through the volume's affine, outward normals (away from the bright side). All
/// components are returned; see [`TriMesh::largest_component`].
pub fn isosurface(vol: &Volume, threshold: f64) -> Result<TriMesh, SurfaceError> {
    if !threshold.is_finite() {
        return Err(SurfaceError::BadThreshold(threshold));
    }
    let [nx, ny, nz] = vol.dims;
    let thr = threshold as f32;
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    for &v in &vol.data {
        if v.is_finite() {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    let inside_count = vol.data.iter().filter(|&&v| v > thr).count();
    if inside_count == 0 {
        return Err(SurfaceError::Empty {
            threshold,
            min: lo as f64,
            max: hi as f64,
        });
    }
    // Grid with one padding layer: indices -1 ..= n.
    let (px, py, pz) = (nx + 2, ny + 2, nz + 2);
    let value = |i: usize, j: usize, k: usize| -> f32 {
        if i == 0 || j == 0 || k == 0 || i > nx || j > ny || k > nz {
            f32::NEG_INFINITY
        } else {
            let v = vol.data[(i - 1) + nx * ((j - 1) + ny * (k - 1))];
            if v.is_nan() {
                f32::NEG_INFINITY
            } else {
                v
            }
        }
    };
    let gid = |i: usize, j: usize, k: usize| i + px * (j + py * k);
    let mut vertex_of_edge: HashMap<(usize, usize), u32> = HashMap::new();
    let mut positions: Vec<[f64; 3]> = Vec::new();
    let mut faces: Vec<[u32; 3]> = Vec::new();
    for k in 0..pz - 1 {
        for j in 0..py - 1 {
            for i in 0..px - 1 {
                let corner = |c: u8| {
                    let (a, b, d) = (
                        i + (c & 1) as usize,
                        j + ((c >> 1) & 1) as usize,
                        k + ((c >> 2) & 1) as usize,
                    );
                    (
                        gid(a, b, d),
                        [a as f64 - 1.0, b as f64 - 1.0, d as f64 - 1.0],
                        value(a, b, d),
                    )
                };
                let cs: [(usize, [f64; 3], f32); 8] = std::array::from_fn(|c| corner(c as u8));
                let any_in = cs.iter().any(|c| c.2 > thr);
                let any_out = cs.iter().any(|c| c.2 <= thr);
                if !(any_in && any_out) {
                    continue;
                }
                for tet in TETS {
                    let t = tet.map(|c| cs[c as usize]);
                    let ins: Vec<usize> = (0..4).filter(|&q| t[q].2 > thr).collect();
                    if ins.is_empty() || ins.len() == 4 {
                        continue;
                    }
                    let outs: Vec<usize> = (0..4).filter(|&q| t[q].2 <= thr).collect();
                    let mut vert = |a: usize, b: usize| -> (u32, [f64; 3]) {
                        let (pa, pb) = (t[a], t[b]);
                        let key = (pa.0.min(pb.0), pa.0.max(pb.0));
                        let (vi, vo) = (pa.2 as f64, pb.2 as f64);
                        let s = if vo.is_finite() {
                            ((vi - threshold) / (vi - vo)).clamp(1e-3, 1.0 - 1e-3)
                        } else {
                            0.5
                        };
                        let p: [f64; 3] = std::array::from_fn(|c| pa.1[c] + s * (pb.1[c] - pa.1[c]));
                        let id = *vertex_of_edge.entry(key).or_insert_with(|| {
                            positions.push(p);
                            (positions.len() - 1) as u32
                        });
                        (id, positions[id as usize])
                    };
                    let cin = centroid(ins.iter().map(|&q| t[q].1));
                    let cout = centroid(outs.iter().map(|&q| t[q].1));
                    let outward = geometry::sub(cout, cin);
                    let mut emit = |tri: [(u32, [f64; 3]); 3]| {
                        let n = geometry::cross(
                            geometry::sub(tri[1].1, tri[0].1),
                            geometry::sub(tri[2].1, tri[0].1),
                        );
                        let f = [tri[0].0, tri[1].0, tri[2].0];
                        faces.push(if geometry::dot(n, outward) >= 0.0 {
                            f
                        } else {
                            [f[0], f[2], f[1]]
                        });
                    };
                    // vert(a, b) takes the inside corner first (its value is finite).
                    if ins.len() == 1 {
                        let a = ins[0];
                        emit([vert(a, outs[0]), vert(a, outs[1]), vert(a, outs[2])]);
                    } else if ins.len() == 3 {
                        let b = outs[0];
                        emit([vert(ins[0], b), vert(ins[1], b), vert(ins[2], b)]);
                    } else {
                        let (a, b, c, d) = (ins[0], ins[1], outs[0], outs[1]);
                        // Quad a-c, a-d, b-d, b-c in cyclic order.
                        let q = [vert(a, c), vert(a, d), vert(b, d), vert(b, c)];
                        emit([q[0], q[1], q[2]]);
                        emit([q[0], q[2], q[3]]);
                    }
                }
            }
        }
    }
    let mut mesh = TriMesh {
        positions: positions.iter().map(|p| apply_affine(&vol.affine, *p)).collect(),
        faces,
    };
    if det3(&vol.affine) < 0.0 {
        mesh.flip();
    }
    Ok(mesh)
}

fn centroid(points: impl Iterator<Item = [f64; 3]>) -> [f64; 3] {
    let (mut s, mut n) = ([0.0; 3], 0.0);
    for p in points {
        s = geometry::add(s, p);
        n += 1.0;
    }
    geometry::scale(s, 1.0 / n)
}

/// Thresholds from the intensity histogram (256 bins over the finite range) by multi-level
/// Otsu: the two thresholds that maximize the between-class variance of three classes
/// (background, myocardium, contrast-filled cavity). The cavity surface uses the upper one.
/// Returns `(lower, upper)` in intensity units.
pub fn otsu_thresholds(vol: &Volume) -> Result<(f64, f64), SurfaceError> {
    const BINS: usize = 256;
    let finite = vol.data.iter().filter(|v| v.is_finite()).map(|&v| v as f64);
    let (lo, hi) = finite
        .clone()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
        return Err(SurfaceError::Constant(lo));
    }
    let width = (hi - lo) / BINS as f64;
    let mut hist = [0f64; BINS];
    for v in finite {
        hist[(((v - lo) / width) as usize).min(BINS - 1)] += 1.0;
    }
    // Prefix sums of counts and first moments (bin centres).
    let mut w = [0f64; BINS + 1];
    let mut m = [0f64; BINS + 1];
    for b in 0..BINS {
        w[b + 1] = w[b] + hist[b];
        m[b + 1] = m[b] + hist[b] * (b as f64 + 0.5);
    }
    let class = |a: usize, b: usize| {
        let n = w[b] - w[a];
        if n > 0.0 {
            let mu = (m[b] - m[a]) / n;
            n * mu * mu
        } else {
            0.0
        }
    };
    let (mut best, mut t) = (f64::NEG_INFINITY, (1, 2));
    for t1 in 1..BINS - 1 {
        for t2 in t1 + 1..BINS {
            let s = class(0, t1) + class(t1, t2) + class(t2, BINS);
            if s > best {
                best = s;
                t = (t1, t2);
            }
        }
    }
    Ok((lo + t.0 as f64 * width, lo + t.1 as f64 * width))
}
