//! A metric made of two metrics one after the other ([`Regularized`](super::Regularized),
//! [`Bent`](super::Bent)): the split of its pattern and the join of the two metrics' frozen
//! values.

use super::pattern::PatternRef;

/// A pattern made of two metrics' patterns one after the other ([`Regularized`](super::Regularized),
/// [`Bent`](super::Bent)):
/// the first metric's rows (a prefix, rows and entries) and the second's with their offsets
/// rebased to their first entry.
pub(crate) struct SplitPattern<'p> {
    /// The first metric's rows.
    pub first: PatternRef<'p>,
    second_offsets: Vec<u32>,
    second_vertices: &'p [u32],
}

impl SplitPattern<'_> {
    /// The second metric's rows, rebased.
    pub fn second(&self) -> PatternRef<'_> {
        PatternRef {
            offsets: &self.second_offsets,
            vertices: self.second_vertices,
        }
    }
}

/// `pattern` split after its first `n_first` residuals ([`SplitPattern`]).
pub(crate) fn split_pattern(pattern: PatternRef<'_>, n_first: usize) -> SplitPattern<'_> {
    let e_first = pattern.offsets[n_first] as usize;
    SplitPattern {
        first: PatternRef {
            offsets: &pattern.offsets[..=n_first],
            vertices: &pattern.vertices[..e_first],
        },
        second_offsets: pattern.offsets[n_first..]
            .iter()
            .map(|o| o - e_first as u32)
            .collect(),
        second_vertices: &pattern.vertices[e_first..],
    }
}

/// Two metrics' frozen values (or pose summaries) one after the other, as a sum of two metrics
/// stores them; `None` when neither has any.
pub(crate) fn join_frozen(first: Option<Vec<f64>>, second: Option<Vec<f64>>) -> Option<Vec<f64>> {
    match (first, second) {
        (Some(mut a), Some(b)) => {
            a.extend_from_slice(&b);
            Some(a)
        }
        (a, b) => a.or(b),
    }
}
