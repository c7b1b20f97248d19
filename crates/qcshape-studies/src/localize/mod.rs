//! Where two groups of deformations differ: per-vertex contrasts of the similarity split
//! ([`crate::contribution`]) between labelled groups, with permutation p-values and a
//! Benjamini-Hochberg false discovery rate (docs/maps.md).
//!
//! For every pair `i < j` of deformations (transferred to one base, eq. 13), `s_v(i, j)` is
//! vertex `v`'s share of their similarity ([`crate::contribution::pair_contributions`]). For two
//! labels `A`, `B` the score of vertex `v` is
//! `mean over i in A, j in B of s_v(i, j) - mean over pairs within A or within B of s_v(i, j)`
//! (normalized length units): positive where the groups differ more than their members do.
//! The p-value is one-sided, from `P` random relabellings of the members of `A` and `B` that
//! keep the group sizes (seeded ChaCha8, so results are reproducible):
//! `p_v = (1 + #{permutations with score_v >= observed score_v}) / (1 + P)`. Vertices are
//! significant when they pass the Benjamini-Hochberg step-up procedure at level `alpha` over
//! all vertices of the contrast.

use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use thiserror::Error;

use crate::contribution::{pair_contributions, ContributionError};
use qcshape::geodesic::GeodesicSolver;
use qcshape::similarity::{all_pairs, Pose};

mod files;
mod motion;
mod study;
pub use files::{write_map, MapFileError, VertexMap};
pub use motion::{motion_contrasts, motion_maps, MotionContrast, MotionMeasure, MotionScale};
pub use study::{
    file_part, group_labels, localize, motion_title, push_region_row, Localization, LocalizeStudyError,
    REGION_SUMMARY_HEADER,
};

/// Options of [`contrasts`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalizeOptions {
    /// Random relabellings per contrast (default 999).
    pub permutations: usize,
    /// Seed of the relabellings (default 0).
    pub seed: u64,
    /// False discovery rate of the Benjamini-Hochberg procedure (default 0.05).
    pub alpha: f64,
}

impl Default for LocalizeOptions {
    fn default() -> Self {
        LocalizeOptions {
            permutations: 999,
            seed: 0,
            alpha: 0.05,
        }
    }
}

/// `'a' or 'b'`, `'a', 'b' or 'c'`.
fn quoted_alternatives(names: &[&str]) -> String {
    let quoted: Vec<String> = names.iter().map(|n| format!("'{n}'")).collect();
    match quoted.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
        _ => quoted.join(""),
    }
}

/// Why a vertex mask file cannot be used ([`LocalizeError::Mask`]).
#[derive(Debug, Error)]
pub enum MaskError {
    /// The file cannot be read.
    #[error("cannot read: {0}")]
    Read(std::io::Error),
    /// The header lacks a column.
    #[error("no {0:?} column in the header")]
    NoColumn(&'static str),
    /// A row without a vertex index.
    #[error("line {0}: bad vertex index")]
    BadVertex(usize),
    /// A vertex index beyond the base mesh.
    #[error("line {line}: vertex {vertex} beyond the {n_vertices} vertices of the base mesh")]
    VertexRange {
        /// Line (1-based).
        line: usize,
        /// The vertex.
        vertex: usize,
        /// Vertices of the base mesh.
        n_vertices: usize,
    },
    /// A region value other than 0/1 or true/false.
    #[error("line {0}: region must be 0/1 or true/false")]
    BadRegion(usize),
}

/// Why a localization cannot be computed.
#[derive(Debug, Error)]
pub enum LocalizeError {
    /// Not one label per deformation.
    #[error("{labels} labels for {deformations} deformations")]
    LabelCount {
        /// Labels given.
        labels: usize,
        /// Deformations.
        deformations: usize,
    },
    /// A significance level outside (0, 1).
    #[error("alpha must be in (0, 1), got {0}")]
    Alpha(f64),
    /// Fewer than two distinct labels.
    #[error("a contrast needs at least two labels, the data set has {0}")]
    TooFewLabels(usize),
    /// Two labels with one deformation each: no within-group pair.
    #[error("labels {a:?} and {b:?} have one deformation each: there is no within-group pair")]
    NoWithinPair {
        /// First label.
        a: String,
        /// Second label.
        b: String,
    },
    /// A name that is not one of the accepted ones (motion measure, motion scale).
    #[error("expected {}, got {name:?}", quoted_alternatives(.expected))]
    UnknownName {
        /// The name given.
        name: String,
        /// The names accepted.
        expected: &'static [&'static str],
    },
    /// A vertex mask file that cannot be read or is malformed.
    #[error("{}: {problem}", path.display())]
    Mask {
        /// The file.
        path: std::path::PathBuf,
        /// What is wrong.
        problem: MaskError,
    },
    /// A pair's similarity split failed.
    #[error("deformations {i} and {j}: {error}")]
    Pair {
        /// First deformation.
        i: usize,
        /// Second deformation.
        j: usize,
        /// The error.
        error: ContributionError,
    },
    /// A deformation's motion split failed.
    #[error("deformation {deformation}: {error}")]
    Motion {
        /// The deformation.
        deformation: usize,
        /// The error.
        error: ContributionError,
    },
}

/// Per-vertex similarity splits of every pair of deformations.
#[derive(Debug, Clone, PartialEq)]
pub struct PairMaps {
    /// Number of deformations.
    pub n: usize,
    /// Number of vertices.
    pub n_vertices: usize,
    /// `s_v(i, j)` for the pairs of [`all_pairs`] in that order (#pairs x #V).
    pub maps: Vec<Vec<f64>>,
    /// Whether every geodesic converged.
    pub converged: bool,
}

impl PairMaps {
    /// Index of pair `(i, j)` (either order, `i != j`) in [`PairMaps::maps`].
    pub fn index(&self, i: usize, j: usize) -> usize {
        let (i, j) = if i < j { (i, j) } else { (j, i) };
        // Pairs of rows before i, then the offset within row i.
        i * (2 * self.n - i - 1) / 2 + (j - i - 1)
    }
}

/// Splits the similarity of every pair of `deformations` (each #poses x #V x 3, already scaled
/// by the common factor, all with the same pose count) per vertex, pairs in parallel.
pub fn pair_maps(solver: &GeodesicSolver, deformations: &[Vec<Pose>]) -> Result<PairMaps, LocalizeError> {
    let n = deformations.len();
    let nv = solver.path_energy().n_vertices();
    let pairs = all_pairs(n);
    let out: Vec<(Vec<f64>, bool)> = pairs
        .par_iter()
        .map(|&(i, j)| {
            pair_contributions(solver, &deformations[i], &deformations[j])
                .map(|c| (c.total, c.converged))
                .map_err(|error| LocalizeError::Pair { i, j, error })
        })
        .collect::<Result<_, _>>()?;
    let converged = out.iter().all(|(_, c)| *c);
    Ok(PairMaps {
        n,
        n_vertices: nv,
        maps: out.into_iter().map(|(m, _)| m).collect(),
        converged,
    })
}

/// One contrast between two labels.
#[derive(Debug, Clone, PartialEq)]
pub struct Contrast {
    /// First label.
    pub a: String,
    /// Second label.
    pub b: String,
    /// Mean between-group split per vertex (#V, normalized length units).
    pub between: Vec<f64>,
    /// Mean within-group split per vertex (#V).
    pub within: Vec<f64>,
    /// `between - within` (#V).
    pub score: Vec<f64>,
    /// One-sided permutation p-values (#V).
    pub p_value: Vec<f64>,
    /// Benjamini-Hochberg decisions at [`LocalizeOptions::alpha`] (#V).
    pub significant: Vec<bool>,
}

/// (between, within) means per vertex for a labelling of `members` (`in_a[k]`: member `k` is in
/// group A).
fn means(maps: &PairMaps, members: &[usize], in_a: &[bool]) -> (Vec<f64>, Vec<f64>) {
    let nv = maps.n_vertices;
    let (mut between, mut within) = (vec![0.0; nv], vec![0.0; nv]);
    let (mut nb, mut nw) = (0usize, 0usize);
    for x in 0..members.len() {
        for y in x + 1..members.len() {
            let m = &maps.maps[maps.index(members[x], members[y])];
            let (acc, count) = if in_a[x] != in_a[y] {
                (&mut between, &mut nb)
            } else {
                (&mut within, &mut nw)
            };
            *count += 1;
            for (s, v) in acc.iter_mut().zip(m) {
                *s += v;
            }
        }
    }
    let scale = |v: &mut Vec<f64>, k: usize| {
        if k > 0 {
            v.iter_mut().for_each(|x| *x /= k as f64);
        }
    };
    scale(&mut between, nb);
    scale(&mut within, nw);
    (between, within)
}

/// Benjamini-Hochberg step-up decisions at level `alpha` for `p` (#tests).
pub fn benjamini_hochberg(p: &[f64], alpha: f64) -> Vec<bool> {
    let m = p.len();
    let mut order: Vec<usize> = (0..m).collect();
    order.sort_by(|&a, &b| p[a].total_cmp(&p[b]).then(a.cmp(&b)));
    let mut k_max = None;
    for (rank, &i) in order.iter().enumerate() {
        if p[i] <= alpha * (rank + 1) as f64 / m as f64 {
            k_max = Some(rank);
        }
    }
    let mut out = vec![false; m];
    if let Some(k) = k_max {
        for &i in &order[..=k] {
            out[i] = true;
        }
    }
    out
}

/// The deformations of one pair of labels, as [`label_pairs`] gives them.
pub(crate) struct LabelPair<'a> {
    /// First label.
    pub a: &'a String,
    /// Second label.
    pub b: &'a String,
    /// Indices of the deformations labelled `a` or `b`, in input order.
    pub members: Vec<usize>,
    /// `in_a[k]`: member `k` is labelled `a`.
    pub in_a: Vec<bool>,
    /// The permutation stream of this pair of labels.
    pub stream: u64,
}

/// Every pair of distinct labels (in order of first appearance) of `n` deformations, after
/// checking `labels` (one per deformation, at least two distinct) and `opts.alpha`.
pub(crate) fn label_pairs<'a>(
    labels: &'a [String],
    n: usize,
    opts: &LocalizeOptions,
) -> Result<Vec<LabelPair<'a>>, LocalizeError> {
    if labels.len() != n {
        return Err(LocalizeError::LabelCount {
            labels: labels.len(),
            deformations: n,
        });
    }
    if !(opts.alpha > 0.0 && opts.alpha < 1.0) {
        return Err(LocalizeError::Alpha(opts.alpha));
    }
    let mut names: Vec<&String> = Vec::new();
    for l in labels {
        if !names.contains(&l) {
            names.push(l);
        }
    }
    if names.len() < 2 {
        return Err(LocalizeError::TooFewLabels(names.len()));
    }
    let mut out = Vec::new();
    for x in 0..names.len() {
        for y in x + 1..names.len() {
            let (a, b) = (names[x], names[y]);
            let members: Vec<usize> = (0..n).filter(|&k| labels[k] == *a || labels[k] == *b).collect();
            let in_a = members.iter().map(|&k| labels[k] == *a).collect();
            out.push(LabelPair {
                a,
                b,
                members,
                in_a,
                stream: (x * names.len() + y) as u64,
            });
        }
    }
    Ok(out)
}

/// The contrast of every pair of distinct labels (in order of first appearance) of the
/// deformations behind `maps` (`labels`: one per deformation).
pub fn contrasts(
    maps: &PairMaps,
    labels: &[String],
    opts: &LocalizeOptions,
) -> Result<Vec<Contrast>, LocalizeError> {
    let mut out = Vec::new();
    for lp in label_pairs(labels, maps.n, opts)? {
        let (a, b) = (lp.a, lp.b);
        let na = lp.in_a.iter().filter(|&&t| t).count();
        if na < 2 && lp.members.len() - na < 2 {
            return Err(LocalizeError::NoWithinPair {
                a: a.to_string(),
                b: b.to_string(),
            });
        }
        let (between, within) = means(maps, &lp.members, &lp.in_a);
        let score: Vec<f64> = between.iter().zip(&within).map(|(b, w)| b - w).collect();
        let p_value = permutation_p_values(
            &lp.in_a,
            opts,
            lp.stream,
            &score,
            |s, o| s >= o,
            |perm| {
                let (bt, wt) = means(maps, &lp.members, perm);
                bt.iter().zip(&wt).map(|(b, w)| b - w).collect()
            },
        );
        let significant = benjamini_hochberg(&p_value, opts.alpha);
        out.push(Contrast {
            a: a.clone(),
            b: b.clone(),
            between,
            within,
            score,
            p_value,
            significant,
        });
    }
    Ok(out)
}

/// One p-value per vertex from `opts.permutations` random relabellings of `in_a` (group sizes
/// kept): `p_v = (1 + #{perm: exceeds(stat(perm)_v, observed_v)}) / (1 + P)`, where `exceeds`
/// gets a relative tolerance of 1e-12 on the observed value (so the identity relabelling
/// counts). Permutation `p` of contrast `stream` draws from its own ChaCha8 stream seeded by
/// (`opts.seed`, `stream`, `p`) and the counts are summed, so the result does not depend on
/// the thread count.
pub(crate) fn permutation_p_values(
    in_a: &[bool],
    opts: &LocalizeOptions,
    stream: u64,
    observed: &[f64],
    exceeds: impl Fn(f64, f64) -> bool + Sync,
    stat: impl Fn(&[bool]) -> Vec<f64> + Sync,
) -> Vec<f64> {
    let exceed: Vec<u32> = (0..opts.permutations)
        .into_par_iter()
        .map(|p| {
            let mut rng = ChaCha8Rng::seed_from_u64(
                opts.seed ^ (stream << 40) ^ (p as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15),
            );
            let mut perm = in_a.to_vec();
            perm.shuffle(&mut rng);
            stat(&perm)
                .iter()
                .zip(observed)
                .map(|(s, o)| u32::from(exceeds(*s, o - 1e-12 * o.abs())))
                .collect::<Vec<u32>>()
        })
        .reduce(
            || vec![0; observed.len()],
            |mut acc, v| {
                acc.iter_mut().zip(&v).for_each(|(a, b)| *a += b);
                acc
            },
        );
    exceed
        .iter()
        .map(|&e| (1.0 + e as f64) / (1.0 + opts.permutations as f64))
        .collect()
}

/// How much of a contrast's positive mass lies in a region, against the region's share of the
/// area (the LV phantom's acceptance: `positive_mass_share >= 2 area_share`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RegionShare {
    /// Vertices in the region.
    pub vertices: usize,
    /// The region's share of the mesh area (vertex areas, a third of each face's area per
    /// corner).
    pub area_share: f64,
    /// The region's share of `sum_v max(score_v, 0)` (0 when nothing is positive).
    pub positive_mass_share: f64,
    /// `positive_mass_share / area_share` (0 when the region has no area).
    pub ratio: f64,
    /// Significant vertices in the region.
    pub significant_in_region: usize,
    /// Significant vertices in all.
    pub significant: usize,
}

impl std::fmt::Display for RegionShare {
    /// One sentence part for terminals and reports: "region of N vertices: A % of the area, M %
    /// of the positive mass (ratio R); S of T significant vertices in it".
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "region of {} vertices: {:.1} % of the area, {:.1} % of the positive mass (ratio {:.2}); {} of {} significant vertices in it",
            self.vertices,
            100.0 * self.area_share,
            100.0 * self.positive_mass_share,
            self.ratio,
            self.significant_in_region,
            self.significant
        )
    }
}

/// [`RegionShare`] of `score` (#V) and `significant` (#V) on the mesh `topology` /
/// `positions` (#V x 3) for the vertex mask `region` (#V).
pub fn region_share(
    topology: &qcshape::mesh::Topology,
    positions: &[[f64; 3]],
    score: &[f64],
    significant: &[bool],
    region: &[bool],
) -> RegionShare {
    let areas = qcshape::mesh::geometry::vertex_areas(topology, positions);
    let total: f64 = areas.iter().sum();
    let inside: f64 = areas.iter().zip(region).filter(|(_, &r)| r).map(|(a, _)| a).sum();
    let area_share = if total > 0.0 { inside / total } else { 0.0 };
    let positive: Vec<f64> = score.iter().map(|s| s.max(0.0)).collect();
    let positive_mass_share = crate::contribution::mass_fraction(&positive, region);
    RegionShare {
        vertices: region.iter().filter(|&&r| r).count(),
        area_share,
        positive_mass_share,
        ratio: if area_share > 0.0 {
            positive_mass_share / area_share
        } else {
            0.0
        },
        significant_in_region: significant.iter().zip(region).filter(|(&s, &r)| s && r).count(),
        significant: significant.iter().filter(|&&s| s).count(),
    }
}

/// Reads a vertex mask for `n_vertices` vertices from a CSV file with a header naming a
/// `vertex` column and a `region` column (`1`/`true` inside, `0`/`false` outside; e.g. the LV
/// phantom's `abnormal_region.csv`). Vertices not listed are outside.
pub fn read_vertex_mask(path: &std::path::Path, n_vertices: usize) -> Result<Vec<bool>, LocalizeError> {
    let bad = |problem: MaskError| LocalizeError::Mask {
        path: path.to_path_buf(),
        problem,
    };
    let text = qcshape::limits::read_regular_text(path, qcshape::limits::MAX_TABLE_FILE_BYTES)
        .map_err(|e| bad(MaskError::Read(e)))?;
    let mut lines = text.lines().enumerate();
    let header: Vec<String> = lines
        .next()
        .map(|(_, h)| h.split(',').map(|c| c.trim().to_ascii_lowercase()).collect())
        .unwrap_or_default();
    let col = |name: &'static str| {
        header
            .iter()
            .position(|c| c == name)
            .ok_or_else(|| bad(MaskError::NoColumn(name)))
    };
    let (cv, cr) = (col("vertex")?, col("region")?);
    let mut mask = vec![false; n_vertices];
    for (k, line) in lines.filter(|(_, l)| !l.trim().is_empty()) {
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        let v: usize = f
            .get(cv)
            .and_then(|s| s.parse().ok())
            .ok_or_else(|| bad(MaskError::BadVertex(k + 1)))?;
        if v >= n_vertices {
            return Err(bad(MaskError::VertexRange {
                line: k + 1,
                vertex: v,
                n_vertices,
            }));
        }
        mask[v] = match f.get(cr).map(|s| s.to_ascii_lowercase()).as_deref() {
            Some("1" | "true") => true,
            Some("0" | "false") => false,
            _ => return Err(bad(MaskError::BadRegion(k + 1))),
        };
    }
    Ok(mask)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pair_index_follows_all_pairs() {
        let maps = PairMaps {
            n: 5,
            n_vertices: 0,
            maps: Vec::new(),
            converged: true,
        };
        for (k, (i, j)) in all_pairs(5).into_iter().enumerate() {
            assert_eq!(maps.index(i, j), k);
            assert_eq!(maps.index(j, i), k);
        }
    }

    #[test]
    fn benjamini_hochberg_steps_up() {
        // m = 5, alpha = 0.05: thresholds 0.01, 0.02, 0.03, 0.04, 0.05.
        let p = [0.005, 0.5, 0.03, 0.021, 0.9];
        assert_eq!(benjamini_hochberg(&p, 0.05), vec![true, false, true, true, false]);
        assert_eq!(benjamini_hochberg(&[0.2, 0.3], 0.05), vec![false, false]);
    }

    /// Synthetic pair maps: 5 + 5 deformations on 10 vertices; between-group pairs differ on
    /// vertices 0..3, everything else is noise of the same size for all pairs.
    #[test]
    fn planted_difference_is_found_and_the_rest_is_not() {
        let n = 10;
        let nv = 10;
        let labels: Vec<String> = (0..n)
            .map(|k| if k < 5 { "a" } else { "b" }.to_string())
            .collect();
        let mut maps = Vec::new();
        for (k, (i, j)) in all_pairs(n).into_iter().enumerate() {
            let between = (i < 5) != (j < 5);
            maps.push(
                (0..nv)
                    .map(|v| {
                        let noise = ((k * 31 + v * 17) % 7) as f64 * 0.01;
                        noise + if between && v < 3 { 1.0 } else { 0.0 }
                    })
                    .collect(),
            );
        }
        let pm = PairMaps {
            n,
            n_vertices: nv,
            maps,
            converged: true,
        };
        let opts = LocalizeOptions {
            permutations: 199,
            seed: 7,
            alpha: 0.1,
        };
        let c = contrasts(&pm, &labels, &opts).unwrap();
        assert_eq!(c.len(), 1);
        let c = &c[0];
        for v in 0..3 {
            assert!(c.score[v] > 0.9, "{v}: {}", c.score[v]);
            // 10 choose 5 = 252 labellings, 2 of them the observed split.
            assert!(c.p_value[v] <= 0.05, "{v}: {}", c.p_value[v]);
            assert!(c.significant[v]);
        }
        assert!(c.score[3..].iter().all(|s| s.abs() < 0.1));
        assert!(c.significant[3..].iter().all(|s| !s));
        // Deterministic.
        assert_eq!(contrasts(&pm, &labels, &opts).unwrap()[0], *c);
    }

    #[test]
    fn region_share_compares_mass_and_area() {
        let s = qcshape::synth::icosphere(2);
        let cap: Vec<bool> = s.positions.iter().map(|p| p[2] > 0.5).collect();
        // Positive score only on the cap, negative elsewhere (ignored).
        let score: Vec<f64> = cap.iter().map(|&c| if c { 1.0 } else { -0.5 }).collect();
        let sig = cap.clone();
        let r = region_share(&s.topology, &s.positions, &score, &sig, &cap);
        assert_eq!(r.positive_mass_share, 1.0);
        assert!(r.area_share > 0.15 && r.area_share < 0.35, "{}", r.area_share);
        assert!((r.ratio - 1.0 / r.area_share).abs() < 1e-12);
        assert_eq!(r.significant_in_region, r.vertices);
        assert_eq!(r.significant, r.vertices);
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("m.csv");
        std::fs::write(&f, "vertex,weight,region\n0,0.9,1\n2,0.1,0\n3,1,true\n").unwrap();
        assert_eq!(read_vertex_mask(&f, 4).unwrap(), vec![true, false, false, true]);
        assert!(read_vertex_mask(&f, 3).is_err());
        std::fs::write(&f, "vertex,mask\n0,1\n").unwrap();
        assert!(read_vertex_mask(&f, 3)
            .unwrap_err()
            .to_string()
            .contains("region"));
    }
}
