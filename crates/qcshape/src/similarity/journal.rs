//! A journal of finished pairs, so that an interrupted similarity run can be resumed without
//! recomputing them (`qcshape similarity --resume`).
//!
//! The journal is a text file: a header line, a `key` line that fingerprints the inputs and
//! the settings, then one `pair` line per finished pair, appended and flushed as soon as the
//! pair is done. A run killed midway leaves at most one partial last line, which is ignored
//! on resume. A journal whose key differs from the current run's is never reused.

use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use super::engine::{PairDistance, Pose, SimilarityError};

const HEADER: &str = "# qcshape similarity journal v1";

/// FNV-1a 64-bit hash of the names, every coordinate's bits and a settings string (metric,
/// solver options, scale): identical inputs give the same key on every machine and version.
pub fn fingerprint(names: &[String], deformations: &[Vec<Pose>], settings: &str) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for b in bytes {
            h ^= *b as u64;
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
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
    h
}

/// An open journal that records pairs as they finish (safe to call from several threads).
#[derive(Debug)]
pub struct Journal {
    path: PathBuf,
    file: Mutex<File>,
}

impl Journal {
    /// Opens the journal at `path` for a run with fingerprint `key` over `n` deformations.
    ///
    /// With `resume`, an existing journal with the same key is kept and its finished pairs are
    /// returned; a journal with another key is an error (it belongs to another run). Without
    /// `resume` (or when no journal exists) a new one is started.
    pub fn open(
        path: &Path,
        key: u64,
        n: usize,
        resume: bool,
    ) -> Result<(Journal, Vec<PairDistance>), SimilarityError> {
        let err = |message: String| SimilarityError::Journal {
            path: path.to_path_buf(),
            message,
        };
        let mut done = Vec::new();
        if resume && path.exists() {
            done = read(path, key, n)?;
        }
        // Write the header and the valid pairs to a new file that replaces the old one in one
        // rename: a partial last line left by a kill is dropped, and no kill loses pairs.
        let mut text = format!("{HEADER}\nkey,{key:016x}\nn,{n}\n");
        for p in &done {
            text.push_str(&line(p));
        }
        let tmp = path.with_extension("journal-tmp");
        std::fs::write(&tmp, text).map_err(|e| err(format!("cannot write {}: {e}", tmp.display())))?;
        std::fs::rename(&tmp, path).map_err(|e| err(format!("cannot write: {e}")))?;
        let file = OpenOptions::new()
            .append(true)
            .open(path)
            .map_err(|e| err(format!("cannot append: {e}")))?;
        let journal = Journal {
            path: path.to_path_buf(),
            file: Mutex::new(file),
        };
        Ok((journal, done))
    }

    fn error(&self, message: String) -> SimilarityError {
        SimilarityError::Journal {
            path: self.path.clone(),
            message,
        }
    }

    /// Appends one finished pair and flushes it to the file.
    pub fn record(&self, pair: &PairDistance) -> Result<(), SimilarityError> {
        let mut f = self.file.lock().unwrap_or_else(|p| p.into_inner());
        f.write_all(line(pair).as_bytes())
            .and_then(|_| f.flush())
            .map_err(|e| self.error(format!("cannot append: {e}")))
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
            message: format!("cannot remove: {e}"),
        })
    }
}

fn line(p: &PairDistance) -> String {
    let per: Vec<String> = p.per_pose.iter().map(|d| format!("{d:?}")).collect();
    format!(
        "pair,{},{},{:?},{},{},{:?},{}\n",
        p.i,
        p.j,
        p.distance,
        p.converged,
        p.iterations,
        p.seconds,
        per.join(";")
    )
}

fn parse_pair(text: &str, n: usize) -> Option<PairDistance> {
    let f: Vec<&str> = text.split(',').collect();
    if f.len() != 8 || f[0] != "pair" {
        return None;
    }
    let i: usize = f[1].parse().ok()?;
    let j: usize = f[2].parse().ok()?;
    if i >= j || j >= n {
        return None;
    }
    let per_pose: Vec<f64> = f[7].split(';').map(|s| s.parse().ok()).collect::<Option<_>>()?;
    let distance: f64 = f[3].parse().ok()?;
    if !distance.is_finite() || per_pose.iter().any(|d| !d.is_finite()) {
        return None;
    }
    Some(PairDistance {
        i,
        j,
        distance,
        per_pose,
        converged: f[4].parse().ok()?,
        iterations: f[5].parse().ok()?,
        seconds: f[6].parse().ok()?,
    })
}

fn read(path: &Path, key: u64, n: usize) -> Result<Vec<PairDistance>, SimilarityError> {
    let err = |message: String| SimilarityError::Journal {
        path: path.to_path_buf(),
        message,
    };
    let file = File::open(path).map_err(|e| err(format!("cannot read: {e}")))?;
    let mut lines = Vec::new();
    for l in BufReader::new(file).split(b'\n') {
        lines.push(l.map_err(|e| err(format!("cannot read: {e}")))?);
    }
    let text = |k: usize| String::from_utf8_lossy(&lines[k]).into_owned();
    if lines.len() < 3 || text(0) != HEADER {
        return Err(err("not a qcshape similarity journal".into()));
    }
    if text(1) != format!("key,{key:016x}") || text(2) != format!("n,{n}") {
        return Err(err(
            "the journal belongs to another run (different inputs or settings); remove it or run without --resume"
                .into(),
        ));
    }
    let mut pairs: Vec<PairDistance> = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for k in 3..lines.len() {
        match parse_pair(&text(k), n) {
            Some(p) => {
                if seen.insert((p.i, p.j)) {
                    pairs.push(p);
                }
            }
            // A run killed while writing leaves a partial last line.
            None if k + 1 == lines.len() => {}
            None => return Err(err(format!("line {}: malformed pair record", k + 1))),
        }
    }
    Ok(pairs)
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
            converged: true,
            iterations: 7,
            seconds: 0.25,
        }
    }

    #[test]
    fn records_survive_a_partial_last_line_and_keys_must_match() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.journal");
        let (j, done) = Journal::open(&path, 42, 4, true).unwrap();
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
        let (j, done) = Journal::open(&path, 42, 4, true).unwrap();
        assert_eq!(done, vec![a.clone(), b.clone()]); // bit-exact floats
        let c = pair(2, 3, 1.5);
        j.record(&c).unwrap();
        drop(j);
        let (_, done) = Journal::open(&path, 42, 4, true).unwrap();
        assert_eq!(done, vec![a, b, c]);
        // Another run's key or size is refused, not silently reused.
        let e = Journal::open(&path, 43, 4, true).unwrap_err();
        assert!(e.to_string().contains("another run"), "{e}");
        assert!(Journal::open(&path, 42, 5, true).is_err());
        // Without resume a fresh journal is started.
        let (j, done) = Journal::open(&path, 43, 4, false).unwrap();
        assert!(done.is_empty());
        j.remove().unwrap();
        assert!(!path.exists());
    }

    #[test]
    fn a_corrupt_middle_line_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.journal");
        std::fs::write(
            &path,
            format!(
                "{HEADER}\nkey,{:016x}\nn,3\npair,0,1,x,true,1,0.1,0\npair,0,2,1.0,true,1,0.1,0;1\n",
                7u64
            ),
        )
        .unwrap();
        let e = Journal::open(&path, 7, 3, true).unwrap_err();
        assert!(e.to_string().contains("line 4"), "{e}");
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
