//! Where one pair's similarity comes from: the per-pose, per-vertex split
//! ([`crate::contribution::pair_contributions`]) of `similarity(M, N) = sum_k dis(M_k, N_k)`
//! (eq. 13) for two named deformations of a prepared data set, as written by
//! `qcshape similarity --details D.csv --explain A,B` (docs/maps.md).
//!
//! Values are lengths in the metric's units (of the solver's coordinates, the input's multiplied
//! by [`Prepared::factor`]), like every distance qcshape reports: `pose_k` (#V) is vertex `v`'s
//! share `l_v` of `dis(M_k, N_k)` and `total` (#V) is `sum_k pose_k`, which sums over the
//! vertices to the pair's similarity.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use thiserror::Error;

use crate::contribution::{pair_contributions, ContributionError, PairContributions};
use crate::render::{render_png, RenderError, RenderOptions};
use qcshape::geodesic::{GeodesicError, GeodesicSolver};
use qcshape::io::{self, Field, IoError};
use qcshape::similarity::{PipelineOptions, Prepared};

/// Why a pair cannot be explained.
#[derive(Debug, Error)]
pub enum ExplainError {
    /// A name is not one of the data set's deformations.
    #[error("no deformation named {name:?} (the data set has {})", known.join(", "))]
    UnknownName {
        /// The name asked for.
        name: String,
        /// The data set's deformations.
        known: Vec<String>,
    },
    /// Both names are the same.
    #[error("{0:?} is named twice: give two different deformations")]
    SameName(String),
    /// The solver cannot be set up.
    #[error(transparent)]
    Solver(#[from] GeodesicError),
    /// The split failed.
    #[error(transparent)]
    Contribution(#[from] ContributionError),
    /// A file cannot be written.
    #[error(transparent)]
    Io(#[from] IoError),
    /// The picture cannot be made.
    #[error(transparent)]
    Render(#[from] RenderError),
}

/// The split of one pair.
#[derive(Debug, Clone, PartialEq)]
pub struct Explanation {
    /// First deformation's name.
    pub a: String,
    /// Second deformation's name.
    pub b: String,
    /// Its index in the data set.
    pub i: usize,
    /// The second's index.
    pub j: usize,
    /// Whether each pose is a key (input) pose (false: inserted by interpolation).
    pub is_key: Vec<bool>,
    /// The split (per pose #poses x #V, total #V, per-pose distances).
    pub contributions: PairContributions,
}

/// Splits the similarity of deformations `a` and `b` (names) of `prepared` per pose and
/// vertex with the solver settings of `opts` (the same as the similarity matrix's).
pub fn explain(
    prepared: &Prepared,
    opts: &PipelineOptions,
    a: &str,
    b: &str,
) -> Result<Explanation, ExplainError> {
    let find = |name: &str| {
        prepared
            .names
            .iter()
            .position(|n| n == name)
            .ok_or_else(|| ExplainError::UnknownName {
                name: name.to_string(),
                known: prepared.names.clone(),
            })
    };
    let (i, j) = (find(a)?, find(b)?);
    if i == j {
        return Err(ExplainError::SameName(a.to_string()));
    }
    let metric = prepared.metric(&opts.metric);
    let solver = GeodesicSolver::new(metric.as_ref(), prepared.topology.clone(), opts.geodesic.clone())?;
    let f = prepared.factor;
    let scale = |d: &[Vec<[f64; 3]>]| -> Vec<Vec<[f64; 3]>> {
        d.iter()
            .map(|p| p.iter().map(|v| v.map(|c| c * f)).collect())
            .collect()
    };
    let contributions = pair_contributions(
        &solver,
        &scale(&prepared.transferred[i]),
        &scale(&prepared.transferred[j]),
    )?;
    Ok(Explanation {
        a: a.to_string(),
        b: b.to_string(),
        i,
        j,
        is_key: prepared.is_key.clone(),
        contributions,
    })
}

impl Explanation {
    /// Field names: `total`, then `pose_000`, `pose_001`, ...
    pub fn field_names(&self) -> Vec<String> {
        std::iter::once("total".to_string())
            .chain((0..self.contributions.per_pose.len()).map(|k| format!("pose_{k:03}")))
            .collect()
    }

    /// CSV text: `vertex,total,pose_000,...` (one row per vertex, normalized length units).
    pub fn csv(&self) -> String {
        let c = &self.contributions;
        let mut s = format!("vertex,{}\n", self.field_names().join(","));
        for v in 0..c.total.len() {
            let _ = write!(s, "{v},{:e}", c.total[v]);
            for p in &c.per_pose {
                let _ = write!(s, ",{:e}", p[v]);
            }
            s.push('\n');
        }
        s
    }

    /// Writes `STEM.csv`, `STEM.vtk` and `STEM.ply` (point data `total`, `pose_000`, ...; the
    /// PLY's quality is `total`) and `STEM.png` (the total on the mesh) on the base mesh
    /// `positions` (#V x 3) / `faces` (#F x 3); `metric` names the metric in the picture's
    /// title. Returns the paths written.
    pub fn write(
        &self,
        stem: &Path,
        positions: &[[f64; 3]],
        faces: &[[u32; 3]],
        metric: &str,
    ) -> Result<Vec<PathBuf>, ExplainError> {
        let with = |ext: &str| {
            let mut s = stem.as_os_str().to_owned();
            s.push(format!(".{ext}"));
            PathBuf::from(s)
        };
        let csv = self.csv();
        let mut out = vec![with("csv")];
        io::write_atomically(&out[0], |w| w.write_all(csv.as_bytes()))?;
        let names = self.field_names();
        let c = &self.contributions;
        let fields: Vec<Field> = std::iter::once(&c.total)
            .chain(&c.per_pose)
            .zip(&names)
            .map(|(v, n)| Field::scalar(n, v))
            .collect();
        for ext in ["vtk", "ply"] {
            let p = with(ext);
            io::write_mesh_fields(&p, positions, faces, &fields)?;
            out.push(p);
        }
        let top = c
            .pose_distances
            .iter()
            .enumerate()
            .max_by(|x, y| x.1.total_cmp(y.1))
            .map_or(0, |(k, _)| k);
        let opts = RenderOptions {
            title: format!(
                "{} vs {}: similarity {:.4} ({metric}); largest pose {top}: {:.4}",
                self.a,
                self.b,
                c.distance,
                c.pose_distances.get(top).copied().unwrap_or(0.0)
            ),
            label: "total: each vertex's share of sum_k dis(M_k, N_k) (mean-edge units)".into(),
            ..Default::default()
        };
        let p = with("png");
        render_png(&p, positions, faces, &c.total, &opts)?;
        out.push(p);
        Ok(out)
    }
}

/// The file stem `--explain A,B` writes beside the `--details` file `details`:
/// `DETAILS_STEM.explain_A_vs_B` (characters other than letters, digits, `-`, `_` become `_`).
pub fn stem_beside(details: &Path, a: &str, b: &str) -> PathBuf {
    let clean = |s: &str| -> String {
        s.chars()
            .map(|c| {
                if c.is_alphanumeric() || matches!(c, '-' | '_') {
                    c
                } else {
                    '_'
                }
            })
            .collect()
    };
    let base = details
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    details.with_file_name(format!("{base}.explain_{}_vs_{}", clean(a), clean(b)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stem_is_beside_the_details_file() {
        assert_eq!(
            stem_beside(Path::new("out/d.csv"), "a b", "c/d"),
            PathBuf::from("out/d.explain_a_b_vs_c_d")
        );
    }
}
