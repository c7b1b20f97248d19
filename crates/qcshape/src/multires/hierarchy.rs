//! The mesh hierarchy: coarse levels that keep a subset of the fine vertices.

use std::sync::Arc;

use meshopt::SimplifyOptions;
use thiserror::Error;

use super::prolong::Prolongation;
use crate::mesh::{geometry, MeshError, Shape, Topology};

/// Default share of vertices kept by each coarsening step.
pub const DEFAULT_RATIO: f64 = 0.25;

/// No level is made with fewer vertices than this.
pub const MIN_VERTICES: usize = 40;

/// Errors building a [`Hierarchy`] (a coarse level that cannot be made is not an error: the
/// hierarchy stops there and says why in [`Hierarchy::stopped`]).
#[derive(Debug, Error)]
pub enum HierarchyError {
    /// The rest pose does not fit the topology or is not finite.
    #[error("rest pose: {0}")]
    Mesh(#[from] MeshError),
    /// No level asked for.
    #[error("invalid option: a hierarchy has at least one level")]
    NoLevel,
    /// The coarsening ratio is not in (0, 1).
    #[error("invalid option: ratio {0} is not in (0, 1)")]
    Ratio(f64),
}

/// One level of a [`Hierarchy`].
#[derive(Debug, Clone)]
pub struct Level {
    /// The level's connectivity (on its own vertex numbering, #Vl vertices).
    pub topology: Arc<Topology>,
    /// Rest positions (#Vl x 3): the finest rest pose at [`Level::fine_ids`].
    pub rest: Vec<[f64; 3]>,
    /// For each vertex of this level, its id in the finest level (level 0); ascending.
    pub fine_ids: Vec<u32>,
}

impl Level {
    /// Number of vertices #Vl.
    pub fn n_vertices(&self) -> usize {
        self.fine_ids.len()
    }

    /// This level's part (#Vl x 3) of a pose of the finest level (#V0 x 3).
    pub fn restrict(&self, fine: &[[f64; 3]]) -> Vec<[f64; 3]> {
        self.fine_ids.iter().map(|&i| fine[i as usize]).collect()
    }
}

/// A mesh hierarchy for spatial multiresolution (paper section 2.2.1): level 0 is the input
/// mesh, each further level keeps a subset of the previous level's vertices (edge-collapse
/// simplification with the mesh border locked, so open surfaces stay open), and
/// [`Hierarchy::prolongation`] carries values from a level to the next finer one. Built once per
/// topology and reused for every pose pair.
#[derive(Debug, Clone)]
pub struct Hierarchy {
    levels: Vec<Level>,
    prolongations: Vec<Prolongation>,
    stopped: Option<String>,
}

impl Hierarchy {
    /// Builds up to `levels` levels (level 0 included) from `topo` and its rest pose `rest`
    /// (#V x 3), each coarse level with about `ratio` times the vertices of the previous one
    /// (default [`DEFAULT_RATIO`]), stopping early when a level would have fewer than
    /// [`MIN_VERTICES`] vertices, when simplification stalls, or when a coarse mesh fails
    /// [`Topology::new`] validation, changes the surface's topology (components, boundary
    /// loops, Euler characteristic) or has a degenerate triangle at rest.
    pub fn new(
        topo: &Arc<Topology>,
        rest: &[[f64; 3]],
        levels: usize,
        ratio: f64,
    ) -> Result<Hierarchy, HierarchyError> {
        if levels == 0 {
            return Err(HierarchyError::NoLevel);
        }
        if !(ratio > 0.0 && ratio < 1.0) {
            return Err(HierarchyError::Ratio(ratio));
        }
        Shape::new(topo.clone(), rest.to_vec())?;
        let mut out = Hierarchy {
            levels: vec![Level {
                topology: topo.clone(),
                rest: rest.to_vec(),
                fine_ids: (0..topo.n_vertices() as u32).collect(),
            }],
            prolongations: Vec::new(),
            stopped: None,
        };
        while out.levels.len() < levels {
            let fine = out.levels.last().expect("level 0 exists");
            match coarsen(&fine.topology, &fine.rest, ratio) {
                Ok((topology, kept)) => {
                    let prolongation = Prolongation::new(&topology, &kept, &fine.rest);
                    let level = Level {
                        topology,
                        rest: kept.iter().map(|&i| fine.rest[i as usize]).collect(),
                        fine_ids: kept.iter().map(|&i| fine.fine_ids[i as usize]).collect(),
                    };
                    out.prolongations.push(prolongation);
                    out.levels.push(level);
                }
                Err(why) => {
                    out.stopped = Some(format!("level {} not built: {why}", out.levels.len()));
                    break;
                }
            }
        }
        Ok(out)
    }

    /// Number of levels built (at least 1).
    pub fn n_levels(&self) -> usize {
        self.levels.len()
    }
    /// The levels, finest (the input) first.
    pub fn levels(&self) -> &[Level] {
        &self.levels
    }
    /// Level `l` (0 = finest).
    pub fn level(&self, l: usize) -> &Level {
        &self.levels[l]
    }
    /// The map from level `l + 1` to level `l`.
    pub fn prolongation(&self, l: usize) -> &Prolongation {
        &self.prolongations[l]
    }
    /// Why fewer levels than requested were built, if so.
    pub fn stopped(&self) -> Option<&str> {
        self.stopped.as_deref()
    }
    /// Vertex counts per level, finest first.
    pub fn vertex_counts(&self) -> Vec<usize> {
        self.levels.iter().map(Level::n_vertices).collect()
    }
}

/// One coarsening step: the coarse topology (compact numbering) and, per coarse vertex, its id
/// in the given level. Errors say why no acceptable coarse level could be made.
fn coarsen(topo: &Topology, rest: &[[f64; 3]], ratio: f64) -> Result<(Arc<Topology>, Vec<u32>), String> {
    let isolated = topo.isolated_vertices();
    let used = topo.n_vertices() - isolated.len();
    let target = (ratio * used as f64).ceil() as usize;
    if target < MIN_VERTICES {
        return Err(format!(
            "it would have about {target} vertices (from {used}), fewer than {MIN_VERTICES}"
        ));
    }
    // Centre before converting to f32 so that far-off coordinates keep their precision.
    let (lo, hi) = geometry::bounding_box(rest);
    let centre = geometry::scale(geometry::add(lo, hi), 0.5);
    let pos32: Vec<[f32; 3]> = rest
        .iter()
        .map(|p| geometry::sub(*p, centre).map(|c| c as f32))
        .collect();
    let indices: Vec<u32> = topo.faces().as_flattened().to_vec();
    let target_faces = ((topo.n_faces() as f64) * target as f64 / used as f64).round() as usize;
    let simplified = meshopt::simplify_decoder(
        &indices,
        &pos32,
        3 * target_faces.max(1),
        1.0,
        SimplifyOptions::LockBorder,
        None,
    );
    let faces: Vec<[u32; 3]> = simplified
        .as_chunks::<3>()
        .0
        .iter()
        .copied()
        .filter(|f| f[0] != f[1] && f[1] != f[2] && f[0] != f[2])
        .collect();
    let mut keep = vec![false; topo.n_vertices()];
    for &v in faces.as_flattened() {
        keep[v as usize] = true;
    }
    let kept_used = keep.iter().filter(|&&k| k).count();
    if kept_used as f64 > 0.9 * used as f64 {
        return Err(format!(
            "simplification stalled at {kept_used} of {used} vertices (target {target})"
        ));
    }
    for &v in &isolated {
        keep[v] = true;
    }
    let kept: Vec<u32> = (0..topo.n_vertices() as u32)
        .filter(|&v| keep[v as usize])
        .collect();
    let mut new_id = vec![u32::MAX; topo.n_vertices()];
    for (c, &f) in kept.iter().enumerate() {
        new_id[f as usize] = c as u32;
    }
    let faces: Vec<[u32; 3]> = faces.iter().map(|f| f.map(|v| new_id[v as usize])).collect();
    let coarse =
        Topology::new(kept.len(), faces).map_err(|e| format!("the simplified mesh is invalid: {e}"))?;
    let same = |t: &Topology| {
        (
            t.n_components(),
            t.boundary_loops().len(),
            t.euler_characteristic(),
        )
    };
    if same(&coarse) != same(topo) {
        return Err(format!(
            "simplification changed the surface (components, boundary loops, Euler characteristic) \
             from {:?} to {:?}",
            same(topo),
            same(&coarse)
        ));
    }
    let coarse_rest: Vec<[f64; 3]> = kept.iter().map(|&i| rest[i as usize]).collect();
    let shape = Shape::new(coarse.clone(), coarse_rest).map_err(|e| e.to_string())?;
    shape
        .check_degenerate(1e-10)
        .map_err(|e| format!("the simplified mesh has a degenerate triangle at rest: {e}"))?;
    Ok((coarse, kept))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::{grid, icosphere, torus};

    #[test]
    fn sphere_levels_keep_subsets_and_the_topology() {
        let s = icosphere(3);
        let h = Hierarchy::new(&s.topology, &s.positions, 3, DEFAULT_RATIO).unwrap();
        assert_eq!(h.n_levels(), 3, "{:?}", h.stopped());
        let counts = h.vertex_counts();
        assert_eq!(counts[0], 642);
        for l in 1..3 {
            let (prev, lev) = (h.level(l - 1), h.level(l));
            assert!(counts[l] >= MIN_VERTICES && (counts[l] as f64) < 0.5 * counts[l - 1] as f64);
            assert_eq!(lev.topology.genus(), Some(0));
            assert!(lev.fine_ids.windows(2).all(|w| w[0] < w[1]));
            assert!(lev
                .fine_ids
                .iter()
                .all(|i| prev.fine_ids.binary_search(i).is_ok()));
            for (v, &f) in lev.fine_ids.iter().enumerate() {
                assert_eq!(lev.rest[v], s.positions[f as usize]);
            }
            assert_eq!(h.prolongation(l - 1).n_fine(), counts[l - 1]);
        }
        // Asking for more levels than the vertex floor allows stops with a reason.
        let h = Hierarchy::new(&s.topology, &s.positions, 6, DEFAULT_RATIO).unwrap();
        assert!(h.n_levels() < 6);
        assert!(h.stopped().unwrap().contains("fewer than"), "{:?}", h.stopped());
    }

    #[test]
    fn open_grid_keeps_its_border() {
        let g = grid(21);
        let h = Hierarchy::new(&g.topology, &g.positions, 2, DEFAULT_RATIO).unwrap();
        assert_eq!(h.n_levels(), 2, "{:?}", h.stopped());
        let coarse = h.level(1);
        assert_eq!(coarse.topology.boundary_loops().len(), 1);
        let border: Vec<u32> = g.topology.boundary_loops()[0].clone();
        for v in &border {
            assert!(
                coarse.fine_ids.binary_search(v).is_ok(),
                "border vertex {v} dropped"
            );
        }
        // The coarse border is the same loop of fine vertices.
        let coarse_border: Vec<u32> = coarse.topology.boundary_loops()[0]
            .iter()
            .map(|&c| coarse.fine_ids[c as usize])
            .collect();
        assert_eq!(coarse_border.len(), border.len());
        // Planar grid: every fine vertex lies on the coarse mesh.
        assert!(h.prolongation(0).max_distance() < 1e-12);
    }

    #[test]
    fn torus_and_bad_options() {
        let t = torus(40, 20, 2.0, 0.6);
        let h = Hierarchy::new(&t.topology, &t.positions, 2, DEFAULT_RATIO).unwrap();
        if h.n_levels() == 2 {
            assert_eq!(h.level(1).topology.genus(), Some(1));
        } else {
            assert!(h.stopped().is_some());
        }
        assert!(Hierarchy::new(&t.topology, &t.positions, 0, 0.25).is_err());
        assert!(Hierarchy::new(&t.topology, &t.positions, 2, 1.5).is_err());
        assert!(Hierarchy::new(&t.topology, &t.positions[1..], 2, 0.25).is_err());
    }
}
