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

/// An exclusive claim on a file (a similarity journal, a shard): the file `<path>.lock`,
/// created with `create_new` and holding the owner's process id, removed when the lock is
/// dropped. A lock left by a process that no longer runs (killed with `kill -9`) is taken over
/// (detected through `/proc` where it exists); elsewhere it must be removed by hand.
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
                    if pid != 0 && process_is_gone(pid) {
                        // A stale lock of a killed run: take it over (one racer wins create_new).
                        let _ = std::fs::remove_file(&lock);
                        continue;
                    }
                    return Err(OutputError::Locked { lock, pid });
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

/// Whether process `pid` is known not to run (no `/proc/<pid>`, or a zombie). `false` when
/// it cannot be told (no `/proc`).
fn process_is_gone(pid: u32) -> bool {
    if !Path::new("/proc/self").exists() {
        return false;
    }
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        Err(_) => true,
        // "pid (comm) S ...": the state follows the last ')'.
        Ok(stat) => stat
            .rsplit_once(')')
            .is_some_and(|(_, rest)| matches!(rest.trim_start().chars().next(), Some('Z' | 'X'))),
    }
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
}
