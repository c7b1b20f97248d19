//! Landmark files: CSV `frame,landmark,x,y,z` (world mm), one row per landmark and frame.
//!
//! Every frame `0 .. F-1` must list the same landmark ids (any non-negative integers, sorted
//! on reading). Subsets for registration are the first `n` ids ([`Landmarks::first`]); the
//! phantom orders its 32 landmarks so that the first 8, 16, 24 and 32 each cover the apex,
//! the base and both walls (section 4.2 uses 16). Two ids have a fixed meaning, used to find
//! the long axis: [`APEX`] and [`BASE_CENTRE`]; [`SEPTUM`] is the angular reference of the
//! free-wall sector.

use std::path::{Path, PathBuf};

use thiserror::Error;

use qcshape::io::table::{Table, TableErrors};
use qcshape::io::write_atomically;

/// Id of the (endocardial) apex landmark.
pub const APEX: u32 = 0;
/// Id of the base-centre landmark (centre of the mitral valve plane).
pub const BASE_CENTRE: u32 = 1;
/// Id of a landmark on the septum (endocardium near the base), the angular reference.
pub const SEPTUM: u32 = 3;

/// Why a landmark file cannot be used. Messages start with the file.
#[derive(Debug, Error)]
pub enum LandmarkError {
    /// The file cannot be read.
    #[error("{}: cannot read: {error}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The system error.
        error: std::io::Error,
    },
    /// A malformed, non-numeric or non-finite row (1-based line; the header is line 1).
    #[error("{}: line {line}: {problem}", path.display())]
    Row {
        /// The file.
        path: PathBuf,
        /// Line number.
        line: u64,
        /// What is wrong, with the offending values.
        problem: RowProblem,
    },
    /// The rows do not form a complete frames x landmarks table.
    #[error("{}: {gap}", path.display())]
    Incomplete {
        /// The file.
        path: PathBuf,
        /// Which frame or landmark is missing.
        gap: LandmarkGap,
    },
    /// The landmarks cannot be written.
    #[error(transparent)]
    Write(#[from] qcshape::io::IoError),
}

/// What a landmark table lacks ([`LandmarkError::Incomplete`]).
#[derive(Debug, Error, Clone, PartialEq, Eq)]
pub enum LandmarkGap {
    /// No row at all.
    #[error("no landmark rows")]
    NoRows,
    /// A frame number below the largest with no row.
    #[error("frame {frame} has no landmarks (frames must be numbered 0 .. {last})")]
    EmptyFrame {
        /// The frame.
        frame: usize,
        /// The largest frame number.
        last: usize,
    },
    /// A frame lacking landmarks that other frames have.
    #[error("frame {frame} is missing landmark(s) {missing:?} that other frames have")]
    MissingLandmarks {
        /// The frame.
        frame: usize,
        /// The missing ids.
        missing: Vec<u32>,
    },
}

/// Landmark positions: `frames[t][k]` is landmark `ids[k]` in frame `t` (#frames x #ids x 3,
/// world mm).
#[derive(Debug, Clone, PartialEq)]
pub struct Landmarks {
    /// Landmark ids, ascending.
    pub ids: Vec<u32>,
    /// Positions per frame.
    pub frames: Vec<Vec<[f64; 3]>>,
}

impl Landmarks {
    /// Number of frames.
    pub fn n_frames(&self) -> usize {
        self.frames.len()
    }

    /// The first `n` landmarks (by id) of every frame; `None` if there are fewer than `n`.
    pub fn first(&self, n: usize) -> Option<Landmarks> {
        (n <= self.ids.len()).then(|| Landmarks {
            ids: self.ids[..n].to_vec(),
            frames: self.frames.iter().map(|f| f[..n].to_vec()).collect(),
        })
    }

    /// The landmark trajectories low-pass filtered over one periodic cycle: every coordinate
    /// of every landmark, as a function of the frame `t = 0 .. F-1` (F frames covering one
    /// whole cycle, frame F following frame F-1 being frame 0), is replaced by its projection
    /// on the Fourier harmonics `0 .. harmonics` of the cycle (least squares, the same linear
    /// filter for every coordinate; world mm). It removes frame-to-frame jitter of tracked or
    /// hand-placed landmarks (independent per frame) while keeping the smooth cardiac motion.
    /// `harmonics >= F / 2` keeps every frequency (a copy).
    pub fn low_pass(&self, harmonics: usize) -> Landmarks {
        let f = self.n_frames();
        if 2 * harmonics >= f {
            return self.clone();
        }
        // Projection matrix onto the kept harmonics: for the orthogonal DFT basis on F points,
        // P[t][s] = (1 + 2 sum_{h=1..H} cos(2 pi h (t - s) / F)) / F.
        let weight = |t: usize, s: usize| {
            let d = t as f64 - s as f64;
            let sum: f64 = (1..=harmonics)
                .map(|h| (2.0 * std::f64::consts::PI * h as f64 * d / f as f64).cos())
                .sum();
            (1.0 + 2.0 * sum) / f as f64
        };
        let frames = (0..f)
            .map(|t| {
                (0..self.ids.len())
                    .map(|k| {
                        let mut p = [0.0; 3];
                        for s in 0..f {
                            let w = weight(t, s);
                            for (c, v) in p.iter_mut().enumerate() {
                                *v += w * self.frames[s][k][c];
                            }
                        }
                        p
                    })
                    .collect()
            })
            .collect();
        Landmarks {
            ids: self.ids.clone(),
            frames,
        }
    }

    /// Position of landmark `id` in frame `t`, if both exist.
    pub fn get(&self, t: usize, id: u32) -> Option<[f64; 3]> {
        let k = self.ids.binary_search(&id).ok()?;
        self.frames.get(t).map(|f| f[k])
    }
}

impl TableErrors for LandmarkError {
    fn unreadable(path: &Path, error: std::io::Error) -> Self {
        LandmarkError::Read {
            path: path.into(),
            error,
        }
    }
    fn malformed(path: &Path, line: u64, error: qcshape::io::table::CsvError) -> Self {
        LandmarkError::Row {
            path: path.into(),
            line,
            problem: RowProblem::Csv(error),
        }
    }
}

/// What is wrong on a row of a landmark CSV ([`LandmarkError::Row`]).
#[derive(Debug, thiserror::Error)]
pub enum RowProblem {
    /// Not CSV as qcshape reads it (the csv crate's error).
    #[error("malformed CSV: {0}")]
    Csv(qcshape::io::table::CsvError),
    /// A column the file needs is not in its header.
    #[error("missing column {0:?}: the header must be frame,landmark,x,y,z")]
    MissingColumn(&'static str),
    /// A frame that is not a non-negative integer.
    #[error("frame {text:?} is not a non-negative integer")]
    Frame {
        /// The field.
        text: String,
        /// The parser's error.
        error: std::num::ParseIntError,
    },
    /// A landmark id that is not a non-negative integer.
    #[error("landmark {text:?} is not a non-negative integer")]
    Landmark {
        /// The field.
        text: String,
        /// The parser's error.
        error: std::num::ParseIntError,
    },
    /// A coordinate that is not a finite number.
    #[error("{axis} = {text:?} is not a finite number")]
    Coordinate {
        /// The column (`x`, `y` or `z`).
        axis: &'static str,
        /// The field.
        text: String,
    },
    /// A landmark given twice for one frame.
    #[error("landmark {id} of frame {frame} is given twice (also on line {first})")]
    Repeated {
        /// The landmark.
        id: u32,
        /// The frame.
        frame: usize,
        /// The line of the first.
        first: u64,
    },
}

/// Reads a landmark CSV (header `frame,landmark,x,y,z`, columns in any order, `#` comments).
pub fn read_landmarks(path: &Path) -> Result<Landmarks, LandmarkError> {
    let row_err = |line: u64, problem: RowProblem| LandmarkError::Row {
        path: path.into(),
        line,
        problem,
    };
    let incomplete = |gap: LandmarkGap| LandmarkError::Incomplete {
        path: path.into(),
        gap,
    };
    let mut table = Table::<LandmarkError>::read(path, false)?;
    const COLS: [&str; 5] = ["frame", "landmark", "x", "y", "z"];
    let mut col = [0usize; 5];
    for (slot, name) in col.iter_mut().zip(COLS) {
        *slot = table
            .column(name)
            .ok_or_else(|| row_err(table.header_line, RowProblem::MissingColumn(name)))?;
    }
    let mut rows: Vec<(usize, u32, [f64; 3], u64)> = Vec::new();
    for rec in table.rows() {
        let (line, rec) = rec?;
        let field = |k: usize| rec.get(col[k]).unwrap_or("");
        let frame = field(0).parse::<usize>().map_err(|error| {
            row_err(
                line,
                RowProblem::Frame {
                    text: field(0).to_string(),
                    error,
                },
            )
        })?;
        let id = field(1).parse::<u32>().map_err(|error| {
            row_err(
                line,
                RowProblem::Landmark {
                    text: field(1).to_string(),
                    error,
                },
            )
        })?;
        let mut p = [0.0; 3];
        for (c, slot) in p.iter_mut().enumerate() {
            let text = field(2 + c);
            *slot = text
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    row_err(
                        line,
                        RowProblem::Coordinate {
                            axis: COLS[2 + c],
                            text: text.to_string(),
                        },
                    )
                })?;
        }
        rows.push((frame, id, p, line));
    }
    if rows.is_empty() {
        return Err(incomplete(LandmarkGap::NoRows));
    }
    let mut ids: Vec<u32> = rows.iter().map(|r| r.1).collect();
    ids.sort_unstable();
    ids.dedup();
    let n_frames = rows.iter().map(|r| r.0).max().unwrap_or(0) + 1;
    type Cell = Option<([f64; 3], u64)>;
    let mut table: Vec<Vec<Cell>> = vec![vec![None; ids.len()]; n_frames];
    for (frame, id, p, line) in rows {
        let k = ids.binary_search(&id).unwrap_or(0);
        if let Some((_, first)) = table[frame][k] {
            return Err(row_err(line, RowProblem::Repeated { id, frame, first }));
        }
        table[frame][k] = Some((p, line));
    }
    let mut frames = Vec::with_capacity(n_frames);
    for (t, row) in table.into_iter().enumerate() {
        let missing: Vec<u32> = row
            .iter()
            .zip(&ids)
            .filter(|(v, _)| v.is_none())
            .map(|(_, &id)| id)
            .collect();
        if missing.len() == ids.len() {
            return Err(incomplete(LandmarkGap::EmptyFrame {
                frame: t,
                last: n_frames - 1,
            }));
        }
        if !missing.is_empty() {
            return Err(incomplete(LandmarkGap::MissingLandmarks { frame: t, missing }));
        }
        frames.push(row.into_iter().map(|v| v.map_or([0.0; 3], |x| x.0)).collect());
    }
    Ok(Landmarks { ids, frames })
}

/// Writes landmarks as CSV `frame,landmark,x,y,z` (shortest round-trip decimals), atomically.
pub fn write_landmarks(path: &Path, lm: &Landmarks) -> Result<(), LandmarkError> {
    let mut s = String::from("frame,landmark,x,y,z\n");
    for (t, f) in lm.frames.iter().enumerate() {
        for (id, p) in lm.ids.iter().zip(f) {
            s.push_str(&format!("{t},{id},{},{},{}\n", p[0], p[1], p[2]));
        }
    }
    write_atomically(path, |w| w.write_all(s.as_bytes()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Landmark 0 at `x(t)` on the x axis in each of `f` frames.
    fn trajectory(f: usize, x: impl Fn(f64) -> f64) -> Landmarks {
        Landmarks {
            ids: vec![0],
            frames: (0..f)
                .map(|t| vec![[x(2.0 * std::f64::consts::PI * t as f64 / f as f64), 1.0, -2.0]])
                .collect(),
        }
    }

    #[test]
    fn low_pass_keeps_the_kept_harmonics_and_removes_the_others() {
        let smooth = |a: f64| 3.0 + 2.0 * a.cos() - 0.5 * (2.0 * a).sin();
        let jitter = |a: f64| 0.7 * (3.0 * a).cos();
        let clean = trajectory(8, smooth);
        let noisy = trajectory(8, |a| smooth(a) + jitter(a));
        let filtered = noisy.low_pass(2);
        for (f, c) in filtered.frames.iter().zip(&clean.frames) {
            for k in 0..3 {
                assert!((f[0][k] - c[0][k]).abs() < 1e-12, "{f:?} vs {c:?}");
            }
        }
        // With one harmonic the second one goes too; the mean and the first harmonic stay.
        let first = noisy.low_pass(1);
        let expected = trajectory(8, |a| 3.0 + 2.0 * a.cos());
        for (f, c) in first.frames.iter().zip(&expected.frames) {
            assert!((f[0][0] - c[0][0]).abs() < 1e-12);
        }
        // Every frequency kept: a copy.
        assert_eq!(noisy.low_pass(4), noisy);
    }

    #[test]
    fn low_pass_reduces_independent_noise_by_the_share_of_kept_harmonics() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let f = 8;
        let lm = Landmarks {
            ids: (0..2000).collect(),
            frames: (0..f)
                .map(|_| (0..2000).map(|_| [rng.random::<f64>() - 0.5, 0.0, 0.0]).collect())
                .collect(),
        };
        let var = |l: &Landmarks| {
            let n = (l.frames.len() * l.ids.len()) as f64;
            l.frames.iter().flatten().map(|p| p[0] * p[0]).sum::<f64>() / n
        };
        // Keeping harmonics 0..2 of 8 frames keeps 5 of 8 degrees of freedom per coordinate.
        let ratio = var(&lm.low_pass(2)) / var(&lm);
        assert!((ratio - 5.0 / 8.0).abs() < 0.03, "{ratio}");
    }
}
