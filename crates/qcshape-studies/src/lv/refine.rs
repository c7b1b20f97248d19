//! Image refinement of a carried mesh (section 4.2: the registration "uses the intensity
//! information" besides the landmarks).
//!
//! The landmark splines carry the frame-0 surface to every frame, so an error in a frame's
//! landmarks becomes a smooth error of that frame's whole mesh. The frame's own image says
//! where the cavity wall is: [`refine_to_image`] moves every vertex along its normal to the
//! nearest crossing of the cavity threshold in that image (trilinear intensity, searched
//! within `reach` mm on both sides) and smooths those normal offsets over the mesh, in a few
//! rounds, each from the previous round's normals; a step that would flip a triangle is
//! halved or quartered, else the rounds stop. The correspondence along the wall still comes
//! from the landmarks; only the wall's position across it comes from the image.

use super::analysis::keeps_triangles;
use qcshape::io::nifti::{apply_affine, Volume};
use qcshape::mesh::{geometry, Topology};

/// Settings of [`refine_to_image`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefineOptions {
    /// Search half-length along each vertex normal (mm); the threshold crossing nearest to
    /// the carried vertex within `[-reach, reach]` is taken.
    pub reach: f64,
    /// Jacobi sweeps of one-ring averaging of the normal offsets (each vertex with its
    /// neighbours, uniform weights), which removes the voxel-scale noise of single crossings.
    pub smoothing: usize,
    /// Rounds of search and move, each from the normals of the previous round's mesh.
    pub rounds: usize,
}

impl RefineOptions {
    /// A search of `reach` mm, two smoothing sweeps, three rounds (the settings of `lv run`).
    pub fn within(reach: f64) -> RefineOptions {
        RefineOptions {
            reach,
            smoothing: 2,
            rounds: 3,
        }
    }
}

/// What [`refine_to_image`] did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Refinement {
    /// Vertices whose normal met the threshold within the reach (in the last round searched).
    pub found: usize,
    /// Root mean square of the vertices' total moves over the rounds (mm).
    pub rms_offset: f64,
    /// Rounds applied (0: the carried positions are returned unchanged, because no crossing
    /// was found or every step would flip a triangle or shrink it below 5 % of its area).
    pub rounds: usize,
}

/// Trilinear intensity of `vol` at a world position (mm); `None` outside the voxel grid.
pub struct Sampler<'a> {
    vol: &'a Volume,
    world_to_voxel: [[f64; 4]; 4],
}

impl<'a> Sampler<'a> {
    /// A sampler of `vol`; `None` if its affine is singular.
    pub fn new(vol: &'a Volume) -> Option<Sampler<'a>> {
        Some(Sampler {
            vol,
            world_to_voxel: vol.inverse_affine()?,
        })
    }

    /// The intensity at world position `w` (mm), trilinear between voxel centres.
    pub fn at(&self, w: [f64; 3]) -> Option<f64> {
        let v = apply_affine(&self.world_to_voxel, w);
        let d = self.vol.dims;
        let mut i0 = [0usize; 3];
        let mut t = [0.0; 3];
        for a in 0..3 {
            if !(v[a] >= 0.0 && v[a] <= (d[a] - 1) as f64) {
                return None;
            }
            let f = v[a].floor().min((d[a].max(2) - 2) as f64);
            i0[a] = f as usize;
            t[a] = v[a] - f;
        }
        let mut s = 0.0;
        for corner in 0..8 {
            let (di, dj, dk) = (corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
            let (i, j, k) = (
                (i0[0] + di).min(d[0] - 1),
                (i0[1] + dj).min(d[1] - 1),
                (i0[2] + dk).min(d[2] - 1),
            );
            let w = [di, dj, dk]
                .iter()
                .zip(t)
                .map(|(&b, ta)| if b == 1 { ta } else { 1.0 - ta })
                .product::<f64>();
            s += w * f64::from(self.vol.data[self.vol.index(i, j, k)]);
        }
        Some(s)
    }
}

/// The signed distance along `n` from `p` to the nearest place where the intensity falls
/// through `threshold` going outward (bright cavity inside, darker wall outside), within
/// `reach` mm; `None` if there is none.
fn crossing(s: &Sampler<'_>, p: [f64; 3], n: [f64; 3], threshold: f64, reach: f64, step: f64) -> Option<f64> {
    let m = (reach / step).ceil() as i64;
    let g = |i: i64| {
        s.at(geometry::add(p, geometry::scale(n, i as f64 * step)))
            .map(|v| v - threshold)
    };
    let mut best: Option<f64> = None;
    let mut prev = g(-m);
    for i in (-m + 1)..=m {
        let cur = g(i);
        if let (Some(a), Some(b)) = (prev, cur) {
            if a > 0.0 && b <= 0.0 {
                let x = (i as f64 - 1.0 + a / (a - b)) * step;
                if x.abs() <= reach && best.is_none_or(|y| x.abs() < y.abs()) {
                    best = Some(x);
                }
            }
        }
        prev = cur;
    }
    best
}

/// Moves the vertices of a closed, outward-oriented cavity mesh (`pos`, #V x 3, mm, on `topo`)
/// to the cavity boundary of `vol` at `threshold`, along their normals (module docs). Vertices
/// whose normal misses the threshold within the reach take their neighbours' smoothed offset.
/// Deterministic; returns the positions and what was done.
pub fn refine_to_image(
    topo: &Topology,
    pos: &[[f64; 3]],
    vol: &Volume,
    threshold: f64,
    opts: &RefineOptions,
) -> (Vec<[f64; 3]>, Refinement) {
    let unchanged = |found| {
        (
            pos.to_vec(),
            Refinement {
                found,
                rms_offset: 0.0,
                rounds: 0,
            },
        )
    };
    let Some(sampler) = Sampler::new(vol).filter(|_| opts.reach > 0.0) else {
        return unchanged(0);
    };
    let step = vol.spacing.iter().cloned().fold(f64::INFINITY, f64::min) / 8.0;
    let mut cur = pos.to_vec();
    let mut found = 0;
    let mut rounds = 0;
    for _ in 0..opts.rounds {
        let normals = geometry::vertex_normals(topo, &cur);
        let raw: Vec<Option<f64>> = cur
            .iter()
            .zip(&normals)
            .map(|(&p, &n)| crossing(&sampler, p, n, threshold, opts.reach, step))
            .collect();
        found = raw.iter().filter(|d| d.is_some()).count();
        if found == 0 {
            break;
        }
        let d = smooth_offsets(topo, &raw, opts.smoothing);
        // The longest of a full, half or quarter step that folds no triangle.
        let next = [1.0, 0.5, 0.25].into_iter().find_map(|frac| {
            let moved: Vec<[f64; 3]> = cur
                .iter()
                .zip(&normals)
                .zip(&d)
                .map(|((&p, &n), &o)| geometry::add(p, geometry::scale(n, frac * o)))
                .collect();
            keeps_triangles(topo, pos, &moved).then_some(moved)
        });
        let Some(next) = next else { break };
        cur = next;
        rounds += 1;
    }
    if rounds == 0 {
        return unchanged(found);
    }
    let rms_offset = (cur
        .iter()
        .zip(pos)
        .map(|(&a, &b)| geometry::norm(geometry::sub(a, b)).powi(2))
        .sum::<f64>()
        / pos.len() as f64)
        .sqrt();
    (
        cur,
        Refinement {
            found,
            rms_offset,
            rounds,
        },
    )
}

/// The normal offsets `raw` (None where no crossing was found) averaged `sweeps` times over
/// each closed one-ring, with weight 1 where a crossing was found and the ring's mean weight
/// after each sweep, so gaps fill from their neighbours.
fn smooth_offsets(topo: &Topology, raw: &[Option<f64>], sweeps: usize) -> Vec<f64> {
    let mut d: Vec<f64> = raw.iter().map(|x| x.unwrap_or(0.0)).collect();
    let mut w: Vec<f64> = raw.iter().map(|x| f64::from(u8::from(x.is_some()))).collect();
    for _ in 0..sweeps {
        let (mut d2, mut w2) = (vec![0.0; d.len()], vec![0.0; d.len()]);
        for v in 0..d.len() {
            let ring = topo.neighbors(v);
            let (mut sd, mut sw) = (d[v] * w[v], w[v]);
            for &u in ring {
                sd += d[u as usize] * w[u as usize];
                sw += w[u as usize];
            }
            d2[v] = if sw > 0.0 { sd / sw } else { 0.0 };
            w2[v] = sw / (ring.len() + 1) as f64;
        }
        (d, w) = (d2, w2);
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;
    use qcshape::synth::icosphere;

    /// A 64³ grid of 1.5 mm voxels centred on the origin with x flipped (as the phantom's),
    /// filled by `f` of the world position.
    fn volume(f: impl Fn([f64; 3]) -> f64) -> Volume {
        let (n, h) = (64, 1.5);
        let half = (n as f64 - 1.0) / 2.0 * h;
        let mut v = Volume::filled([n; 3], [h; 3], [half, -half, -half], 0.0);
        v.affine[0][0] = -h;
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let w = v.to_world([i as f64, j as f64, k as f64]);
                    let idx = v.index(i, j, k);
                    v.data[idx] = f(w) as f32;
                }
            }
        }
        v
    }

    /// A bright ball of radius `r` mm (blood 400, wall 60, a smooth edge of about a voxel).
    fn ball(r: f64) -> Volume {
        volume(|w| 60.0 + 340.0 * 0.5 * (1.0 - ((geometry::norm(w) - r) / 1.0).tanh()))
    }

    #[test]
    fn sampler_is_exact_on_linear_intensities_and_none_outside() {
        let f = |w: [f64; 3]| 2.0 * w[0] + 3.0 * w[1] - w[2] + 5.0;
        let v = volume(f);
        let s = Sampler::new(&v).unwrap();
        for p in [[0.3, -7.1, 12.9], [-40.0, 33.2, -1.7], [10.0, 10.0, 10.0]] {
            let got = s.at(p).unwrap();
            assert!((got - f(p)).abs() < 1e-3, "{p:?}: {got} vs {}", f(p));
        }
        assert!(s.at([60.0, 0.0, 0.0]).is_none());
        // The sampler's inverse affine is `to_voxel`'s map.
        let inv = v.inverse_affine().unwrap();
        let p = [3.7, -21.0, 8.2];
        let (a, b) = (apply_affine(&inv, p), v.to_voxel(p).unwrap());
        assert!((0..3).all(|c| (a[c] - b[c]).abs() < 1e-12), "{a:?} vs {b:?}");
    }

    #[test]
    fn refinement_moves_a_misplaced_sphere_onto_the_ball_wall() {
        let sphere = icosphere(3);
        let topo = sphere.topology.clone();
        let (r, threshold) = (20.0, 230.0);
        // An offset, anisotropic sphere: up to about 2.5 mm off the wall.
        let off: Vec<[f64; 3]> = sphere
            .positions
            .iter()
            .map(|p| [21.5 * p[0] + 0.7, 18.8 * p[1], 20.9 * p[2]])
            .collect();
        let vol = ball(r);
        let err = |pos: &[[f64; 3]]| {
            (pos.iter().map(|&p| (geometry::norm(p) - r).powi(2)).sum::<f64>() / pos.len() as f64).sqrt()
        };
        let (refined, info) = refine_to_image(&topo, &off, &vol, threshold, &RefineOptions::within(4.0));
        let (before, after) = (err(&off), err(&refined));
        // Measured: 0.94 mm before, 0.03 mm after (three rounds).
        assert!(before > 0.8, "{before}");
        assert!(after < 0.05, "{after} mm off the wall after refinement");
        assert_eq!(info.found, topo.n_vertices());
        assert!(info.rounds > 0 && (info.rms_offset - before).abs() < 0.2 * before);
        // A reach shorter than the error finds the wall nowhere beyond it: fewer crossings.
        let (_, short) = refine_to_image(&topo, &off, &vol, threshold, &RefineOptions::within(0.3));
        assert!(short.found < topo.n_vertices() / 2, "{short:?}");
        // A threshold the image never crosses leaves the mesh as it was.
        let (same, none) = refine_to_image(&topo, &off, &vol, 1000.0, &RefineOptions::within(4.0));
        assert_eq!((none.rounds, none.found), (0, 0));
        assert_eq!(same, off);
    }
}
