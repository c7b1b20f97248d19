//! The merge of a sharded run's journals (`qcshape similarity-merge`): [`merge`] checks that
//! the shards of one run are all there, come from the same data and settings and cover every
//! pair once, and assembles the pairs; [`Merged::matrix`] is the same matrix, bit for bit, as a
//! single run's.

use std::collections::{BTreeMap, HashSet};
use std::path::{Path, PathBuf};

use super::error::{JournalProblem, SimilarityError};
use super::journal::JournalFile;
use super::matrix::{matrix_of, DistanceMatrix, MatrixError};
use super::shard::Shard;
use super::types::PairDistance;

/// The shards of one run, merged.
#[derive(Debug, Clone, PartialEq)]
pub struct Merged {
    /// The deformation names (n), as recorded by the shards.
    pub names: Vec<String>,
    /// Every pair `i < j`, in row order.
    pub pairs: Vec<PairDistance>,
    /// The run's settings string ([`super::settings_key`]).
    pub settings: String,
    /// The number of shards.
    pub count: usize,
}

impl Merged {
    /// The n x n similarity matrix (eq. 13) of the merged pairs.
    pub fn matrix(&self) -> Result<DistanceMatrix, MatrixError> {
        matrix_of(&self.names, &self.pairs)
    }
}

/// Reads the shard journals at `paths` and merges them. Refused, with the file named: a file
/// that is not a shard journal, shards of different runs (another data fingerprint, other
/// settings, another shard count), a shard given twice or missing, a shard whose pairs are not
/// exactly its share (a shard that is still running or was killed: rerun it with `--resume`),
/// and a shard with torn or corrupt records.
pub fn merge(paths: &[PathBuf]) -> Result<Merged, SimilarityError> {
    let err = |path: &Path, problem: JournalProblem| SimilarityError::Journal {
        path: path.to_path_buf(),
        problem,
    };
    let Some(first_path) = paths.first() else {
        return Err(SimilarityError::NoShards);
    };
    let mut shards: BTreeMap<usize, (PathBuf, JournalFile)> = BTreeMap::new();
    let mut first: Option<(Shard, JournalFile)> = None;
    for path in paths {
        let file = JournalFile::read(path)?;
        let Some(shard) = file.shard else {
            return Err(err(path, JournalProblem::WholeRun));
        };
        let Some(names) = &file.names else {
            return Err(err(path, JournalProblem::NoNames));
        };
        if let Some((s0, f0)) = &first {
            let first = first_path.clone();
            let differs = if f0.settings != file.settings {
                Some(JournalProblem::ShardSettings {
                    first,
                    differing: super::journal::differing_settings(&f0.settings, &file.settings),
                })
            } else if f0.key != file.key || f0.names.as_ref() != Some(names) {
                Some(JournalProblem::ShardData { first })
            } else if s0.count != shard.count {
                Some(JournalProblem::ShardCount {
                    first,
                    count: shard.count,
                    first_count: s0.count,
                })
            } else {
                None
            };
            if let Some(problem) = differs {
                return Err(err(path, problem));
            }
        } else {
            first = Some((shard, file.clone()));
        }
        if file.dropped > 0 {
            return Err(err(path, JournalProblem::Torn(file.dropped)));
        }
        // The share's size without listing it: a forged header (n = 70,000) must not make us
        // allocate its pairs when the file holds far fewer records.
        let share = shard
            .count_of(file.n)
            .ok_or_else(|| err(path, JournalProblem::TooLarge(file.n)))?;
        if file.pairs.len() < share {
            return Err(err(
                path,
                JournalProblem::Incomplete {
                    shard,
                    have: file.pairs.len(),
                    want: share,
                },
            ));
        }
        let want: HashSet<(usize, usize)> = shard.pairs(file.n).into_iter().collect();
        let have: HashSet<(usize, usize)> = file.pairs.iter().map(|p| (p.i, p.j)).collect();
        if let Some(&(i, j)) = have.difference(&want).next() {
            return Err(err(path, JournalProblem::ForeignPair { i, j, shard }));
        }
        if have.len() < want.len() {
            return Err(err(
                path,
                JournalProblem::Incomplete {
                    shard,
                    have: have.len(),
                    want: want.len(),
                },
            ));
        }
        if let Some((other, _)) = shards.get(&shard.index) {
            return Err(err(
                path,
                JournalProblem::DuplicateShard {
                    shard,
                    other: other.clone(),
                },
            ));
        }
        shards.insert(shard.index, (path.clone(), file));
    }
    let (shard0, file0) = first.expect("at least one file");
    let missing: Vec<usize> = (1..=shard0.count).filter(|k| !shards.contains_key(k)).collect();
    if !missing.is_empty() {
        return Err(SimilarityError::MissingShards {
            missing,
            count: shard0.count,
            run: first_path.to_path_buf(),
        });
    }
    let mut pairs: Vec<PairDistance> = shards.into_values().flat_map(|(_, f)| f.pairs).collect();
    pairs.sort_by_key(|p| (p.i, p.j));
    Ok(Merged {
        names: file0.names.expect("checked"),
        pairs,
        settings: file0.settings,
        count: shard0.count,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::similarity::{all_pairs, Journal};

    fn pair(i: usize, j: usize) -> PairDistance {
        let d = (i * 10 + j) as f64 / 7.0;
        PairDistance {
            i,
            j,
            distance: d,
            per_pose: vec![0.0, d],
            per_pose_energy: Some(vec![[0.0, 0.0], [0.9 * d, 0.1 * d]]),
            converged: true,
            iterations: 3,
            seconds: 0.5,
        }
    }

    fn write_shards(dir: &Path, n: usize, count: usize, names: &[String], settings: &str) -> Vec<PathBuf> {
        (1..=count)
            .map(|k| {
                let shard = Shard::new(k, count).unwrap();
                let path = shard.file_for(&dir.join("D.csv"));
                let (j, _) = Journal::open_shard(&path, 99, settings, names, None, shard, false).unwrap();
                for (i, jj) in shard.pairs(n) {
                    j.record(&pair(i, jj)).unwrap();
                }
                path
            })
            .collect()
    }

    /// A forged header naming 70,000 deformations (about 2.4e9 pairs) is refused from the
    /// record count, without listing the pairs.
    #[test]
    fn a_forged_shard_header_does_not_allocate_its_pairs() {
        let dir = tempfile::tempdir().unwrap();
        let n = 70_000;
        let names: Vec<String> = (0..n).map(|k| format!("d{k}")).collect();
        let p = dir.path().join("D.csv.shard-1-of-2");
        let text = format!(
            "{}\nkey,0000000000000001\nn,{n}\nsettings,m=a\nshard,1/2\nnames,{}\n",
            crate::similarity::error::HEADER,
            serde_json::to_string(&names).unwrap()
        );
        std::fs::write(&p, text).unwrap();
        let t = std::time::Instant::now();
        let e = merge(std::slice::from_ref(&p)).unwrap_err().to_string();
        assert!(e.contains("incomplete") && e.contains("0 of its"), "{e}");
        assert!(t.elapsed().as_secs_f64() < 5.0);
    }

    #[test]
    fn merge_assembles_complete_shards_and_refuses_the_rest() {
        let dir = tempfile::tempdir().unwrap();
        let n = 5;
        let names: Vec<String> = (0..n).map(|k| format!("d,{k}\"")).collect();
        let paths = write_shards(dir.path(), n, 3, &names, "m=a");
        let m = merge(&paths).unwrap();
        assert_eq!(m.names, names);
        assert_eq!(
            m.pairs,
            all_pairs(n)
                .into_iter()
                .map(|(i, j)| pair(i, j))
                .collect::<Vec<_>>()
        );
        // Order of the files does not matter.
        let mut rev = paths.clone();
        rev.reverse();
        assert_eq!(merge(&rev).unwrap(), m);
        // A missing shard, a shard given twice.
        let e = merge(&paths[..2]).unwrap_err().to_string();
        assert!(e.contains("3/3") && e.contains("missing"), "{e}");
        let e = merge(&[paths[0].clone(), paths[0].clone(), paths[1].clone()])
            .unwrap_err()
            .to_string();
        assert!(e.contains("also given"), "{e}");
        // Another run's shard (other settings).
        let other = tempfile::tempdir().unwrap();
        let p2 = write_shards(other.path(), n, 3, &names, "m=b");
        let e = merge(&[paths[0].clone(), paths[1].clone(), p2[2].clone()])
            .unwrap_err()
            .to_string();
        assert!(e.contains("another run") && e.contains("m b (not a)"), "{e}");
        // An incomplete shard: one record cut off.
        let text = std::fs::read_to_string(&paths[1]).unwrap();
        let cut: Vec<&str> = text.lines().collect();
        std::fs::write(&paths[1], cut[..cut.len() - 1].join("\n") + "\n").unwrap();
        let e = merge(&paths).unwrap_err().to_string();
        assert!(e.contains("incomplete") && e.contains("--resume"), "{e}");
        // A torn record.
        std::fs::write(&paths[1], text.clone() + "pair,0,1,0.5,tr").unwrap();
        let e = merge(&paths).unwrap_err().to_string();
        assert!(e.contains("torn"), "{e}");
        // A whole-run journal is not a shard.
        let whole = dir.path().join("D.csv.journal");
        Journal::open(&whole, 99, "m=a", n, None, false).unwrap();
        let e = merge(&[whole]).unwrap_err().to_string();
        assert!(e.contains("not of a shard"), "{e}");
    }

    /// Shard files of version 2 (no energy field) still merge; their pairs have no energy
    /// split, and shards of both versions merge together.
    #[test]
    fn version_2_shards_still_merge() {
        let dir = tempfile::tempdir().unwrap();
        let n = 4;
        let names: Vec<String> = (0..n).map(|k| format!("d{k}")).collect();
        let paths = write_shards(dir.path(), n, 2, &names, "m=a");
        // Rewrite shard 1 as version 2: the old header, the pair lines without their last
        // field (each with its own check).
        let text = std::fs::read_to_string(&paths[0]).unwrap();
        let old: Vec<String> = text
            .lines()
            .map(|l| {
                if let Some(first) = l.strip_prefix("# qcshape similarity journal v3") {
                    format!("# qcshape similarity journal v2{first}")
                } else if l.starts_with("pair,") {
                    let body = l.rsplit_once(",#").unwrap().0;
                    let body = body.rsplit_once(',').unwrap().0;
                    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
                    for b in body.bytes() {
                        h ^= b as u64;
                        h = h.wrapping_mul(0x0000_0100_0000_01b3);
                    }
                    format!("{body},#{h:016x}")
                } else {
                    l.to_string()
                }
            })
            .collect();
        std::fs::write(&paths[0], old.join("\n") + "\n").unwrap();
        let m = merge(&paths).unwrap();
        let s1 = Shard::new(1, 2).unwrap();
        for p in &m.pairs {
            let want = pair(p.i, p.j);
            assert_eq!((p.distance, &p.per_pose), (want.distance, &want.per_pose));
            if s1.pairs(n).contains(&(p.i, p.j)) {
                assert_eq!(p.per_pose_energy, None);
            } else {
                assert_eq!(p.per_pose_energy, want.per_pose_energy);
            }
        }
        assert_eq!(m.pairs.len(), 6);
    }

    #[test]
    fn a_shard_resumes_only_its_own_journal() {
        let dir = tempfile::tempdir().unwrap();
        let names: Vec<String> = (0..4).map(|k| k.to_string()).collect();
        let s1 = Shard::new(1, 2).unwrap();
        let path = dir.path().join("x");
        let (j, _) = Journal::open_shard(&path, 5, "s", &names, None, s1, false).unwrap();
        j.record(&pair(0, 1)).unwrap();
        drop(j);
        let (_, done) = Journal::open_shard(&path, 5, "s", &names, None, s1, true).unwrap();
        assert_eq!(done, vec![pair(0, 1)]);
        let e =
            Journal::open_shard(&path, 5, "s", &names, None, Shard::new(2, 2).unwrap(), true).unwrap_err();
        assert!(e.to_string().contains("shard 1/2"), "{e}");
        let e = Journal::open(&path, 5, "s", 4, None, true).unwrap_err();
        assert!(e.to_string().contains("whole matrix"), "{e}");
    }
}
