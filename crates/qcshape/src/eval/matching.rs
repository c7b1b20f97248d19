//! Matching clusters to classes with the Hungarian algorithm, and the matched confusion matrix.

use pathfinding::kuhn_munkres::kuhn_munkres;
use pathfinding::matrix::Matrix;

use super::{check_range, EvalError};

/// A one-to-one matching of `k` clusters to `c` classes maximizing the number of items whose
/// cluster is matched to their class.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Matching {
    /// The class matched to each cluster (k); `None` for clusters left over when `k > c`.
    pub cluster_class: Vec<Option<usize>>,
    /// Items whose cluster is matched to their own class (the maximized count).
    pub matched: usize,
    /// Contingency table (k x c): `contingency[cl][cls]` items of class `cls` in cluster `cl`.
    pub contingency: Vec<Vec<usize>>,
}

impl Matching {
    /// The predicted class of each item: its cluster's class (`None` in a left-over cluster).
    pub fn predictions(&self, clusters: &[usize]) -> Vec<Option<usize>> {
        clusters.iter().map(|&cl| self.cluster_class[cl]).collect()
    }
}

/// Matches `k` clusters to `c` classes (Hungarian algorithm, `pathfinding::kuhn_munkres` on the
/// contingency table padded with zeros to `max(k, c)` square), maximizing the matched count.
/// `clusters` and `classes` give one index per item (`< k` and `< c`).
pub fn hungarian_match(
    clusters: &[usize],
    k: usize,
    classes: &[usize],
    c: usize,
) -> Result<Matching, EvalError> {
    if clusters.len() != classes.len() {
        return Err(EvalError::LengthMismatch {
            what: "clusters against classes",
            a: clusters.len(),
            b: classes.len(),
        });
    }
    check_range(clusters, k, "cluster")?;
    check_range(classes, c, "class")?;
    let mut contingency = vec![vec![0usize; c]; k];
    for (&cl, &cls) in clusters.iter().zip(classes) {
        contingency[cl][cls] += 1;
    }
    let m = k.max(c);
    if m == 0 {
        return Ok(Matching {
            cluster_class: vec![],
            matched: 0,
            contingency,
        });
    }
    let mut w = vec![0i64; m * m];
    for (cl, row) in contingency.iter().enumerate() {
        for (cls, &v) in row.iter().enumerate() {
            w[cl * m + cls] = v as i64;
        }
    }
    let w = Matrix::from_vec(m, m, w).expect("m x m values");
    let (total, assign) = kuhn_munkres(&w);
    let cluster_class = (0..k).map(|cl| Some(assign[cl]).filter(|&cls| cls < c)).collect();
    Ok(Matching {
        cluster_class,
        matched: total as usize,
        contingency,
    })
}

/// A confusion matrix of `c` classes: `counts[actual][predicted]`, with one extra last column
/// for items predicted as no class (in a cluster left unmatched).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ConfusionMatrix {
    /// c x (c + 1) counts.
    pub counts: Vec<Vec<usize>>,
}

impl ConfusionMatrix {
    /// Builds the matrix from actual classes (`< c`) and predictions (`None` = no class).
    pub fn from_predictions(
        actual: &[usize],
        predicted: &[Option<usize>],
        c: usize,
    ) -> Result<ConfusionMatrix, EvalError> {
        if actual.len() != predicted.len() {
            return Err(EvalError::LengthMismatch {
                what: "classes against predictions",
                a: actual.len(),
                b: predicted.len(),
            });
        }
        check_range(actual, c, "class")?;
        let mut counts = vec![vec![0usize; c + 1]; c];
        for (item, (&a, &p)) in actual.iter().zip(predicted).enumerate() {
            let col = match p {
                Some(p) if p >= c => {
                    return Err(EvalError::OutOfRange {
                        item,
                        what: "predicted class",
                        index: p,
                        count: c,
                    })
                }
                Some(p) => p,
                None => c,
            };
            counts[a][col] += 1;
        }
        Ok(ConfusionMatrix { counts })
    }

    /// Number of classes `c`.
    pub fn n_classes(&self) -> usize {
        self.counts.len()
    }

    /// Number of items.
    pub fn total(&self) -> usize {
        self.counts.iter().flatten().sum()
    }

    /// Items of `class` predicted as no class.
    pub fn unmatched(&self, class: usize) -> usize {
        self.counts[class][self.n_classes()]
    }

    /// Share of items predicted as their own class (0 for no items).
    pub fn accuracy(&self) -> f64 {
        let t = self.total();
        if t == 0 {
            return 0.0;
        }
        (0..self.n_classes()).map(|i| self.counts[i][i]).sum::<usize>() as f64 / t as f64
    }
}

/// The Hungarian matching of clusters to classes and the resulting confusion matrix.
pub fn matched_confusion(
    clusters: &[usize],
    k: usize,
    classes: &[usize],
    c: usize,
) -> Result<(Matching, ConfusionMatrix), EvalError> {
    let m = hungarian_match(clusters, k, classes, c)?;
    let cm = ConfusionMatrix::from_predictions(classes, &m.predictions(clusters), c)?;
    Ok((m, cm))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Items built from a contingency table (cluster x class).
    fn items(table: &[&[usize]]) -> (Vec<usize>, Vec<usize>) {
        let (mut cl, mut cs) = (vec![], vec![]);
        for (i, row) in table.iter().enumerate() {
            for (j, &v) in row.iter().enumerate() {
                for _ in 0..v {
                    cl.push(i);
                    cs.push(j);
                }
            }
        }
        (cl, cs)
    }

    #[test]
    fn hand_computed_matching_and_confusion() {
        // Clusters x classes (A, B, C):
        //   cluster 0: A0 B1 C2
        //   cluster 1: A3 B0 C1
        //   cluster 2: A1 B2 C0
        // Best one-to-one matching: 0 -> C (2), 1 -> A (3), 2 -> B (2), total 7; every other
        // matching scores at most 4. The confusion matrix (actual x predicted) is then
        //   A: 3 1 0 | B: 0 2 1 | C: 1 0 2.
        let (clusters, classes) = items(&[&[0, 1, 2], &[3, 0, 1], &[1, 2, 0]]);
        let (m, cm) = matched_confusion(&clusters, 3, &classes, 3).unwrap();
        assert_eq!(m.cluster_class, vec![Some(2), Some(0), Some(1)]);
        assert_eq!(m.matched, 7);
        assert_eq!(
            cm.counts,
            vec![vec![3, 1, 0, 0], vec![0, 2, 1, 0], vec![1, 0, 2, 0]]
        );
        assert!((cm.accuracy() - 0.7).abs() < 1e-15);
    }

    #[test]
    fn more_clusters_than_classes_leaves_one_unmatched() {
        // 3 clusters, 2 classes: cluster 0 = A4, cluster 1 = B3 A1, cluster 2 = B1.
        // Matching: 0 -> A, 1 -> B (7 items); cluster 2 is left over, its B item unmatched.
        let (clusters, classes) = items(&[&[4, 0], &[1, 3], &[0, 1]]);
        let (m, cm) = matched_confusion(&clusters, 3, &classes, 2).unwrap();
        assert_eq!(m.cluster_class, vec![Some(0), Some(1), None]);
        assert_eq!(m.matched, 7);
        assert_eq!(cm.counts, vec![vec![4, 1, 0], vec![0, 3, 1]]);
        assert_eq!(cm.unmatched(1), 1);
    }

    #[test]
    fn fewer_clusters_than_classes_never_predict_one_class() {
        // 2 clusters, 3 classes: cluster 0 = A2 B2, cluster 1 = C3 B1. 0 -> A or B (2),
        // 1 -> C (3); the tie is broken by the solver, the count is 5 either way.
        let (clusters, classes) = items(&[&[2, 2, 0], &[0, 1, 3]]);
        let (m, cm) = matched_confusion(&clusters, 2, &classes, 3).unwrap();
        assert_eq!(m.matched, 5);
        assert_eq!(m.cluster_class[1], Some(2));
        assert_eq!(cm.total(), 8);
        assert_eq!((0..3).map(|i| cm.counts[i][i]).sum::<usize>(), 5);
    }

    #[test]
    fn bad_inputs_are_errors() {
        assert!(matches!(
            hungarian_match(&[0, 1], 2, &[0], 1),
            Err(EvalError::LengthMismatch { .. })
        ));
        assert!(matches!(
            hungarian_match(&[0, 2], 2, &[0, 0], 1),
            Err(EvalError::OutOfRange {
                item: 1,
                index: 2,
                ..
            })
        ));
    }
}
