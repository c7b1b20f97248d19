//! Sharded similarity runs for batch systems: shard `K` of `S` computes a deterministic share
//! of the pairs into its own journal (`qcshape similarity --shard K/S -o OUT` writes
//! `OUT.shard-K-of-S`), and [`super::merge_shards`] checks that the shards of one run are all there, come
//! from the same data and settings and cover every pair once, and assembles the matrix
//! (`qcshape similarity-merge`): the same values, bit for bit, as a single run.
//!
//! The split is round-robin over the pairs in row order (pair number `p` of
//! [`super::all_pairs`] goes to shard `p mod S + 1`), so the shards get nearly equal numbers of
//! pairs of every row, and their costs are close even when some deformations are expensive.

use std::collections::HashSet;
use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use super::types::all_pairs;

/// Shard `index` (1-based) of `count`: `K/S` on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Shard {
    /// Which shard, 1..=count.
    pub index: usize,
    /// How many shards the pairs are split into (at least 1).
    pub count: usize,
}

impl Shard {
    /// Shard `index` of `count`, checked (1 <= index <= count).
    pub fn new(index: usize, count: usize) -> Result<Shard, String> {
        if count == 0 || index == 0 || index > count {
            return Err(format!(
                "shard {index}/{count}: expected K/S with 1 <= K <= S (e.g. 1/4 .. 4/4)"
            ));
        }
        Ok(Shard { index, count })
    }

    /// Whether pair number `p` (in the row order of [`super::all_pairs`]) is in this shard.
    pub fn holds(&self, p: usize) -> bool {
        p % self.count + 1 == self.index
    }

    /// How many pairs of `n` deformations this shard computes (`None` if `n (n - 1) / 2`
    /// overflows), without listing them.
    pub fn count_of(&self, n: usize) -> Option<usize> {
        let total = n.checked_mul(n.saturating_sub(1))? / 2;
        Some(total / self.count + usize::from(self.index - 1 < total % self.count))
    }

    /// The pairs `(i, j)`, `i < j`, of `n` deformations that this shard computes, in row order.
    pub fn pairs(&self, n: usize) -> Vec<(usize, usize)> {
        all_pairs(n)
            .into_iter()
            .enumerate()
            .filter(|(p, _)| self.holds(*p))
            .map(|(_, ij)| ij)
            .collect()
    }

    /// The pairs of `n` deformations that other shards compute (to skip in this one).
    pub fn others(&self, n: usize) -> HashSet<(usize, usize)> {
        all_pairs(n)
            .into_iter()
            .enumerate()
            .filter(|(p, _)| !self.holds(*p))
            .map(|(_, ij)| ij)
            .collect()
    }

    /// The file a shard of output `OUT` is written to: `OUT.shard-K-of-S`.
    pub fn file_for(&self, output: &Path) -> PathBuf {
        let mut s = output.as_os_str().to_owned();
        s.push(format!(".shard-{}-of-{}", self.index, self.count));
        PathBuf::from(s)
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl FromStr for Shard {
    type Err = String;

    fn from_str(s: &str) -> Result<Shard, String> {
        let bad = || format!("{s:?}: expected K/S, two whole numbers with 1 <= K <= S (e.g. 2/8)");
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let k = k.trim().parse().map_err(|_| bad())?;
        let n = n.trim().parse().map_err(|_| bad())?;
        Shard::new(k, n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::similarity::all_pairs;

    #[test]
    fn shards_partition_the_pairs_evenly() {
        for n in [2, 3, 7, 20] {
            for count in 1..6 {
                let mut all = Vec::new();
                let sizes: Vec<usize> = (1..=count)
                    .map(|k| {
                        let p = Shard::new(k, count).unwrap().pairs(n);
                        all.extend(p.iter().copied());
                        p.len()
                    })
                    .collect();
                all.sort();
                assert_eq!(all, all_pairs(n), "n {n}, {count} shards");
                let (lo, hi) = (sizes.iter().min().unwrap(), sizes.iter().max().unwrap());
                assert!(hi - lo <= 1, "{sizes:?}");
            }
        }
        assert_eq!("2/8".parse::<Shard>().unwrap(), Shard { index: 2, count: 8 });
        for bad in ["0/3", "4/3", "3", "a/b", "1/0", "-1/2"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
        let f = Shard::new(3, 4).unwrap().file_for(Path::new("out/D.csv"));
        assert_eq!(f, PathBuf::from("out/D.csv.shard-3-of-4"));
    }
}
