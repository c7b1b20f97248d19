//! Scores: eq. 15's sensitivity and specificity from averaged one-vs-rest confusion matrices,
//! leave-one-out nearest-neighbour accuracy, the adjusted Rand index, and eq. 17's `tau`.

use super::{check_range, hungarian_match, n_groups, ConfusionMatrix, EvalError};
use crate::similarity::DistanceMatrix;

/// A two-class (one class against the rest) confusion matrix; `f64` so that averages are
/// exact.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct BinaryCounts {
    /// True positives: items of the class predicted as the class.
    pub tp: f64,
    /// False negatives: items of the class predicted otherwise (or as no class).
    pub fn_: f64,
    /// False positives: items of other classes predicted as the class.
    pub fp: f64,
    /// True negatives: items of other classes not predicted as the class.
    pub tn: f64,
}

impl BinaryCounts {
    /// `TP / (TP + FN)`.
    pub fn sensitivity(&self) -> f64 {
        self.tp / (self.tp + self.fn_)
    }

    /// `TN / (FP + TN)`.
    pub fn specificity(&self) -> f64 {
        self.tn / (self.fp + self.tn)
    }
}

/// Eq. 15 on a `c`-class confusion matrix.
///
/// For each class `k` (one against the rest): `TP_k = counts[k][k]`, `FN_k` = the other items
/// of class `k` (including those predicted as no class), `FP_k` = items of other classes
/// predicted as `k`, `TN_k = n - TP_k - FN_k - FP_k`. The paper averages these `c` matrices
/// entry by entry (`mean`) and computes
/// `sensitivity = TP/(TP + FN)` and `specificity = TN/(FP + TN)` on the average: these are
/// `sensitivity` and `specificity` here. (On the average, the sensitivity equals the share of
/// items predicted as their class, and the specificity is `sum TN_k / sum (FP_k + TN_k)`.)
/// The means of the per-class values are given as `macro_sensitivity` and
/// `macro_specificity`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct OneVsRest {
    /// One binary confusion matrix per class (c).
    pub per_class: Vec<BinaryCounts>,
    /// Their entry-wise mean.
    pub mean: BinaryCounts,
    /// Eq. 15 sensitivity of the mean matrix, in [0, 1].
    pub sensitivity: f64,
    /// Eq. 15 specificity of the mean matrix, in [0, 1].
    pub specificity: f64,
    /// Mean over classes of `TP_k / (TP_k + FN_k)`.
    pub macro_sensitivity: f64,
    /// Mean over classes of `TN_k / (FP_k + TN_k)`.
    pub macro_specificity: f64,
}

/// Eq. 15 (see [`OneVsRest`]). Needs at least two classes, each with at least one item.
pub fn one_vs_rest(cm: &ConfusionMatrix) -> Result<OneVsRest, EvalError> {
    let c = cm.n_classes();
    if c < 2 {
        return Err(EvalError::TooFew {
            measure: "sensitivity and specificity",
            min: 2,
            what: "classes",
            got: c,
        });
    }
    let n = cm.total() as f64;
    let mut per_class = Vec::with_capacity(c);
    for k in 0..c {
        let row: usize = cm.counts[k].iter().sum();
        if row == 0 {
            return Err(EvalError::EmptyClass(k));
        }
        let tp = cm.counts[k][k] as f64;
        let fn_ = row as f64 - tp;
        let fp = (0..c).filter(|&a| a != k).map(|a| cm.counts[a][k]).sum::<usize>() as f64;
        per_class.push(BinaryCounts {
            tp,
            fn_,
            fp,
            tn: n - tp - fn_ - fp,
        });
    }
    let cf = c as f64;
    let mean = per_class
        .iter()
        .fold(BinaryCounts::default(), |a, b| BinaryCounts {
            tp: a.tp + b.tp / cf,
            fn_: a.fn_ + b.fn_ / cf,
            fp: a.fp + b.fp / cf,
            tn: a.tn + b.tn / cf,
        });
    Ok(OneVsRest {
        sensitivity: mean.sensitivity(),
        specificity: mean.specificity(),
        macro_sensitivity: per_class.iter().map(BinaryCounts::sensitivity).sum::<f64>() / cf,
        macro_specificity: per_class.iter().map(BinaryCounts::specificity).sum::<f64>() / cf,
        per_class,
        mean,
    })
}

/// The nearest other item of item `i` (smallest `d_ij`, `j != i`; ties to the lowest index).
/// Needs n >= 2.
pub fn nearest_neighbour(d: &DistanceMatrix, i: usize) -> usize {
    let row = d.row(i);
    (0..d.len())
        .filter(|&j| j != i)
        .fold(None::<usize>, |b, j| match b {
            Some(b) if row[b] <= row[j] => Some(b),
            _ => Some(j),
        })
        .expect("n >= 2")
}

/// Leave-one-out 1-nearest-neighbour accuracy: the share of items whose nearest other item
/// (smallest `d_ij`, `j != i`; ties to the lowest index) has the same class. Needs n >= 2.
pub fn loo_nearest_neighbour_accuracy(d: &DistanceMatrix, classes: &[usize]) -> Result<f64, EvalError> {
    let n = d.len();
    if classes.len() != n {
        return Err(EvalError::LengthMismatch {
            what: "matrix rows against classes",
            a: n,
            b: classes.len(),
        });
    }
    if n < 2 {
        return Err(EvalError::TooFew {
            measure: "leave-one-out",
            min: 2,
            what: "items",
            got: n,
        });
    }
    let hits = (0..n)
        .filter(|&i| classes[nearest_neighbour(d, i)] == classes[i])
        .count();
    Ok(hits as f64 / n as f64)
}

fn pairs(x: usize) -> f64 {
    let x = x as f64;
    x * (x - 1.0) / 2.0
}

/// Adjusted Rand index (Hubert and Arabie) of two partitions of the same items:
/// `(index - expected) / (max - expected)` with `index = sum_ij C(n_ij, 2)`,
/// `expected = sum_i C(a_i, 2) sum_j C(b_j, 2) / C(n, 2)` and
/// `max = (sum_i C(a_i, 2) + sum_j C(b_j, 2)) / 2`. 1 for identical partitions, about 0 for
/// independent ones. When `max == expected` (both partitions trivial, e.g. fewer than two
/// items) it is 1.
pub fn adjusted_rand_index(a: &[usize], b: &[usize]) -> Result<f64, EvalError> {
    if a.len() != b.len() {
        return Err(EvalError::LengthMismatch {
            what: "two partitions",
            a: a.len(),
            b: b.len(),
        });
    }
    let (ka, kb) = (n_groups(a), n_groups(b));
    let mut table = vec![0usize; ka * kb];
    let (mut ra, mut rb) = (vec![0usize; ka], vec![0usize; kb]);
    for (&x, &y) in a.iter().zip(b) {
        table[x * kb + y] += 1;
        ra[x] += 1;
        rb[y] += 1;
    }
    let index: f64 = table.iter().map(|&v| pairs(v)).sum();
    let sa: f64 = ra.iter().map(|&v| pairs(v)).sum();
    let sb: f64 = rb.iter().map(|&v| pairs(v)).sum();
    let total = pairs(a.len());
    if total == 0.0 {
        return Ok(1.0);
    }
    let expected = sa * sb / total;
    let max = 0.5 * (sa + sb);
    if max == expected {
        return Ok(1.0);
    }
    Ok((index - expected) / (max - expected))
}

/// Eq. 17: the share of items whose class is unchanged between a reference clustering
/// `first` (e.g. noise-free) and `second` (e.g. with noise), after matching the clusters of
/// `second` to those of `first` by the Hungarian algorithm (cluster numbers are arbitrary).
/// In [0, 1]; 1 when the partitions are equal up to renumbering.
pub fn tau(first: &[usize], second: &[usize]) -> Result<f64, EvalError> {
    if first.len() != second.len() {
        return Err(EvalError::LengthMismatch {
            what: "two clusterings",
            a: first.len(),
            b: second.len(),
        });
    }
    if first.is_empty() {
        return Err(EvalError::TooFew {
            measure: "tau",
            min: 1,
            what: "items",
            got: 0,
        });
    }
    let (k1, k2) = (n_groups(first), n_groups(second));
    check_range(second, k2, "cluster")?;
    let m = hungarian_match(second, k2, first, k1)?;
    Ok(m.matched as f64 / first.len() as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eq15_on_a_hand_computed_confusion_matrix() {
        // Actual x predicted, 10 items:
        //        A  B  C
        //   A    3  1  0
        //   B    0  2  1
        //   C    1  0  2
        // One vs rest:      TP FN FP TN
        //   A               3  1  1  5
        //   B               2  1  1  6
        //   C               2  1  1  6
        // Mean:             7/3 1 1 17/3
        // sensitivity = (7/3) / (7/3 + 1) = 7/10; specificity = (17/3) / (1 + 17/3) = 17/20.
        // Macro: (3/4 + 2/3 + 2/3)/3 = 25/36; (5/6 + 6/7 + 6/7)/3 = 107/126.
        let cm = ConfusionMatrix {
            counts: vec![vec![3, 1, 0, 0], vec![0, 2, 1, 0], vec![1, 0, 2, 0]],
        };
        let r = one_vs_rest(&cm).unwrap();
        let want = [(3.0, 1.0, 1.0, 5.0), (2.0, 1.0, 1.0, 6.0), (2.0, 1.0, 1.0, 6.0)];
        for (b, w) in r.per_class.iter().zip(want) {
            assert_eq!((b.tp, b.fn_, b.fp, b.tn), w);
        }
        assert!((r.mean.tp - 7.0 / 3.0).abs() < 1e-15 && (r.mean.tn - 17.0 / 3.0).abs() < 1e-15);
        assert!((r.sensitivity - 0.7).abs() < 1e-15);
        assert!((r.specificity - 0.85).abs() < 1e-15);
        assert!((r.macro_sensitivity - 25.0 / 36.0).abs() < 1e-15);
        assert!((r.macro_specificity - 107.0 / 126.0).abs() < 1e-15);
    }

    #[test]
    fn unmatched_items_are_false_negatives_only() {
        // A: 2 right, 1 in a left-over cluster; B: 3 right. n = 6.
        // A: TP 2 FN 1 FP 0 TN 3; B: TP 3 FN 0 FP 0 TN 3. Mean 2.5 0.5 0 3.
        let cm = ConfusionMatrix {
            counts: vec![vec![2, 0, 1], vec![0, 3, 0]],
        };
        let r = one_vs_rest(&cm).unwrap();
        assert!((r.sensitivity - 2.5 / 3.0).abs() < 1e-15);
        assert_eq!(r.specificity, 1.0);
        let one = ConfusionMatrix {
            counts: vec![vec![3, 0]],
        };
        assert!(one_vs_rest(&one).is_err());
    }

    #[test]
    fn leave_one_out_nearest_neighbour() {
        // Points on a line: 0, 1, 5, 6, 7 (classes a a b b a).
        // Nearest: 0->1 (a=a), 1->0 (a=a), 5->6 (b=b), 6->5 (tie with 7, lowest index: b=b),
        // 7->6 (a vs b: miss). Accuracy 4/5.
        let x: [f64; 5] = [0.0, 1.0, 5.0, 6.0, 7.0];
        let names = (0..5).map(|i| format!("p{i}")).collect();
        let d = DistanceMatrix::from_fn(names, |i, j| (x[i] - x[j]).abs()).unwrap();
        let acc = loo_nearest_neighbour_accuracy(&d, &[0, 0, 1, 1, 0]).unwrap();
        assert!((acc - 0.8).abs() < 1e-15);
    }

    #[test]
    fn adjusted_rand_index_by_hand() {
        // a = 000111, b = 001122. Table: (0,0)=2 (0,1)=1 (1,1)=1 (1,2)=2.
        // index = 1 + 0 + 0 + 1 = 2; sum C(a_i,2) = 3 + 3 = 6; sum C(b_j,2) = 1+1+1 = 3;
        // C(6,2) = 15; expected = 6*3/15 = 1.2; max = 4.5; ARI = 0.8 / 3.3.
        let a = [0, 0, 0, 1, 1, 1];
        let b = [0, 0, 1, 1, 2, 2];
        let ari = adjusted_rand_index(&a, &b).unwrap();
        assert!((ari - 0.8 / 3.3).abs() < 1e-15, "{ari}");
        assert_eq!(adjusted_rand_index(&a, &[1, 1, 1, 0, 0, 0]).unwrap(), 1.0);
        assert_eq!(
            adjusted_rand_index(&a, &b).unwrap(),
            adjusted_rand_index(&b, &a).unwrap()
        );
        assert!(adjusted_rand_index(&a, &b[..5]).is_err());
    }

    #[test]
    fn tau_by_hand() {
        // first  = 0 0 1 1 2 2; second = 1 1 0 2 2 2. second x first table:
        //   s0: 0 1 0;  s1: 2 0 0;  s2: 0 1 2. Best matching s1->0, s2->2, s0->1: 5 of 6.
        let t = tau(&[0, 0, 1, 1, 2, 2], &[1, 1, 0, 2, 2, 2]).unwrap();
        assert!((t - 5.0 / 6.0).abs() < 1e-15);
        assert_eq!(tau(&[0, 0, 1], &[1, 1, 0]).unwrap(), 1.0);
        // Fewer clusters in the second run: s0 = all -> matched to one class only.
        assert!((tau(&[0, 0, 1, 1], &[0, 0, 0, 0]).unwrap() - 0.5).abs() < 1e-15);
    }
}
