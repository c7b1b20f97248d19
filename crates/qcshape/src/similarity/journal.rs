//! A journal of finished pairs, so that an interrupted similarity run can be resumed without
//! recomputing them (`qcshape similarity --resume`).
//!
//! The journal is a text file: a header line, a `key` line that fingerprints the inputs and
//! the settings, an `n` line (the number of deformations), a `settings` line (the settings in
//! words, to name what differs when a journal is refused), then one `pair` line per finished
//! pair, appended and flushed as soon as the pair is done. Every pair line ends with
//! `,#<16 hex digits>`, the FNV-1a hash of the text before it: a record torn by a kill or a full
//! disk, or changed on disk, fails its check and is dropped (and recomputed) on resume, and so
//! is a record that passes its check but holds what no run writes (another pose count than the
//! run's, a value out of its range, a distance that is not its poses' sum, a repeated pair):
//! [`Journal::dropped_records`] names each with its line and reason. A journal whose key differs
//! from the current run's is never reused.
//!
//! A pair line is `pair,I,J,DISTANCE,CONVERGED,ITERATIONS,SECONDS,PER_POSE,ENERGY,#CHECK`:
//! `PER_POSE` the pose distances separated by `;`, `ENERGY` the energy split of every pose's
//! path ([`PairDistance::per_pose_energy`]) as `geometric:regularizer` separated by `;`, or
//! empty when unknown (tangent mode). Floats are written with Rust's shortest round-trip
//! formatting, so they read back bit for bit. Version 3 (this one) added the `ENERGY` field;
//! journals and shard files of version 2 (header `# qcshape similarity journal v2`, pair lines
//! without it) still load, their pairs without an energy split (`None`), and are rewritten as
//! version 3 when resumed. Earlier qcshape releases refuse version 3 files.

use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use super::error::{JournalProblem, SimilarityError, HEADER, HEADER_V2};
use super::shard::Shard;
use super::types::{DroppedRecord, PairDistance, Pose, RecordProblem};

/// FNV-1a 64-bit hash of the names, every coordinate's bits and a settings string (metric,
/// solver options, scale): identical inputs give the same key on every machine and version.
pub fn fingerprint(names: &[String], deformations: &[Vec<Pose>], settings: &str) -> u64 {
    let mut h = Fnv::new();
    let mut eat = |bytes: &[u8]| h.eat(bytes);
    eat(settings.as_bytes());
    for (name, poses) in names.iter().zip(deformations) {
        eat(name.as_bytes());
        eat(&[0]);
        for pose in poses {
            eat(&(pose.len() as u64).to_le_bytes());
            for v in pose {
                for c in v {
                    eat(&c.to_bits().to_le_bytes());
                }
            }
        }
    }
    h.0
}

/// FNV-1a, 64 bits.
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    fn eat(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.0 ^= *b as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
}

/// The check of one record's text (without its `,#...` suffix).
fn checksum(text: &str) -> u64 {
    let mut h = Fnv::new();
    h.eat(text.as_bytes());
    h.0
}

/// An open journal that records pairs as they finish (safe to call from several threads).
#[derive(Debug)]
pub struct Journal {
    path: PathBuf,
    file: Mutex<File>,
    dropped: Vec<DroppedRecord>,
}

/// Whether a journal may be written at `path`: nothing is there, an empty file, or a file that
/// starts with a journal header (of any version). Anything else is someone's data.
fn replaceable(path: &Path) -> bool {
    use std::io::Read;
    let Ok(meta) = std::fs::symlink_metadata(path) else {
        return true;
    };
    if !meta.is_file() {
        return false;
    }
    let mut head = Vec::with_capacity(64);
    match File::open(path).and_then(|f| f.take(64).read_to_end(&mut head)) {
        Ok(0) => true,
        Ok(_) => head.starts_with(b"# qcshape similarity journal"),
        Err(_) => false,
    }
}

impl Journal {
    /// Opens the journal at `path` for a run with fingerprint `key` over `n` deformations of
    /// `poses` poses each (`None`: not checked);
    /// `settings` is the run's settings string (see [`super::settings_key`]), kept in the
    /// journal to name the settings that differ when a journal is refused.
    ///
    /// With `resume`, an existing journal with the same key is kept and its finished pairs are
    /// returned (records that fail their check are dropped: [`Journal::dropped`]); a journal with
    /// another key is an error (it belongs to another run). Without `resume` (or when no journal
    /// exists) a new one is started.
    pub fn open(
        path: &Path,
        key: u64,
        settings: &str,
        n: usize,
        poses: Option<usize>,
        resume: bool,
    ) -> Result<(Journal, Vec<PairDistance>), SimilarityError> {
        Self::open_with(
            path,
            &Head {
                key,
                n,
                poses,
                settings,
                shard: None,
                names: None,
            },
            resume,
        )
    }

    /// Opens the journal of shard `shard` of a sharded run (`qcshape similarity --shard K/S`):
    /// as [`Journal::open`], and the file also records the shard and the deformation `names`
    /// (n), so that [`super::merge_shards`] can check and assemble the shards without the data.
    pub fn open_shard(
        path: &Path,
        key: u64,
        settings: &str,
        names: &[String],
        poses: Option<usize>,
        shard: Shard,
        resume: bool,
    ) -> Result<(Journal, Vec<PairDistance>), SimilarityError> {
        let head = Head {
            key,
            n: names.len(),
            poses,
            settings,
            shard: Some(shard),
            names: Some(names),
        };
        Self::open_with(path, &head, resume)
    }

    fn open_with(
        path: &Path,
        head: &Head,
        resume: bool,
    ) -> Result<(Journal, Vec<PairDistance>), SimilarityError> {
        let err = |problem: JournalProblem| SimilarityError::Journal {
            path: path.to_path_buf(),
            problem,
        };
        if head.settings.contains('\n') {
            return Err(err(JournalProblem::SettingsLineBreak));
        }
        if !replaceable(path) {
            return Err(err(JournalProblem::NotReplaceable));
        }
        let (mut done, mut dropped) = (Vec::new(), Vec::new());
        if resume && path.exists() {
            (done, dropped) = read(path, head)?;
        }
        // Write the header and the valid pairs to a new file that replaces the old one in one
        // rename: a torn or corrupt record is dropped, and no kill loses pairs.
        let mut text = format!(
            "{HEADER}\nkey,{:016x}\nn,{}\nsettings,{}\n",
            head.key, head.n, head.settings
        );
        if let Some(shard) = head.shard {
            text.push_str(&format!("shard,{shard}\n"));
        }
        if let Some(names) = head.names {
            let json = serde_json::to_string(names).map_err(|e| err(JournalProblem::EncodeNames(e)))?;
            text.push_str(&format!("names,{json}\n"));
        }
        for p in &done {
            text.push_str(&line(p));
        }
        let tmp = path.with_extension("journal-tmp");
        std::fs::write(&tmp, text).map_err(|error| {
            err(JournalProblem::WriteTemporary {
                tmp: tmp.clone(),
                error,
            })
        })?;
        std::fs::rename(&tmp, path).map_err(|e| err(JournalProblem::Write(e)))?;
        let file = OpenOptions::new()
            .append(true)
            .open(path)
            .map_err(|e| err(JournalProblem::Append(e)))?;
        let journal = Journal {
            path: path.to_path_buf(),
            file: Mutex::new(file),
            dropped,
        };
        Ok((journal, done))
    }

    fn error(&self, problem: JournalProblem) -> SimilarityError {
        SimilarityError::Journal {
            path: self.path.clone(),
            problem,
        }
    }

    /// Appends one finished pair and flushes it to the file.
    pub fn record(&self, pair: &PairDistance) -> Result<(), SimilarityError> {
        let mut f = self.file.lock().unwrap_or_else(|p| p.into_inner());
        f.write_all(line(pair).as_bytes())
            .and_then(|_| f.flush())
            .map_err(|e| self.error(JournalProblem::Append(e)))
    }

    /// The number of records of the resumed journal that were dropped, so that their pairs are
    /// recomputed: torn or corrupt (failed their check), malformed, out of range, of another
    /// pose count, or repeating a pair ([`Journal::dropped_records`] names them).
    pub fn dropped(&self) -> usize {
        self.dropped.len()
    }

    /// The records of the resumed journal that were dropped, each with its line and reason.
    pub fn dropped_records(&self) -> &[DroppedRecord] {
        &self.dropped
    }

    /// The journal's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Deletes the journal (after the complete result is written).
    pub fn remove(self) -> Result<(), SimilarityError> {
        let path = self.path.clone();
        drop(self.file);
        std::fs::remove_file(&path).map_err(|e| SimilarityError::Journal {
            path,
            problem: JournalProblem::Remove(e),
        })
    }
}

fn line(p: &PairDistance) -> String {
    let per: Vec<String> = p.per_pose.iter().map(|d| format!("{d:?}")).collect();
    let energy: Vec<String> = p
        .per_pose_energy
        .iter()
        .flatten()
        .map(|[g, r]| format!("{g:?}:{r:?}"))
        .collect();
    let body = format!(
        "pair,{},{},{:?},{},{},{:?},{},{}",
        p.i,
        p.j,
        p.distance,
        p.converged,
        p.iterations,
        p.seconds,
        per.join(";"),
        energy.join(";")
    );
    let check = checksum(&body);
    format!("{body},#{check:016x}\n")
}

/// One record, if it is whole (its check matches), well formed, of `poses` pose distances (when
/// given), and every value in its range: distances, energies and seconds finite and >= 0, the
/// distance the sum of the pose distances. Otherwise the pair (when readable) and the reason.
fn parse_pair(
    text: &str,
    n: usize,
    poses: Option<usize>,
) -> Result<PairDistance, (Option<(usize, usize)>, RecordProblem)> {
    let (body, check) = text.rsplit_once(",#").ok_or((None, RecordProblem::Checksum))?;
    if check.len() != 16 || u64::from_str_radix(check, 16).ok() != Some(checksum(body)) {
        return Err((None, RecordProblem::Checksum));
    }
    let malformed = |field, expected| RecordProblem::Malformed { field, expected };
    let f: Vec<&str> = body.split(',').collect();
    // Version 2 records have 8 fields (no energy split), version 3 records 9.
    if !(f.len() == 8 || f.len() == 9) || f[0] != "pair" {
        return Err((
            None,
            malformed(
                "record",
                "pair,I,J,DISTANCE,CONVERGED,ITERATIONS,SECONDS,PER_POSE,ENERGY",
            ),
        ));
    }
    let i: usize = f[1].parse().map_err(|_| (None, malformed("I", "a count")))?;
    let j: usize = f[2].parse().map_err(|_| (None, malformed("J", "a count")))?;
    let at = Some((i, j));
    let bad = |problem| (at, problem);
    if i >= j || j >= n {
        return Err(bad(RecordProblem::NotAPair { i, j, n }));
    }
    let number = |field: &'static str, s: &str| -> Result<f64, (Option<(usize, usize)>, RecordProblem)> {
        let v: f64 = s.parse().map_err(|_| bad(malformed(field, "a number")))?;
        if v.is_finite() && v >= 0.0 {
            Ok(v)
        } else {
            Err(bad(RecordProblem::Range { field, value: v }))
        }
    };
    let per_pose: Vec<f64> = f[7]
        .split(';')
        .map(|s| number("pose distance", s))
        .collect::<Result<_, _>>()?;
    if let Some(k) = poses.filter(|k| *k != per_pose.len()) {
        return Err(bad(RecordProblem::PoseCount {
            found: per_pose.len(),
            expected: k,
        }));
    }
    let distance = number("distance", f[3])?;
    let sum: f64 = per_pose.iter().sum();
    if (distance - sum).abs() > 1e-12 * sum.max(1.0) {
        return Err(bad(RecordProblem::Sum { distance, sum }));
    }
    let per_pose_energy = match f.get(8) {
        None | Some(&"") => None,
        Some(text) => {
            let parts: Vec<[f64; 2]> = text
                .split(';')
                .map(|gr| {
                    let (g, r) = gr
                        .split_once(':')
                        .ok_or_else(|| bad(malformed("energy", "geometric:regularizer")))?;
                    Ok([number("geometric energy", g)?, number("regularizer energy", r)?])
                })
                .collect::<Result<_, _>>()?;
            if parts.len() != per_pose.len() {
                return Err(bad(RecordProblem::EnergyCount {
                    found: parts.len(),
                    expected: per_pose.len(),
                }));
            }
            Some(parts)
        }
    };
    Ok(PairDistance {
        i,
        j,
        distance,
        per_pose,
        per_pose_energy,
        converged: f[4]
            .parse()
            .map_err(|_| bad(malformed("CONVERGED", "true or false")))?,
        iterations: f[5]
            .parse()
            .map_err(|_| bad(malformed("ITERATIONS", "a count")))?,
        seconds: number("seconds", f[6])?,
    })
}

/// The fixed lines of a journal: what identifies the run (and, for a shard, which shard).
struct Head<'a> {
    key: u64,
    n: usize,
    /// The run's pose count, when known: a record with another is dropped.
    poses: Option<usize>,
    settings: &'a str,
    shard: Option<Shard>,
    names: Option<&'a [String]>,
}

/// Everything a journal file holds, read without judging whose run it belongs to.
#[derive(Debug, Clone, PartialEq)]
pub struct JournalFile {
    /// The run's fingerprint ([`fingerprint`]).
    pub key: u64,
    /// The number of deformations.
    pub n: usize,
    /// The run's settings string ([`super::settings_key`]).
    pub settings: String,
    /// The shard, for the journal of a sharded run.
    pub shard: Option<Shard>,
    /// The deformation names (n), recorded by sharded runs.
    pub names: Option<Vec<String>>,
    /// The whole records, in file order, without repeats.
    pub pairs: Vec<PairDistance>,
    /// Records dropped: torn, corrupt (failed their check), malformed, out of range, of
    /// another pose count than given to [`JournalFile::read_checked`], or repeated.
    pub dropped: usize,
    /// The dropped records, each with its line and reason.
    pub dropped_records: Vec<DroppedRecord>,
}

impl JournalFile {
    /// Reads the journal at `path`; every record of a pair is checked for its fields' ranges
    /// (and its pose count against the other records' is not: see [`JournalFile::read_checked`]).
    pub fn read(path: &Path) -> Result<JournalFile, SimilarityError> {
        Self::read_checked(path, None)
    }

    /// [`JournalFile::read`], with every record's pose count checked against `poses` (the
    /// run's), when given.
    pub fn read_checked(path: &Path, poses: Option<usize>) -> Result<JournalFile, SimilarityError> {
        let err = |problem: JournalProblem| SimilarityError::Journal {
            path: path.to_path_buf(),
            problem,
        };
        let bytes = crate::limits::read_regular_file(path, crate::limits::MAX_TABLE_FILE_BYTES)
            .map_err(|e| err(JournalProblem::Read(e)))?;
        let lines: Vec<String> = bytes
            .split(|&b| b == b'\n')
            .map(|l| String::from_utf8_lossy(l).into_owned())
            .collect();
        if lines.len() < 4 || !(lines[0] == HEADER || lines[0] == HEADER_V2) {
            return Err(err(JournalProblem::NotAJournal));
        }
        let key = lines[1]
            .strip_prefix("key,")
            .and_then(|k| u64::from_str_radix(k, 16).ok())
            .ok_or_else(|| {
                err(JournalProblem::HeaderLine {
                    line: 2,
                    expected: "key,<16 hex digits>",
                    found: lines[1].clone(),
                })
            })?;
        let n = lines[2]
            .strip_prefix("n,")
            .and_then(|k| k.parse().ok())
            .ok_or_else(|| {
                err(JournalProblem::HeaderLine {
                    line: 3,
                    expected: "n,<count>",
                    found: lines[2].clone(),
                })
            })?;
        let settings = lines[3]
            .strip_prefix("settings,")
            .ok_or_else(|| {
                err(JournalProblem::HeaderLine {
                    line: 4,
                    expected: "settings,...",
                    found: lines[3].clone(),
                })
            })?
            .to_string();
        let mut file = JournalFile {
            key,
            n,
            settings,
            shard: None,
            names: None,
            pairs: Vec::new(),
            dropped: 0,
            dropped_records: Vec::new(),
        };
        let mut seen = std::collections::HashSet::new();
        for (k, raw) in lines.iter().enumerate().skip(4) {
            if raw.is_empty() {
                continue;
            }
            if let Some(s) = raw.strip_prefix("shard,") {
                let shard = s.parse().map_err(|_: String| {
                    err(JournalProblem::ShardLine {
                        line: k + 1,
                        found: s.to_string(),
                    })
                })?;
                file.shard = Some(shard);
            } else if let Some(json) = raw.strip_prefix("names,") {
                let names: Vec<String> = serde_json::from_str(json)
                    .map_err(|error| err(JournalProblem::NamesLine { line: k + 1, error }))?;
                if names.len() != n {
                    return Err(err(JournalProblem::NameCount {
                        line: k + 1,
                        names: names.len(),
                        n,
                    }));
                }
                file.names = Some(names);
            } else {
                let record = parse_pair(raw, n, poses).and_then(|p| {
                    if seen.insert((p.i, p.j)) {
                        Ok(p)
                    } else {
                        Err((Some((p.i, p.j)), RecordProblem::Repeated))
                    }
                });
                match record {
                    Ok(p) => file.pairs.push(p),
                    Err((pair, problem)) => {
                        file.dropped += 1;
                        file.dropped_records.push(DroppedRecord {
                            line: k + 1,
                            pair,
                            problem,
                        });
                    }
                }
            }
        }
        Ok(file)
    }
}

/// The whole records of a journal to resume with `head`, and the records dropped.
fn read(path: &Path, head: &Head) -> Result<(Vec<PairDistance>, Vec<DroppedRecord>), SimilarityError> {
    let err = |problem: JournalProblem| SimilarityError::Journal {
        path: path.to_path_buf(),
        problem,
    };
    let file = JournalFile::read_checked(path, head.poses).map_err(|e| match e {
        SimilarityError::Journal { path, problem } => SimilarityError::Journal {
            path,
            problem: JournalProblem::NotResumable(Box::new(problem)),
        },
        e => e,
    })?;
    let n = head.n;
    if file.n != n {
        return Err(err(JournalProblem::OtherCount {
            journal: file.n,
            run: n,
        }));
    }
    if file.key != head.key {
        let differ = differing_settings(&file.settings, head.settings);
        return Err(err(if differ.is_empty() {
            JournalProblem::OtherInputs
        } else {
            JournalProblem::OtherSettings(differ)
        }));
    }
    if file.shard != head.shard {
        return Err(err(JournalProblem::OtherShard {
            journal: file.shard,
            run: head.shard,
        }));
    }
    Ok((file.pairs, file.dropped_records))
}

/// The settings in which two settings strings differ, as `(name, value in a, value in b)`:
/// the `|`-separated fields, and inside a field such as the metric's `MetricSpec { kind: ..,
/// lambda: .. }` each `name: value` part, so that a message names `lambda` rather than
/// printing both structures.
pub(crate) fn differing_settings(a: &str, b: &str) -> Vec<(String, String, String)> {
    fn parts(s: &str) -> Vec<&str> {
        s.split(['|', ',', '{', '}', '(', ')'])
            .map(str::trim)
            .filter(|p| !p.is_empty())
            .collect()
    }
    fn split(p: &str) -> (&str, &str) {
        p.split_once('=')
            .or_else(|| p.split_once(": "))
            .map_or(("setting", p), |(n, v)| (n.trim(), v.trim()))
    }
    let (pa, pb) = (parts(a), parts(b));
    if pa.len() != pb.len() {
        return vec![("settings".into(), format!("{a:?}"), format!("{b:?}"))];
    }
    pa.iter()
        .zip(&pb)
        .filter(|(x, y)| x != y)
        .map(|(x, y)| {
            let ((nx, vx), (ny, vy)) = (split(x), split(y));
            if nx == ny {
                (nx.to_string(), vx.to_string(), vy.to_string())
            } else {
                ("setting".to_string(), x.to_string(), y.to_string())
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pair(i: usize, j: usize, d: f64) -> PairDistance {
        PairDistance {
            i,
            j,
            distance: d,
            per_pose: vec![0.0, d / 3.0, 2.0 * d / 3.0],
            per_pose_energy: Some(vec![[0.0, 0.0], [d / 7.0, d * 1e-3], [0.1 + d, 1.0 / 3.0]]),
            converged: true,
            iterations: 7,
            seconds: 0.25,
        }
    }

    #[test]
    fn differing_settings_are_named_inside_the_metric() {
        let a = "MetricSpec { kind: Isometric, scale: Calibrated, lambda: 0.01 }|steps=8|insert=0";
        let b = "MetricSpec { kind: Isometric, scale: Calibrated, lambda: 0.1 }|steps=8|insert=2";
        assert_eq!(
            differing_settings(a, b),
            vec![
                ("lambda".to_string(), "0.01".to_string(), "0.1".to_string()),
                ("insert".to_string(), "0".to_string(), "2".to_string())
            ]
        );
    }

    #[test]
    fn a_file_that_is_not_a_journal_is_never_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("data.csv");
        std::fs::write(&path, "name,value\na,1\n").unwrap();
        for resume in [false, true] {
            let e = Journal::open(&path, 1, "s", 3, None, resume)
                .unwrap_err()
                .to_string();
            assert!(
                e.contains("data.csv") && e.contains("not a qcshape similarity journal"),
                "{e}"
            );
        }
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "name,value\na,1\n");
        // A folder is refused too; an empty file and an old journal are replaced.
        assert!(Journal::open(dir.path(), 1, "s", 3, None, false).is_err());
        std::fs::write(&path, "").unwrap();
        drop(Journal::open(&path, 1, "s", 3, None, false).unwrap());
        drop(Journal::open(&path, 2, "t", 3, None, false).unwrap());
    }

    #[test]
    fn records_survive_a_partial_last_line_and_keys_must_match() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.journal");
        let (j, done) = Journal::open(&path, 42, "m=a|s=4", 4, None, true).unwrap();
        assert!(done.is_empty());
        let a = pair(0, 1, 0.1 + 0.2);
        let b = pair(1, 3, std::f64::consts::PI);
        j.record(&a).unwrap();
        j.record(&b).unwrap();
        drop(j);
        // Simulate a kill in the middle of a write.
        let mut f = OpenOptions::new().append(true).open(&path).unwrap();
        f.write_all(b"pair,2,3,0.5,tr").unwrap();
        drop(f);
        let (j, done) = Journal::open(&path, 42, "m=a|s=4", 4, None, true).unwrap();
        assert_eq!(done, vec![a.clone(), b.clone()]); // bit-exact floats
        assert_eq!(j.dropped(), 1);
        let c = pair(2, 3, 1.5);
        j.record(&c).unwrap();
        drop(j);
        let (j, done) = Journal::open(&path, 42, "m=a|s=4", 4, None, true).unwrap();
        assert_eq!(done, vec![a, b, c]);
        assert_eq!(j.dropped(), 0);
        drop(j);
        // Another run's key or size is refused, not silently reused, naming what differs.
        let e = Journal::open(&path, 43, "m=b|s=4", 4, None, true).unwrap_err();
        assert!(
            e.to_string().contains("another run") && e.to_string().contains("m: journal a, now b"),
            "{e}"
        );
        let e = Journal::open(&path, 43, "m=a|s=4", 4, None, true).unwrap_err();
        assert!(e.to_string().contains("different inputs"), "{e}");
        assert!(Journal::open(&path, 42, "m=a|s=4", 5, None, true).is_err());
        // Without resume a fresh journal is started.
        let (j, done) = Journal::open(&path, 43, "m=a|s=4", 4, None, false).unwrap();
        assert!(done.is_empty());
        j.remove().unwrap();
        assert!(!path.exists());
    }

    #[test]
    fn every_cut_of_the_last_record_and_a_changed_digit_are_dropped() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.journal");
        let (j, _) = Journal::open(&path, 7, "x", 3, None, false).unwrap();
        let a = pair(0, 1, 1.164056);
        let b = PairDistance {
            per_pose: vec![0.0, 1.164056789, 2.5],
            per_pose_energy: None,
            ..pair(0, 2, 3.664056789)
        };
        j.record(&a).unwrap();
        j.record(&b).unwrap();
        drop(j);
        let whole = std::fs::read(&path).unwrap();
        let last = line(&b).len();
        for cut in whole.len() - last..whole.len() {
            std::fs::write(&path, &whole[..cut]).unwrap();
            let (j, done) = Journal::open(&path, 7, "x", 3, None, true).unwrap();
            // A record is whole when nothing but its newline is missing.
            if cut == whole.len() - 1 {
                assert_eq!(done, vec![a.clone(), b.clone()], "cut at {cut}");
                assert_eq!(j.dropped(), 0);
            } else {
                assert_eq!(done, vec![a.clone()], "cut at {cut}");
                let torn = usize::from(cut > whole.len() - last);
                assert_eq!(j.dropped(), torn, "cut at {cut}");
            }
        }
        // One changed digit in a middle record: dropped, the rest kept.
        let text = String::from_utf8(whole)
            .unwrap()
            .replacen("1.164056,", "1.164057,", 1);
        std::fs::write(&path, text).unwrap();
        let (j, done) = Journal::open(&path, 7, "x", 3, None, true).unwrap();
        assert_eq!(done, vec![b]);
        assert_eq!(j.dropped(), 1);
    }

    /// The energy split survives a resume bit for bit (known, unknown, extreme values), and a
    /// split that does not match the pose count or is not a number drops the record.
    #[test]
    fn energy_parts_round_trip_and_bad_parts_are_dropped() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.journal");
        let (j, _) = Journal::open(&path, 9, "s", 4, None, false).unwrap();
        let a = PairDistance {
            per_pose_energy: Some(vec![
                [0.0, 0.0],
                [f64::MIN_POSITIVE, 1e300],
                [0.1 + 0.2, std::f64::consts::E],
            ]),
            ..pair(0, 1, 0.7)
        };
        let tangent = PairDistance {
            per_pose_energy: None,
            ..pair(1, 2, 0.9)
        };
        j.record(&a).unwrap();
        j.record(&tangent).unwrap();
        drop(j);
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.starts_with("# qcshape similarity journal v3\n"), "{text}");
        assert!(
            text.contains(";0.30000000000000004:2.718281828459045,#"),
            "{text}"
        );
        let (j, done) = Journal::open(&path, 9, "s", 4, None, true).unwrap();
        assert_eq!(done, vec![a.clone(), tangent.clone()]);
        assert_eq!(done[0].regularizer_share(), a.regularizer_share());
        assert_eq!(done[1].regularizer_share(), None);
        assert_eq!(j.dropped(), 0);
        // Records with a well-formed check but a bad split: two parts for three poses, a
        // missing regularizer, a NaN.
        let mut f = OpenOptions::new().append(true).open(&path).unwrap();
        for energy in [
            "0.0:0.0;1.0:2.0",
            "0.0:0.0;1.0;2.0:3.0",
            "0.0:0.0;NaN:1.0;1.0:1.0",
        ] {
            let body = format!("pair,2,3,1.5,true,3,0.5,0.0;0.5;1.0,{energy}");
            writeln!(f, "{body},#{:016x}", checksum(&body)).unwrap();
        }
        drop((f, j));
        let (j, done) = Journal::open(&path, 9, "s", 4, None, true).unwrap();
        assert_eq!(done, vec![a, tangent]);
        assert_eq!(j.dropped(), 3);
    }

    /// Records with a valid check but values no run writes are dropped, each named with its
    /// line and reason, and their pairs recomputed (issue 60 item 4): one pose distance where
    /// three are due, a negative or infinite value, a distance that is not its poses' sum, a
    /// repeated pair. The first whole record of a pair is the one kept.
    #[test]
    fn forged_records_with_a_valid_check_are_dropped_and_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.journal");
        let (j, _) = Journal::open(&path, 5, "s", 4, Some(3), false).unwrap();
        let good = pair(0, 3, 1.5);
        j.record(&good).unwrap();
        drop(j);
        let mut f = OpenOptions::new().append(true).open(&path).unwrap();
        for body in [
            "pair,0,1,1.5,true,3,0.5,1.5,0.5:0.5",
            "pair,0,2,1.5,true,3,0.5,0.0;-0.5;2.0,",
            "pair,1,2,1.5,true,3,0.5,0.0;0.5;inf,",
            "pair,1,3,9.5,true,3,0.5,0.0;0.5;1.0,",
            "pair,2,3,1.5,true,3,-1,0.0;0.5;1.0,",
            "pair,0,3,1.5,true,3,0.5,0.0;0.5;1.0,",
        ] {
            writeln!(f, "{body},#{:016x}", checksum(body)).unwrap();
        }
        drop(f);
        let (j, done) = Journal::open(&path, 5, "s", 4, Some(3), true).unwrap();
        assert_eq!(done, vec![good]);
        let named: Vec<String> = j.dropped_records().iter().map(|d| d.to_string()).collect();
        assert_eq!(
            named,
            [
                "the record on line 6 (pair 0, 1): 1 pose distance(s) where the run has 3 poses",
                "the record on line 7 (pair 0, 2): pose distance = -0.5 is out of range (finite and >= 0)",
                "the record on line 8 (pair 1, 2): pose distance = inf is out of range (finite and >= 0)",
                "the record on line 9 (pair 1, 3): distance 9.5 is not the sum of its pose distances (1.5)",
                "the record on line 10 (pair 2, 3): seconds = -1.0 is out of range (finite and >= 0)",
                "the record on line 11 (pair 0, 3): repeats a pair recorded before",
            ]
        );
        // The rewritten journal holds the good record only: a second resume drops nothing.
        drop(j);
        let (j, done) = Journal::open(&path, 5, "s", 4, Some(3), true).unwrap();
        assert_eq!((done.len(), j.dropped()), (1, 0));
    }

    /// A journal of version 2 (no energy field) still resumes: its pairs come back without
    /// an energy split, and the rewritten journal is version 3.
    #[test]
    fn version_2_journals_still_load() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.journal");
        let body = "pair,0,2,1.25,true,11,0.5,0.0;0.5;0.75";
        let text = format!(
            "# qcshape similarity journal v2\nkey,{:016x}\nn,3\nsettings,m=a\n{body},#{:016x}\n",
            77,
            checksum(body)
        );
        std::fs::write(&path, text).unwrap();
        let file = JournalFile::read(&path).unwrap();
        let want = PairDistance {
            i: 0,
            j: 2,
            distance: 1.25,
            per_pose: vec![0.0, 0.5, 0.75],
            per_pose_energy: None,
            converged: true,
            iterations: 11,
            seconds: 0.5,
        };
        assert_eq!((file.pairs.clone(), file.dropped), (vec![want.clone()], 0));
        let (j, done) = Journal::open(&path, 77, "m=a", 3, None, true).unwrap();
        assert_eq!(done, vec![want.clone()]);
        let b = pair(0, 1, 2.0);
        j.record(&b).unwrap();
        drop(j);
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.starts_with("# qcshape similarity journal v3\n"), "{text}");
        let (_, done) = Journal::open(&path, 77, "m=a", 3, None, true).unwrap();
        assert_eq!(done, vec![want, b]);
        // Another first line is still refused.
        std::fs::write(&path, "# qcshape similarity journal v1\nkey,0\nn,3\nsettings,\n").unwrap();
        let e = Journal::open(&path, 77, "m=a", 3, None, true)
            .unwrap_err()
            .to_string();
        assert!(e.contains("v3") && e.contains("v2"), "{e}");
    }

    #[test]
    fn fingerprint_sees_coordinates_names_and_settings() {
        let names = vec!["a".to_string()];
        let d = vec![vec![vec![[0.0, 1.0, 2.0]]]];
        let k = fingerprint(&names, &d, "isometric");
        assert_eq!(k, fingerprint(&names, &d, "isometric"));
        assert_ne!(k, fingerprint(&names, &d, "conformal"));
        assert_ne!(k, fingerprint(&["b".to_string()], &d, "isometric"));
        let d2 = vec![vec![vec![[0.0, 1.0, 2.0 + 1e-15]]]];
        assert_ne!(k, fingerprint(&names, &d2, "isometric"));
    }
}
