//! The synthetic benchmark of the paper (section 3, Fig. 3): every initial shape deformed by
//! every deformation, as labelled [`Deformation`]s, and a writer for the manifest layout of
//! [`crate::dataset`].
//!
//! Genus 0: 6 [`InitialShape`]s x 8 [`DeformationKind`]s = 48 deformations. Genus 1: 3
//! [`TorusShape`]s x 8 = 24. Pose `k` of `P` is the deformation at time `t = k / (P - 1)`, so
//! pose 0 is the initial shape itself. With `jitter > 0` each deformation instance gets its own
//! amplitude `1 + jitter * u`, `u` uniform in `[-1, 1]`, drawn from the seed in the set's fixed
//! order, so that the members of a class are not identical motions.

use std::path::{Component, Path, PathBuf};
use std::sync::Arc;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use thiserror::Error;

use super::deformations::{deform, DeformParams, DeformationKind};
use super::shapes::{
    initial_shape, template, torus_shape, torus_template, InitialShape, TorusShape, MAX_LEVEL,
};
use crate::dataset::{write_manifest, DatasetError, Deformation, ManifestRow, MANIFEST_NAME};
use crate::io::{self, Format, IoError, VertexAttributes, WriteOptions, DEGENERATE_REL_TOL};
use crate::mesh::{MeshError, Shape};

/// Largest accepted jitter: amplitudes then stay in `[0.5, 1.5]`, where every motion is valid.
pub const MAX_JITTER: f64 = 0.5;
/// Largest accepted number of poses per deformation.
pub const MAX_POSES: usize = 1000;

/// Options of the benchmark generator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SynthOptions {
    /// Template resolution: icosphere level (`10 * 4^level + 2` vertices; 3 gives 642) and
    /// torus `6 * 2^level x 3 * 2^level`. At most [`MAX_LEVEL`].
    pub level: u32,
    /// Seed of the amplitude jitter.
    pub seed: u64,
    /// Poses per deformation (at least 2); pose `k` is at time `k / (poses - 1)`.
    pub poses: usize,
    /// Relative amplitude variation per deformation instance, in `[0, MAX_JITTER]`; 0 makes
    /// every instance the nominal motion.
    pub jitter: f64,
}

impl Default for SynthOptions {
    fn default() -> Self {
        SynthOptions {
            level: 3,
            seed: 0,
            poses: 3,
            jitter: 0.1,
        }
    }
}

/// Why a benchmark cannot be generated or written.
#[derive(Debug, Error)]
pub enum SynthError {
    /// The template level is too fine.
    #[error("level {0} is out of range: the templates accept levels 0 to {MAX_LEVEL}")]
    Level(u32),
    /// Fewer than 2 or more than [`MAX_POSES`] poses.
    #[error("poses must be between 2 and {MAX_POSES} (got {0}): pose k is at time k / (poses - 1)")]
    Poses(usize),
    /// Jitter outside `[0, MAX_JITTER]` (or not a number).
    #[error("jitter must be between 0 and {MAX_JITTER} (got {0})")]
    Jitter(f64),
    /// A generated pose is degenerate (cannot happen within the accepted options).
    #[error("deformation {name}: pose {pose}: {error}")]
    Degenerate {
        /// The deformation.
        name: String,
        /// The pose number.
        pose: usize,
        /// The problem.
        error: MeshError,
    },
    /// The format cannot hold the benchmark exactly (STL is unindexed single precision).
    #[error("the {0} format cannot store the benchmark (it is unindexed, single precision); use ply, obj, off or vtk")]
    Format(Format),
    /// A deformation name that is not a plain folder name.
    #[error(
        "deformation name {0:?} cannot be a folder name (empty, '.', '..' or containing a path separator)"
    )]
    Name(String),
    /// Nothing to write.
    #[error("no deformations to write")]
    Empty,
    /// A folder cannot be created.
    #[error("{}: cannot create the folder: {error}", path.display())]
    CreateDir {
        /// The folder.
        path: PathBuf,
        /// The system error.
        error: std::io::Error,
    },
    /// A mesh file cannot be written.
    #[error(transparent)]
    Io(#[from] IoError),
    /// The manifest cannot be written.
    #[error(transparent)]
    Dataset(#[from] DatasetError),
}

impl SynthOptions {
    /// Errors on an out-of-range level, pose count or jitter.
    pub fn validate(&self) -> Result<(), SynthError> {
        if self.level > MAX_LEVEL {
            return Err(SynthError::Level(self.level));
        }
        if !(2..=MAX_POSES).contains(&self.poses) {
            return Err(SynthError::Poses(self.poses));
        }
        if !(0.0..=MAX_JITTER).contains(&self.jitter) {
            return Err(SynthError::Jitter(self.jitter));
        }
        Ok(())
    }
}

/// One deformation instance: `kind` applied to `initial` with amplitude `amplitude`, sampled
/// at `poses` times `k / (poses - 1)`. Every pose is checked for degenerate faces.
fn instance(
    name: String,
    initial: &Shape,
    kind: DeformationKind,
    amplitude: f64,
    poses: usize,
) -> Result<Deformation, SynthError> {
    let params = DeformParams::of(initial).with_amplitude(amplitude);
    let mut out = Vec::with_capacity(poses);
    for k in 0..poses {
        let t = k as f64 / (poses - 1) as f64;
        let pos = if k == 0 {
            initial.positions.clone()
        } else {
            deform(initial, kind, t, &params)
        };
        let shape =
            Shape::new_checked(Arc::clone(&initial.topology), pos, DEGENERATE_REL_TOL).map_err(|error| {
                SynthError::Degenerate {
                    name: name.clone(),
                    pose: k,
                    error,
                }
            })?;
        out.push(shape.positions);
    }
    Ok(Deformation {
        name,
        label: Some(kind.name().to_string()),
        topology: Arc::clone(&initial.topology),
        poses: out,
        paths: Vec::new(),
        warnings: Vec::new(),
    })
}

/// Every (initial shape, deformation) pair, grouped by deformation in
/// [`DeformationKind::all`] order, with jittered amplitudes from `stream` of the seed.
fn build(shapes: &[(&str, Shape)], opts: &SynthOptions, stream: u64) -> Result<Vec<Deformation>, SynthError> {
    opts.validate()?;
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    rng.set_stream(stream);
    let mut out = Vec::with_capacity(shapes.len() * DeformationKind::all().len());
    for kind in DeformationKind::all() {
        for (shape_name, initial) in shapes {
            let u: f64 = rng.random_range(-1.0..=1.0);
            let amplitude = 1.0 + opts.jitter * u;
            out.push(instance(
                format!("{shape_name}-{}", kind.name()),
                initial,
                kind,
                amplitude,
                opts.poses,
            )?);
        }
    }
    Ok(out)
}

/// The genus-0 benchmark (Fig. 3): 48 deformations named `"{shape}-{deformation}"` (e.g.
/// `"pear-twist"`), labelled with the deformation's name, grouped by deformation in
/// [`DeformationKind::all`] order (shapes in [`InitialShape::all`] order within a group), each
/// with `opts.poses` poses (#V x 3, #V = `10 * 4^level + 2`) on one shared topology. `paths`
/// are empty.
pub fn genus0_benchmark(opts: &SynthOptions) -> Result<Vec<Deformation>, SynthError> {
    opts.validate()?;
    let t = template(opts.level);
    let shapes: Vec<(&str, Shape)> = InitialShape::all()
        .iter()
        .map(|k| (k.name(), initial_shape(*k, &t)))
        .collect();
    build(&shapes, opts, 0)
}

/// The genus-1 benchmark: the eight deformations on the three [`TorusShape`]s (24
/// deformations named `"{torus}-{deformation}"`, e.g. `"torus-thin-bend"`), in the same order
/// and layout as [`genus0_benchmark`], on [`torus_template`]`(level)`. The jitter uses its own
/// random stream of the seed.
pub fn genus1_benchmark(opts: &SynthOptions) -> Result<Vec<Deformation>, SynthError> {
    opts.validate()?;
    let t = torus_template(opts.level);
    let shapes: Vec<(&str, Shape)> = TorusShape::all()
        .iter()
        .map(|k| (k.name(), torus_shape(*k, &t)))
        .collect();
    build(&shapes, opts, 1)
}

fn create_dir(path: &Path) -> Result<(), SynthError> {
    std::fs::create_dir_all(path).map_err(|error| SynthError::CreateDir {
        path: path.into(),
        error,
    })
}

/// Writes `defs` under `dir`: pose `k` of deformation `d` to `dir/<d.name>/pose<k>.<ext>`
/// (atomically), and `dir/manifest.csv` (`deformation,label,pose,path`, paths relative to
/// `dir`), which [`crate::dataset::Dataset::load`] reads back. PLY, OBJ, OFF and VTK store the
/// coordinates exactly; STL is refused. Returns the manifest's path.
pub fn write_benchmark(dir: &Path, defs: &[Deformation], format: Format) -> Result<PathBuf, SynthError> {
    if format == Format::Stl {
        return Err(SynthError::Format(format));
    }
    if defs.is_empty() {
        return Err(SynthError::Empty);
    }
    for d in defs {
        let mut parts = Path::new(&d.name).components();
        let plain = matches!(parts.next(), Some(Component::Normal(_))) && parts.next().is_none();
        if !plain || d.name.contains(['/', '\\']) {
            return Err(SynthError::Name(d.name.clone()));
        }
    }
    create_dir(dir)?;
    let mut rows = Vec::new();
    for d in defs {
        create_dir(&dir.join(&d.name))?;
        for (k, pose) in d.poses.iter().enumerate() {
            let rel = PathBuf::from(&d.name).join(format!("pose{k:03}.{}", format.extension()));
            io::write_mesh_with(
                &dir.join(&rel),
                format,
                pose,
                d.topology.faces(),
                &VertexAttributes::default(),
                &WriteOptions::default(),
            )?;
            rows.push(ManifestRow {
                deformation: d.name.clone(),
                label: d.label.clone(),
                pose: k as i64,
                path: rel,
            });
        }
    }
    let manifest = dir.join(MANIFEST_NAME);
    write_manifest(&manifest, &rows)?;
    Ok(manifest)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dataset::Dataset;

    fn small(seed: u64, jitter: f64) -> SynthOptions {
        SynthOptions {
            level: 1,
            seed,
            poses: 3,
            jitter,
        }
    }

    #[test]
    fn forty_eight_labelled_deformations_on_one_topology() {
        let defs = genus0_benchmark(&SynthOptions {
            level: 2,
            ..Default::default()
        })
        .unwrap();
        assert_eq!(defs.len(), 48);
        let kinds = DeformationKind::all();
        for (i, d) in defs.iter().enumerate() {
            let (kind, shape) = (kinds[i / 6], InitialShape::all()[i % 6]);
            assert_eq!(d.name, format!("{}-{}", shape.name(), kind.name()));
            assert_eq!(d.label.as_deref(), Some(kind.name()));
            assert!(Arc::ptr_eq(&d.topology, &defs[0].topology));
            assert_eq!(d.n_poses(), 3);
            assert_eq!(d.poses[0].len(), 162);
            assert!(d.paths.is_empty());
            // Pose 0 is the initial shape.
            let initial = initial_shape(shape, &template(2));
            assert_eq!(d.poses[0], initial.positions);
            assert_ne!(d.poses[1], d.poses[0]);
            assert_ne!(d.poses[2], d.poses[1]);
        }
        for kind in kinds {
            let n = defs
                .iter()
                .filter(|d| d.label.as_deref() == Some(kind.name()))
                .count();
            assert_eq!(n, 6, "{kind}");
        }
    }

    #[test]
    fn poses_follow_the_time_grid_and_jitter_only_scales_the_amplitude() {
        let opts = SynthOptions {
            poses: 5,
            jitter: 0.0,
            ..small(0, 0.0)
        };
        let defs = genus0_benchmark(&opts).unwrap();
        let d = &defs[7]; // bend on the ellipsoid
        assert_eq!(d.name, "ellipsoid-bend");
        let s = initial_shape(InitialShape::Ellipsoid, &template(1));
        for (k, pose) in d.poses.iter().enumerate() {
            let want = deform(&s, DeformationKind::Bend, k as f64 / 4.0, &DeformParams::of(&s));
            assert_eq!(pose, &want, "pose {k}");
        }
        // With jitter, each instance is the nominal motion at a scaled amplitude in
        // [1 - jitter, 1 + jitter]: the stretch moves the top vertex by 0.4 * amplitude * h_z.
        let jit = genus0_benchmark(&small(7, 0.3)).unwrap();
        let mut amps = Vec::new();
        for d in jit.iter().filter(|d| d.label.as_deref() == Some("stretch")) {
            let top = (0..d.poses[0].len())
                .max_by(|&a, &b| d.poses[0][a][2].total_cmp(&d.poses[0][b][2]))
                .unwrap();
            let h = DeformParams::of(&Shape {
                topology: d.topology.clone(),
                positions: d.poses[0].clone(),
            })
            .frame
            .half[2];
            let dz = d.poses[2][top][2] - d.poses[0][top][2];
            amps.push(dz / (0.4 * h));
        }
        assert_eq!(amps.len(), 6);
        assert!(
            amps.iter().all(|a| (0.7 - 1e-9..=1.3 + 1e-9).contains(a)),
            "{amps:?}"
        );
        assert!(amps.iter().any(|a| (a - 1.0).abs() > 0.01), "{amps:?}");
    }

    #[test]
    fn deterministic_per_seed() {
        let a = genus0_benchmark(&small(3, 0.1)).unwrap();
        let b = genus0_benchmark(&small(3, 0.1)).unwrap();
        let c = genus0_benchmark(&small(4, 0.1)).unwrap();
        let exact = genus0_benchmark(&small(3, 0.0)).unwrap();
        let exact2 = genus0_benchmark(&small(4, 0.0)).unwrap();
        for i in 0..a.len() {
            assert_eq!(a[i].poses, b[i].poses);
            assert_ne!(a[i].poses[2], c[i].poses[2], "{}", a[i].name);
            assert_eq!(exact[i].poses, exact2[i].poses);
        }
    }

    #[test]
    fn genus_one_set() {
        let defs = genus1_benchmark(&small(0, 0.1)).unwrap();
        assert_eq!(defs.len(), 24);
        assert_eq!(defs[0].name, "torus-round-twist");
        assert_eq!(defs[23].name, "torus-elliptic-ripple");
        assert_eq!(defs[0].topology.genus(), Some(1));
        assert!(defs.iter().all(|d| Arc::ptr_eq(&d.topology, &defs[0].topology)));
        assert_eq!(defs[0].poses[0].len(), 72);
    }

    #[test]
    fn bad_options_are_errors() {
        let cases = [
            (
                SynthOptions {
                    level: 9,
                    ..Default::default()
                },
                "level 9 is out of range",
            ),
            (
                SynthOptions {
                    poses: 1,
                    ..Default::default()
                },
                "poses must be between 2",
            ),
            (
                SynthOptions {
                    jitter: 0.8,
                    ..Default::default()
                },
                "jitter must be between 0 and 0.5",
            ),
            (
                SynthOptions {
                    jitter: f64::NAN,
                    ..Default::default()
                },
                "jitter",
            ),
        ];
        for (opts, want) in cases {
            let e = genus0_benchmark(&opts).unwrap_err().to_string();
            assert!(e.contains(want), "{e}");
            assert!(genus1_benchmark(&opts).is_err());
        }
    }

    #[test]
    fn write_and_load_back() {
        let dir = tempfile::tempdir().unwrap();
        let defs = genus0_benchmark(&small(1, 0.1)).unwrap();
        for format in [Format::Ply, Format::Obj, Format::Off, Format::Vtk] {
            let out = dir.path().join(format.extension());
            let manifest = write_benchmark(&out, &defs, format).unwrap();
            assert_eq!(manifest, out.join("manifest.csv"));
            let text = std::fs::read_to_string(&manifest).unwrap();
            let ext = format.extension();
            assert!(
                text.starts_with(&format!(
                    "deformation,label,pose,path\nsphere-twist,twist,0,sphere-twist/pose000.{ext}\n"
                )),
                "{text}"
            );
            assert_eq!(text.lines().count(), 1 + 48 * 3);
            let ds = Dataset::load(&out).unwrap();
            assert_eq!(ds.deformations.len(), 48);
            assert!(ds.shares_topology());
            for (got, want) in ds.deformations.iter().zip(&defs) {
                assert_eq!(got.name, want.name);
                assert_eq!(got.label, want.label);
                assert_eq!(got.topology.faces(), want.topology.faces());
                // These formats print shortest round-trip decimals or doubles: exact.
                assert_eq!(got.poses, want.poses, "{format}: {}", want.name);
            }
        }
        let e = write_benchmark(dir.path(), &defs, Format::Stl)
            .unwrap_err()
            .to_string();
        assert!(e.contains("STL format cannot store"), "{e}");
        let mut bad = defs[0].clone();
        bad.name = "../x".into();
        let e = write_benchmark(dir.path(), &[bad], Format::Ply)
            .unwrap_err()
            .to_string();
        assert!(e.contains("cannot be a folder name"), "{e}");
        assert!(matches!(
            write_benchmark(dir.path(), &[], Format::Ply),
            Err(SynthError::Empty)
        ));
    }

    #[test]
    fn same_seed_same_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let write = |name: &str, seed: u64| {
            let defs = genus0_benchmark(&small(seed, 0.1)).unwrap();
            write_benchmark(&dir.path().join(name), &defs[..8], Format::Ply).unwrap();
            let mut bytes = Vec::new();
            for d in &defs[..8] {
                for k in 0..3 {
                    bytes.extend(
                        std::fs::read(
                            dir.path()
                                .join(name)
                                .join(&d.name)
                                .join(format!("pose{k:03}.ply")),
                        )
                        .unwrap(),
                    );
                }
            }
            bytes.extend(std::fs::read(dir.path().join(name).join("manifest.csv")).unwrap());
            bytes
        };
        let (a, b, c) = (write("a", 5), write("b", 5), write("c", 6));
        assert_eq!(a, b);
        assert_ne!(a, c);
    }
}
