//! Folding hinges between two poses: interior edges whose dihedral angle turns by more than
//! [`FOLD_TURN_DEGREES`] from one pose to the other. Between nearby frames of a smooth surface in
//! motion no hinge turns that far; thin faces of captured meshes fold over, and the bending term
//! ([`super::RelativeBending`]) charges such faces heavily (the angle's gradient grows like one
//! over the face's height): on the horse gallop's frames 1 and 3 (8,431 vertices) 83 of 25,255
//! hinges fold, the bending term carries 92 % of the default geodesic's energy and the solve runs
//! to its iteration limit (docs/log/bending.md "Folding faces on captured meshes"). The geodesic
//! warnings use this to say so.

#[cfg(doc)]
use super::bending::dihedral_angles;
use super::bending::{angle_change, hinge_value, hinges};
use crate::mesh::Topology;

/// A hinge folds when its dihedral angle turns by more than this many degrees between two poses.
/// Measured largest turns between frames (docs/log/bending.md "Folding faces on captured
/// meshes"): the cactus 2-3, the real left ventricle's endocardium 16 and epicardium 46, the
/// horse gallop up to 180.
pub const FOLD_TURN_DEGREES: f64 = 60.0;

/// The bending term's share of a geodesic's energy above which folding hinges are worth a
/// warning: 0.5 (the term then decides the distance, as the L2 regularizer does above the same
/// share).
pub const BENDING_SHARE_WARNING: f64 = 0.5;

/// The folding hinges between two poses of one topology.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Folds {
    /// Interior edges whose dihedral angle turns by more than [`FOLD_TURN_DEGREES`].
    pub folding: usize,
    /// Interior edges (hinges) of the topology.
    pub hinges: usize,
    /// The largest turn of a dihedral angle, degrees in `[0, 180]` (0 without hinges).
    pub largest_degrees: f64,
}

impl Folds {
    /// The folds from pose `a` to pose `b` (each #V x 3 on `topo`; any units: angles do not
    /// depend on scale). A turn is the change of the signed dihedral angle (as
    /// [`dihedral_angles`]) in `[-180, 180]` degrees, from the two poses' `(sin, cos)` as the
    /// bending term forms it.
    pub fn between(topo: &Topology, a: &[[f64; 3]], b: &[[f64; 3]]) -> Folds {
        let hinges = hinges(topo);
        let turns = hinges.iter().map(|(vs, _)| {
            let at = |p: &[[f64; 3]]| hinge_value(&vs.map(|v| p[v as usize])).0;
            let [sin, cos] = angle_change(at(a), at(b));
            sin.atan2(cos).abs().to_degrees()
        });
        let mut folds = Folds {
            folding: 0,
            hinges: hinges.len(),
            largest_degrees: 0.0,
        };
        for t in turns {
            if t > FOLD_TURN_DEGREES {
                folds.folding += 1;
            }
            folds.largest_degrees = folds.largest_degrees.max(t);
        }
        folds
    }

    /// The warning for a geodesic whose bending term carries `bending_share` of the energy
    /// (`Geodesic::bending_share`) between poses with these folds: `None` unless the share is
    /// above [`BENDING_SHARE_WARNING`] and some hinge folds. `off` is how the caller turns the
    /// term off (`--bending 0`, `bending=0`).
    pub fn warning(&self, bending_share: f64, off: &str) -> Option<String> {
        if !(bending_share > BENDING_SHARE_WARNING && self.folding > 0) {
            return None;
        }
        Some(format!(
            "the bending term carries {:.0} % of the energy and {} of {} hinges turn by more \
             than {FOLD_TURN_DEGREES} degrees between the ends (largest {:.0}): faces folding \
             over, as thin faces of captured meshes do, or a motion finer than the mesh; the \
             distance then mostly measures the bending of such faces, and on fine meshes the \
             solve converges slowly. {off} leaves the term out (horse gallop frames 1 and 3: \
             converged in 904 iterations, against more than 5,510 with it); a finer mesh or \
             repaired faces keep it",
            100.0 * bending_share,
            self.folding,
            self.hinges,
            self.largest_degrees
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::icosphere;

    /// A rigid motion and a stretch fold nothing; pushing one vertex of a sphere through its neighbours'
    /// plane folds the hinges around it, and only those.
    #[test]
    fn a_vertex_pushed_through_its_ring_folds_its_hinges() {
        let s = icosphere(2);
        let topo = s.topology.as_ref();
        let a = s.positions.clone();
        let (c, sn) = (0.6f64.cos(), 0.6f64.sin());
        let turned: Vec<[f64; 3]> = a
            .iter()
            .map(|p| [c * p[0] - sn * p[1] + 3.0, sn * p[0] + c * p[1], p[2] - 1.0])
            .map(|p| p.map(|v| 7.0 * v))
            .collect();
        let rigid = Folds::between(topo, &a, &turned);
        assert_eq!(rigid.folding, 0);
        assert!(rigid.largest_degrees < 1e-6, "{rigid:?}");
        assert_eq!(rigid.hinges, topo.edges().len());

        // A smooth motion of the whole surface (a stretch by 1.5 along z) folds nothing either.
        let stretched: Vec<[f64; 3]> = a.iter().map(|p| [p[0], p[1], 1.5 * p[2]]).collect();
        assert_eq!(Folds::between(topo, &a, &stretched).folding, 0);

        let mut dented = a.clone();
        dented[0] = dented[0].map(|v| 0.6 * v);
        let folds = Folds::between(topo, &a, &dented);
        // The vertex's spokes and the edges of its ring: at most 2 x 6.
        assert!(folds.folding >= 5 && folds.folding <= 12, "{folds:?}");
        assert!(folds.largest_degrees > FOLD_TURN_DEGREES, "{folds:?}");
        assert!(folds.warning(0.9, "--bending 0").is_some());
        assert!(folds.warning(0.4, "--bending 0").is_none());
        assert!(rigid.warning(0.9, "--bending 0").is_none());
    }
}
