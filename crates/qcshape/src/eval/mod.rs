//! Evaluation of a clustering against known classes (eq. 15), of a distance matrix by
//! leave-one-out nearest neighbour, the adjusted Rand index, and the stability share `tau` of
//! eq. 17.
//!
//! Partitions are given as one index per item (`0..k` clusters, `0..c` classes);
//! [`encode_labels`] turns text labels into class indices.

pub mod matching;
pub mod scores;

pub use matching::{hungarian_match, matched_confusion, ConfusionMatrix, Matching};
pub use scores::{
    adjusted_rand_index, loo_nearest_neighbour_accuracy, nearest_neighbour, one_vs_rest, tau, BinaryCounts,
    OneVsRest,
};

use thiserror::Error;

/// Why an evaluation cannot be computed.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum EvalError {
    /// Two per-item lists have different lengths.
    #[error("{what}: {a} items against {b}")]
    LengthMismatch {
        /// What was compared.
        what: &'static str,
        /// First length.
        a: usize,
        /// Second length.
        b: usize,
    },
    /// An index is not below its declared count.
    #[error("item {item} has {what} {index}, but there are only {count}")]
    OutOfRange {
        /// Item.
        item: usize,
        /// "cluster" or "class".
        what: &'static str,
        /// The index.
        index: usize,
        /// The declared count.
        count: usize,
    },
    /// Too few items or classes for the measure: `measure` needs at least `min` `what`
    /// (`got`).
    #[error("{measure} needs at least {min} {what}, got {got}")]
    TooFew {
        /// The measure: "sensitivity and specificity", "leave-one-out", "tau".
        measure: &'static str,
        /// Its minimum.
        min: usize,
        /// "classes" or "items".
        what: &'static str,
        /// The count given.
        got: usize,
    },
    /// A class has no item, so its sensitivity is undefined.
    #[error("class {0} has no item")]
    EmptyClass(usize),
}

/// Class indices of text labels (n), classes numbered in order of first appearance, and the
/// class names (c).
pub fn encode_labels<S: AsRef<str>>(labels: &[S]) -> (Vec<usize>, Vec<String>) {
    let mut names: Vec<String> = Vec::new();
    let idx = labels
        .iter()
        .map(|l| {
            let l = l.as_ref();
            match names.iter().position(|n| n == l) {
                Some(i) => i,
                None => {
                    names.push(l.to_string());
                    names.len() - 1
                }
            }
        })
        .collect();
    (idx, names)
}

/// Checks that `a` holds indices below `count`.
pub(crate) fn check_range(a: &[usize], count: usize, what: &'static str) -> Result<(), EvalError> {
    match a.iter().enumerate().find(|(_, &x)| x >= count) {
        Some((item, &index)) => Err(EvalError::OutOfRange {
            item,
            what,
            index,
            count,
        }),
        None => Ok(()),
    }
}

/// The number of groups of a partition: `1 + max index` (0 when empty).
pub(crate) fn n_groups(a: &[usize]) -> usize {
    a.iter().max().map_or(0, |m| m + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_are_numbered_by_first_appearance() {
        let (idx, names) = encode_labels(&["run", "walk", "run", "jump"]);
        assert_eq!(idx, vec![0, 1, 0, 2]);
        assert_eq!(names, vec!["run", "walk", "jump"]);
    }
}
