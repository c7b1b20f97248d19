//! Outputs never overwrite inputs: the one check every writing command and the Python API run
//! before they compute ([`refuse_input_overlap`] for an output file, [`refuse_folder_overlap`]
//! for an output folder), and the lock ([`RunLock`]) that keeps two runs off one journal.
//!
//! Paths are compared after [`std::fs::canonicalize`] (an output that does not exist yet is
//! resolved through its nearest existing ancestor), and on Unix also by device and inode, so
//! that `./D.csv`, `../x/D.csv`, a symbolic link and a hard link to an input are all recognized.

use std::io::Write;
use std::path::{Component, Path, PathBuf};

use thiserror::Error;

/// An output that would destroy an input, or a run that another run already holds.
#[derive(Debug, Error)]
pub enum OutputError {
    /// The output file is one of the inputs.
    #[error("{what} {} would overwrite the input file {}; choose another output path", output.display(), input.display())]
    OverwritesInput {
        /// The option that names the output (`-o`, `--out`, ...).
        what: String,
        /// The output path as given.
        output: PathBuf,
        /// The input path as given.
        input: PathBuf,
    },
    /// The output folder holds one of the inputs (the command writes files and subfolders
    /// there and could replace it).
    #[error("{what} {} holds the input file {}; choose another output folder", output.display(), input.display())]
    FolderHoldsInput {
        /// The option that names the output folder.
        what: String,
        /// The output folder as given.
        output: PathBuf,
        /// The input path as given.
        input: PathBuf,
    },
    /// An output file path names an existing folder.
    #[error("{what} {} is a folder; name an output file", output.display())]
    IsFolder {
        /// The option that names the output.
        what: String,
        /// The output path as given.
        output: PathBuf,
    },
    /// An output folder path names an existing file.
    #[error("{what} {} is a file, not a folder", output.display())]
    NotAFolder {
        /// The option that names the output folder.
        what: String,
        /// The output path as given.
        output: PathBuf,
    },
    /// Another live run holds the lock file.
    #[error("another run holds {} (process {pid}); wait for it to finish, or remove the file if no run is active", lock.display())]
    Locked {
        /// The lock file.
        lock: PathBuf,
        /// The process id recorded in it (0 when unreadable).
        pid: u32,
    },
    /// A lock file younger than [`STALE_LOCK_HOURS`] whose process cannot be checked (no
    /// `/proc`): it may belong to a live run.
    #[error(
        "{} was taken by process {pid} {} ago and this system cannot tell whether that process \
         still runs (no /proc); if no run is active, remove the file (rm \"{}\") and start again; \
         a lock is taken over by itself after {STALE_LOCK_HOURS} hours",
        lock.display(),
        hours_minutes(*age_seconds),
        lock.display()
    )]
    MaybeLocked {
        /// The lock file.
        lock: PathBuf,
        /// The process id recorded in it (0 when unreadable).
        pid: u32,
        /// Seconds since the lock file was written.
        age_seconds: u64,
    },
    /// The lock file cannot be created or written.
    #[error("{}: cannot create the lock file: {error}", lock.display())]
    Lock {
        /// The lock file.
        lock: PathBuf,
        /// The system error.
        #[source]
        error: std::io::Error,
    },
}

/// The absolute, symlink-free form of `p`; for a path that does not exist (yet), its nearest
/// existing ancestor canonicalized with the rest appended (`.` and `..` resolved lexically).
fn resolve(p: &Path) -> PathBuf {
    if let Ok(c) = std::fs::canonicalize(p) {
        return c;
    }
    let abs = if p.is_absolute() {
        p.to_path_buf()
    } else {
        std::env::current_dir().unwrap_or_default().join(p)
    };
    let mut rest = Vec::new();
    let mut cur = abs.as_path();
    loop {
        if let Ok(c) = std::fs::canonicalize(cur) {
            let mut out = c;
            for comp in rest.iter().rev() {
                match comp {
                    Component::ParentDir => {
                        out.pop();
                    }
                    Component::CurDir => {}
                    c => out.push(c.as_os_str()),
                }
            }
            return out;
        }
        match (cur.parent(), cur.components().next_back()) {
            (Some(parent), Some(last)) => {
                rest.push(last);
                cur = parent;
            }
            _ => return abs,
        }
    }
}

/// Whether `a` and `b` are one existing file (same device and inode on Unix).
fn same_existing_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(x), Ok(y)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return x.dev() == y.dev() && x.ino() == y.ino();
        }
    }
    let _ = (a, b);
    false
}

/// Refuses an output file that is one of `inputs` (by canonical path, or the same file through
/// a link), or that names an existing folder. `what` names the option in the message (`-o`,
/// `--details`). Call it before any computation.
pub fn refuse_input_overlap(inputs: &[&Path], output: &Path, what: &str) -> Result<(), OutputError> {
    if output.is_dir() {
        return Err(OutputError::IsFolder {
            what: what.into(),
            output: output.into(),
        });
    }
    let out = resolve(output);
    for input in inputs {
        if resolve(input) == out || same_existing_file(input, output) {
            return Err(OutputError::OverwritesInput {
                what: what.into(),
                output: output.into(),
                input: input.to_path_buf(),
            });
        }
    }
    Ok(())
}

/// Refuses an output folder that holds one of `inputs` (directly or in a subfolder), that is
/// an input, or that names an existing file. Call it before any computation.
pub fn refuse_folder_overlap(inputs: &[&Path], folder: &Path, what: &str) -> Result<(), OutputError> {
    if folder.exists() && !folder.is_dir() {
        if let Some(input) = inputs.iter().find(|i| same_existing_file(i, folder)) {
            return Err(OutputError::OverwritesInput {
                what: what.into(),
                output: folder.into(),
                input: input.to_path_buf(),
            });
        }
        return Err(OutputError::NotAFolder {
            what: what.into(),
            output: folder.into(),
        });
    }
    let dir = resolve(folder);
    for input in inputs {
        if resolve(input).starts_with(&dir) {
            return Err(OutputError::FolderHoldsInput {
                what: what.into(),
                output: folder.into(),
                input: input.to_path_buf(),
            });
        }
    }
    Ok(())
}

/// The lock file of `path`: `path` with `.lock` appended to its name.
pub fn lock_path(path: &Path) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".lock");
    PathBuf::from(s)
}

/// How old a lock file must be before it is taken over where its process cannot be checked
/// (no `/proc`: macOS, Windows, the BSDs).
pub const STALE_LOCK_HOURS: u64 = 24;

/// `3 h 05 min` (or `42 min`, `0 min`) for a duration in seconds.
fn hours_minutes(seconds: u64) -> String {
    let (h, m) = (seconds / 3600, seconds % 3600 / 60);
    if h > 0 {
        format!("{h} h {m:02} min")
    } else {
        format!("{m} min")
    }
}

/// An exclusive claim on a file (a similarity journal, a shard): the file `<path>.lock`,
/// created with `create_new` and holding the owner's process id, removed when the lock is
/// dropped. A lock left by a process that no longer runs (killed with `kill -9`) is taken over:
/// where `/proc` exists (Linux) as soon as the process is gone; elsewhere, where whether a
/// process runs cannot be told portably, once the lock file is [`STALE_LOCK_HOURS`] old (a
/// younger one gives [`OutputError::MaybeLocked`], which names the file to remove).
#[derive(Debug)]
pub struct RunLock {
    path: PathBuf,
}

impl RunLock {
    /// Takes the lock of `path`, or fails with [`OutputError::Locked`] when another live
    /// process holds it.
    pub fn acquire(path: &Path) -> Result<RunLock, OutputError> {
        let lock = lock_path(path);
        for _ in 0..3 {
            match std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&lock)
            {
                Ok(mut f) => {
                    let me = std::process::id();
                    f.write_all(format!("{me}\n").as_bytes())
                        .map_err(|error| OutputError::Lock {
                            lock: lock.clone(),
                            error,
                        })?;
                    return Ok(RunLock { path: lock });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let pid = std::fs::read_to_string(&lock)
                        .ok()
                        .and_then(|s| s.trim().parse::<u32>().ok())
                        .unwrap_or(0);
                    let age = std::fs::metadata(&lock)
                        .and_then(|m| m.modified())
                        .ok()
                        .and_then(|t| t.elapsed().ok());
                    match staleness(pid, process_is_gone(pid), age) {
                        Staleness::Stale => {
                            // A stale lock of a killed run: take it over (one racer wins create_new).
                            let _ = std::fs::remove_file(&lock);
                            continue;
                        }
                        Staleness::Live => return Err(OutputError::Locked { lock, pid }),
                        Staleness::Unknown(age_seconds) => {
                            return Err(OutputError::MaybeLocked {
                                lock,
                                pid,
                                age_seconds,
                            })
                        }
                    }
                }
                Err(error) => return Err(OutputError::Lock { lock, error }),
            }
        }
        Err(OutputError::Locked { lock, pid: 0 })
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for RunLock {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

/// What an existing lock file is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Staleness {
    /// Its process is known to be gone, or it is older than [`STALE_LOCK_HOURS`] where that
    /// cannot be told: take it over.
    Stale,
    /// Its process runs.
    Live,
    /// Its process cannot be checked and it is younger (seconds since it was written).
    Unknown(u64),
}

/// The rule: `gone` is [`process_is_gone`] (`None`: cannot be told), `age` the lock file's age
/// (`None`: unreadable, or written in the future).
fn staleness(pid: u32, gone: Option<bool>, age: Option<std::time::Duration>) -> Staleness {
    match gone {
        Some(true) if pid != 0 => Staleness::Stale,
        Some(_) => Staleness::Live,
        None => match age {
            Some(a) if a.as_secs() >= STALE_LOCK_HOURS * 3600 => Staleness::Stale,
            a => Staleness::Unknown(a.map_or(0, |a| a.as_secs())),
        },
    }
}

/// Whether process `pid` is known not to run (no `/proc/<pid>`, or a zombie); `None` when it
/// cannot be told (no `/proc`).
fn process_is_gone(pid: u32) -> Option<bool> {
    if !Path::new("/proc/self").exists() {
        return None;
    }
    Some(match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        Err(_) => true,
        // "pid (comm) S ...": the state follows the last ')'.
        Ok(stat) => stat
            .rsplit_once(')')
            .is_some_and(|(_, rest)| matches!(rest.trim_start().chars().next(), Some('Z' | 'X'))),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_inputs_links_and_folders() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let a = d.join("a.csv");
        std::fs::write(&a, "x").unwrap();
        std::fs::create_dir(d.join("sub")).unwrap();
        let b = d.join("sub/b.ply");
        std::fs::write(&b, "y").unwrap();
        let inputs = [a.as_path(), b.as_path()];
        // The same file by another spelling.
        let other = d.join("sub/../a.csv");
        assert!(matches!(
            refuse_input_overlap(&inputs, &other, "-o"),
            Err(OutputError::OverwritesInput { .. })
        ));
        // An existing folder as output file.
        assert!(matches!(
            refuse_input_overlap(&inputs, &d.join("sub"), "-o"),
            Err(OutputError::IsFolder { .. })
        ));
        // A new file next to the inputs is fine; so is one in a folder yet to be made.
        refuse_input_overlap(&inputs, &d.join("c.csv"), "-o").unwrap();
        refuse_input_overlap(&inputs, &d.join("new/deeper/c.csv"), "-o").unwrap();
        #[cfg(unix)]
        {
            let link = d.join("link.csv");
            std::os::unix::fs::symlink(&a, &link).unwrap();
            assert!(refuse_input_overlap(&inputs, &link, "-o").is_err());
            let hard = d.join("hard.csv");
            std::fs::hard_link(&a, &hard).unwrap();
            assert!(refuse_input_overlap(&inputs, &hard, "-o").is_err());
        }
        // Folders: one that holds an input (directly or below), the input's own folder.
        assert!(matches!(
            refuse_folder_overlap(&inputs, d, "--out"),
            Err(OutputError::FolderHoldsInput { .. })
        ));
        assert!(refuse_folder_overlap(&inputs, &d.join("sub"), "--out").is_err());
        assert!(matches!(
            refuse_folder_overlap(&inputs, &a, "--out"),
            Err(OutputError::OverwritesInput { .. })
        ));
        refuse_folder_overlap(&inputs, &d.join("out"), "--out").unwrap();
        refuse_folder_overlap(&inputs, &d.join("sub/../out"), "--out").unwrap();
    }

    #[test]
    fn a_lock_excludes_a_second_run_and_goes_with_its_owner() {
        let dir = tempfile::tempdir().unwrap();
        let j = dir.path().join("D.csv.journal");
        let first = RunLock::acquire(&j).unwrap();
        let e = RunLock::acquire(&j).unwrap_err();
        assert!(e.to_string().contains("another run holds"), "{e}");
        drop(first);
        assert!(!lock_path(&j).exists());
        let _again = RunLock::acquire(&j).unwrap();
        // A lock left by a process that is gone is taken over.
        drop(_again);
        std::fs::write(lock_path(&j), format!("{}\n", u32::MAX - 7)).unwrap();
        if Path::new("/proc/self").exists() {
            let _taken = RunLock::acquire(&j).unwrap();
        }
    }

    #[test]
    fn without_proc_a_lock_is_stale_after_its_age_limit() {
        use std::time::Duration;
        let h = |n: u64| Some(Duration::from_secs(n * 3600));
        // /proc answers: its answer decides, whatever the age.
        assert_eq!(staleness(7, Some(true), h(0)), Staleness::Stale);
        assert_eq!(staleness(7, Some(false), h(1000)), Staleness::Live);
        assert_eq!(staleness(0, Some(true), h(0)), Staleness::Live);
        // No /proc: the age decides.
        assert_eq!(staleness(7, None, h(STALE_LOCK_HOURS)), Staleness::Stale);
        assert_eq!(staleness(0, None, h(STALE_LOCK_HOURS + 1)), Staleness::Stale);
        assert_eq!(
            staleness(7, None, Some(Duration::from_secs(3 * 3600 + 5 * 60))),
            Staleness::Unknown(3 * 3600 + 5 * 60)
        );
        assert_eq!(staleness(7, None, None), Staleness::Unknown(0));
        let e = OutputError::MaybeLocked {
            lock: PathBuf::from("D.csv.journal.lock"),
            pid: 7,
            age_seconds: 3 * 3600 + 5 * 60,
        };
        let m = e.to_string();
        assert!(
            m.contains("D.csv.journal.lock was taken by process 7 3 h 05 min ago"),
            "{m}"
        );
        assert!(m.contains("rm \"D.csv.journal.lock\""), "{m}");
        assert!(m.contains(&format!("after {STALE_LOCK_HOURS} hours")), "{m}");
        assert_eq!(hours_minutes(59), "0 min");
    }
}
