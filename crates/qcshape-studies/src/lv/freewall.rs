//! The left-ventricle free wall as an open submesh (section 4.3: "we only consider the faces
//! of the mesh which belong to the LV free wall").
//!
//! The long axis runs from the apex landmark to the base-centre landmark; angles are measured
//! about it (right-handed, apex to base) from the direction of the septum landmark. A face
//! belongs to the free wall when its centroid lies in the angular sector and in the height
//! band (normalized height 0 at the apex, 1 at the base centre). The selection is then made a
//! topological disk: holes are filled, the largest piece kept, and faces touching the rest
//! only at a vertex dropped, so the submesh has one boundary loop.

use std::sync::Arc;

use thiserror::Error;

use qcshape::mesh::{geometry, MeshError, Topology};

/// Marks a boundary side in `Topology::edge_faces`.
const NO_FACE: u32 = u32::MAX;

/// Why no free-wall submesh can be made.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum FreeWallError {
    /// Apex and base centre coincide (or are not finite).
    #[error("cannot define the long axis: apex and base centre coincide")]
    ApexAtBase,
    /// The septum landmark lies on the long axis.
    #[error("cannot define the long axis: the septum landmark lies on the long axis")]
    SeptumOnAxis,
    /// A sector or band option is out of range.
    #[error("bad free-wall option: width {width} must be in (0, 360], centre {centre} finite, heights {lo} < {hi}")]
    Options {
        /// Sector width (degrees).
        width: f64,
        /// Sector centre (degrees).
        centre: f64,
        /// Lowest normalized height.
        lo: f64,
        /// Highest normalized height.
        hi: f64,
    },
    /// No face lies in the sector.
    #[error(
        "no face lies in the free-wall sector (centre {centre} deg, width {width} deg, heights {lo}..{hi})"
    )]
    Empty {
        /// Sector centre (degrees).
        centre: f64,
        /// Sector width (degrees).
        width: f64,
        /// Lowest normalized height.
        lo: f64,
        /// Highest normalized height.
        hi: f64,
    },
    /// The submesh is not a disk (one component, one boundary loop, Euler characteristic 1).
    #[error("the free-wall submesh is not a disk: {components} component(s), {loops} boundary loop(s), Euler characteristic {euler}")]
    NotDisk {
        /// Connected components.
        components: usize,
        /// Boundary loops.
        loops: usize,
        /// Euler characteristic.
        euler: i64,
    },
    /// The submesh's faces do not form a valid topology.
    #[error(transparent)]
    Mesh(#[from] MeshError),
}

/// The long axis with an angular reference: cylindrical coordinates around it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LvAxis {
    /// Apex (mm).
    pub apex: [f64; 3],
    /// Unit vector from apex to base centre.
    pub axis: [f64; 3],
    /// Apex-to-base-centre length (mm).
    pub length: f64,
    /// Unit reference direction (towards the septum), perpendicular to `axis`.
    pub reference: [f64; 3],
}

impl LvAxis {
    /// The axis from the apex, base-centre and septum points (mm).
    pub fn new(apex: [f64; 3], base_centre: [f64; 3], septum: [f64; 3]) -> Result<LvAxis, FreeWallError> {
        let d = geometry::sub(base_centre, apex);
        let length = geometry::norm(d);
        if length.partial_cmp(&1e-9) != Some(std::cmp::Ordering::Greater) || !length.is_finite() {
            return Err(FreeWallError::ApexAtBase);
        }
        let axis = geometry::scale(d, 1.0 / length);
        let s = geometry::sub(septum, apex);
        let r = geometry::sub(s, geometry::scale(axis, geometry::dot(s, axis)));
        let rn = geometry::norm(r);
        if rn.partial_cmp(&(1e-9 * length)) != Some(std::cmp::Ordering::Greater) {
            return Err(FreeWallError::SeptumOnAxis);
        }
        Ok(LvAxis {
            apex,
            axis,
            length,
            reference: geometry::scale(r, 1.0 / rn),
        })
    }

    /// `(height, angle_deg, radius)`: normalized height along the axis (0 apex, 1 base
    /// centre), angle about the axis from the reference in (-180, 180], distance to the axis.
    pub fn cylindrical(&self, p: [f64; 3]) -> (f64, f64, f64) {
        let q = geometry::sub(p, self.apex);
        let h = geometry::dot(q, self.axis);
        let r = geometry::sub(q, geometry::scale(self.axis, h));
        let second = geometry::cross(self.axis, self.reference);
        let ang = geometry::dot(r, second).atan2(geometry::dot(r, self.reference));
        (h / self.length, ang.to_degrees(), geometry::norm(r))
    }
}

/// The free-wall sector and height band.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SectorOptions {
    /// Sector centre, degrees from the septum direction (default 180: the lateral wall).
    pub centre_deg: f64,
    /// Sector width in degrees, in (0, 360] (default 180).
    pub width_deg: f64,
    /// Normalized height band `[lo, hi]` (default 0.15 .. 0.9: no apical cap, no valve plane).
    pub heights: (f64, f64),
}

impl Default for SectorOptions {
    fn default() -> Self {
        SectorOptions {
            centre_deg: 180.0,
            width_deg: 180.0,
            heights: (0.15, 0.9),
        }
    }
}

impl SectorOptions {
    /// The whole myocardial wall: every angle, from the apex up to the normalized height 0.9,
    /// so without the valve-plane cap that closes the cavity surface (not myocardium). A disk
    /// like the free wall.
    pub fn wall() -> Self {
        SectorOptions {
            centre_deg: 180.0,
            width_deg: 360.0,
            heights: (-1.0, 0.9),
        }
    }
}

/// An open submesh: selected faces renumbered onto their vertices.
#[derive(Debug, Clone)]
pub struct Submesh {
    /// Connectivity on the compacted vertices (one boundary loop).
    pub topology: Arc<Topology>,
    /// `vertices[k]` is the whole mesh's vertex that became vertex `k` (#V_sub).
    pub vertices: Vec<u32>,
    /// Indices of the whole mesh's faces kept (#F_sub, same order as `topology.faces()`).
    pub faces: Vec<usize>,
}

impl Submesh {
    /// The submesh's positions (#V_sub x 3) taken from a whole-mesh pose (#V x 3).
    pub fn restrict(&self, positions: &[[f64; 3]]) -> Vec<[f64; 3]> {
        self.vertices.iter().map(|&v| positions[v as usize]).collect()
    }
}

/// Components of the faces with `sel[f] == want`, joined across edges; returns a component id
/// per face (`usize::MAX` for faces not in the class) and the component sizes.
fn components(topo: &Topology, sel: &[bool], want: bool) -> (Vec<usize>, Vec<usize>) {
    let mut comp = vec![usize::MAX; sel.len()];
    let mut sizes = Vec::new();
    for start in 0..sel.len() {
        if sel[start] != want || comp[start] != usize::MAX {
            continue;
        }
        let id = sizes.len();
        let mut stack = vec![start];
        comp[start] = id;
        let mut n = 0;
        while let Some(f) = stack.pop() {
            n += 1;
            for &e in &topo.face_edges()[f] {
                for &g in &topo.edge_faces()[e as usize] {
                    if g != NO_FACE && sel[g as usize] == want && comp[g as usize] == usize::MAX {
                        comp[g as usize] = id;
                        stack.push(g as usize);
                    }
                }
            }
        }
        sizes.push(n);
    }
    (comp, sizes)
}

/// Makes `sel` a disk-like selection: fill holes, keep the largest piece, drop bow-ties.
fn clean(topo: &Topology, sel: &mut [bool]) {
    for _ in 0..20 {
        let before = sel.to_vec();
        let (comp, sizes) = components(topo, sel, false);
        if let Some(big) = (0..sizes.len()).max_by_key(|&c| sizes[c]) {
            for f in 0..sel.len() {
                if !sel[f] && comp[f] != big {
                    sel[f] = true;
                }
            }
        }
        let (comp, sizes) = components(topo, sel, true);
        if let Some(big) = (0..sizes.len()).max_by_key(|&c| sizes[c]) {
            for f in 0..sel.len() {
                if sel[f] && comp[f] != big {
                    sel[f] = false;
                }
            }
        }
        // Bow-ties: a vertex whose selected faces form several fans keeps the largest fan.
        for v in 0..topo.n_vertices() {
            let fans: Vec<usize> = topo
                .vertex_faces(v)
                .iter()
                .map(|&(f, _)| f as usize)
                .filter(|&f| sel[f])
                .collect();
            if fans.len() < 2 {
                continue;
            }
            let mut group: Vec<usize> = (0..fans.len()).collect();
            loop {
                let mut changed = false;
                for a in 0..fans.len() {
                    for b in 0..fans.len() {
                        if group[a] != group[b] && shares_edge_at(topo, fans[a], fans[b], v) {
                            let g = group[a].min(group[b]);
                            let (ga, gb) = (group[a], group[b]);
                            for x in group.iter_mut() {
                                if *x == ga || *x == gb {
                                    *x = g;
                                }
                            }
                            changed = true;
                        }
                    }
                }
                if !changed {
                    break;
                }
            }
            let mut count = vec![0usize; fans.len()];
            for &g in &group {
                count[g] += 1;
            }
            if count.iter().filter(|&&c| c > 0).count() > 1 {
                let keep = (0..fans.len()).max_by_key(|&g| count[g]).unwrap_or(0);
                for (k, &f) in fans.iter().enumerate() {
                    if group[k] != keep {
                        sel[f] = false;
                    }
                }
            }
        }
        if before == sel {
            break;
        }
    }
}

fn shares_edge_at(topo: &Topology, f: usize, g: usize, v: usize) -> bool {
    let (a, b) = (topo.faces()[f], topo.faces()[g]);
    a.iter().filter(|&&x| x as usize != v && b.contains(&x)).count() >= 1
}

/// Selects the free wall of a closed LV surface (topology `topo`, frame-0 positions #V x 3,
/// world mm) and returns it as an open submesh with one boundary loop.
pub fn free_wall(
    topo: &Topology,
    positions: &[[f64; 3]],
    axis: &LvAxis,
    opts: &SectorOptions,
) -> Result<Submesh, FreeWallError> {
    let (lo, hi) = opts.heights;
    let valid = opts.width_deg > 0.0 && opts.width_deg <= 360.0 && opts.centre_deg.is_finite() && lo < hi;
    if !valid {
        return Err(FreeWallError::Options {
            width: opts.width_deg,
            centre: opts.centre_deg,
            lo,
            hi,
        });
    }
    let mut sel: Vec<bool> = topo
        .faces()
        .iter()
        .map(|f| {
            let c = geometry::scale(
                geometry::add(
                    geometry::add(positions[f[0] as usize], positions[f[1] as usize]),
                    positions[f[2] as usize],
                ),
                1.0 / 3.0,
            );
            let (h, ang, _) = axis.cylindrical(c);
            let d = (ang - opts.centre_deg + 540.0).rem_euclid(360.0) - 180.0;
            h >= lo && h <= hi && d.abs() <= opts.width_deg / 2.0
        })
        .collect();
    if !sel.iter().any(|&s| s) {
        return Err(FreeWallError::Empty {
            centre: opts.centre_deg,
            width: opts.width_deg,
            lo,
            hi,
        });
    }
    clean(topo, &mut sel);
    let faces: Vec<usize> = (0..sel.len()).filter(|&f| sel[f]).collect();
    let mut map = vec![u32::MAX; topo.n_vertices()];
    let mut vertices = Vec::new();
    let mut sub_faces = Vec::with_capacity(faces.len());
    for &f in &faces {
        sub_faces.push(topo.faces()[f].map(|v| {
            if map[v as usize] == u32::MAX {
                map[v as usize] = vertices.len() as u32;
                vertices.push(v);
            }
            map[v as usize]
        }));
    }
    let sub = Topology::new(vertices.len(), sub_faces)?;
    let loops = sub.boundary_loops().len();
    if sub.n_components() != 1 || loops != 1 || sub.euler_characteristic() != 1 {
        return Err(FreeWallError::NotDisk {
            components: sub.n_components(),
            loops,
            euler: sub.euler_characteristic(),
        });
    }
    Ok(Submesh {
        topology: sub,
        vertices,
        faces,
    })
}
