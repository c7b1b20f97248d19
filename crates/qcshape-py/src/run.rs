//! Running library calls without the GIL: the work runs on a worker thread (in a rayon pool of
//! the requested size) while the calling thread, GIL released, polls for Ctrl-C; an interrupt
//! sets the cancel flag the library checks between pairs, waits for the worker and raises
//! `KeyboardInterrupt`. Progress goes to stderr.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use qcshape::similarity::Stage;

/// Runs `work(cancel)` on `threads` worker threads (None: rayon's global pool, all cores) with
/// the GIL released, honouring Ctrl-C.
pub fn detached<T, F>(py: Python<'_>, threads: Option<usize>, work: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce(&AtomicBool) -> PyResult<T> + Send,
{
    let pool = match threads {
        None => None,
        Some(0) => {
            return Err(PyValueError::new_err(
                "threads: must be at least 1 (or None for all cores)",
            ))
        }
        Some(t) => Some(
            rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .map_err(|e| {
                    PyValueError::new_err(format!("threads: cannot start {t} worker threads ({e})"))
                })?,
        ),
    };
    let cancel = AtomicBool::new(false);
    let (out, interrupt) = py.detach(|| {
        std::thread::scope(|s| {
            let (tx, rx) = mpsc::channel::<()>();
            let cancel = &cancel;
            let pool = pool.as_ref();
            let handle = s.spawn(move || {
                let r = match pool {
                    Some(p) => p.install(|| work(cancel)),
                    None => work(cancel),
                };
                // The receiver may be gone only if the caller panicked.
                let _ = tx.send(());
                r
            });
            let mut interrupt = None;
            loop {
                match rx.recv_timeout(Duration::from_millis(50)) {
                    Ok(()) | Err(mpsc::RecvTimeoutError::Disconnected) => break,
                    Err(mpsc::RecvTimeoutError::Timeout) => {
                        if interrupt.is_none() {
                            if let Err(e) = Python::attach(|py| py.check_signals()) {
                                cancel.store(true, Ordering::Relaxed);
                                interrupt = Some(e);
                            }
                        }
                    }
                }
            }
            let out = match handle.join() {
                Ok(r) => r,
                Err(panic) => std::panic::resume_unwind(panic),
            };
            (out, interrupt)
        })
    });
    match interrupt {
        Some(e) => Err(e),
        None => out,
    }
}

/// Whether to print progress: `progress=True` / `False`, or None (the default): only when stderr
/// is a terminal, so that logs, pipes and notebooks get no progress lines.
pub fn progress_enabled(progress: Option<bool>) -> bool {
    use std::io::IsTerminal;
    progress.unwrap_or_else(|| std::io::stderr().is_terminal())
}

/// Counts of a long call printed to stderr: on a terminal one `\r`-updated line (at most 5
/// times a second), elsewhere (progress=True into a log) plain lines, at most one every 5 s.
pub struct Progress {
    enabled: bool,
    tty: bool,
    totals: [usize; 3],
    counts: [AtomicUsize; 3],
    last: Mutex<Instant>,
}

const LABELS: [&str; 3] = ["interpolating", "transferring", "pairs"];

impl Progress {
    /// `totals`: deformations to interpolate, to transfer, pairs.
    pub fn new(enabled: bool, totals: [usize; 3]) -> Self {
        use std::io::IsTerminal;
        Progress {
            enabled,
            tty: std::io::stderr().is_terminal(),
            totals,
            counts: Default::default(),
            last: Mutex::new(Instant::now() - Duration::from_secs(1)),
        }
    }

    /// Only pairs (pairwise distances).
    pub fn pairs(enabled: bool, n: usize) -> Self {
        Progress::new(enabled, [0, 0, n])
    }

    /// One more item of `stage` done.
    pub fn tick(&self, stage: Stage) {
        if !self.enabled {
            return;
        }
        let s = match stage {
            Stage::Interpolation => 0,
            Stage::Transfer => 1,
            Stage::Similarity => 2,
        };
        let n = self.counts[s].fetch_add(1, Ordering::Relaxed) + 1;
        let total = self.totals[s];
        let Ok(mut last) = self.last.lock() else {
            return;
        };
        let every = Duration::from_millis(if self.tty { 200 } else { 5000 });
        if n == total || last.elapsed() >= every {
            if self.tty {
                eprint!("\rqcshape: {} {n}/{total}   ", LABELS[s]);
                if n == total {
                    eprintln!();
                }
            } else {
                eprintln!("qcshape: {} {n}/{total}", LABELS[s]);
            }
            *last = Instant::now();
        }
    }
}
