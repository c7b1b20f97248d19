//! Running library calls without the GIL: the work runs on a worker thread (in a rayon pool of
//! the requested size) while the calling thread, GIL released, polls for Ctrl-C; an interrupt
//! sets the stop flag ([`Watch`]) that the library checks between pairs and that every geodesic
//! solver checks once per iteration (through [`Watch::geodesic`]'s monitor), waits for the
//! worker and raises `KeyboardInterrupt`. Progress: the workers count finished items and solver
//! iterations ([`Progress::tick`], atomics only) and the polling thread hands the counts to the
//! Python reporter of `qcshape._progress` (a tqdm bar, a line, plain log lines or the user's
//! callable) with the GIL.

use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use qcshape::geodesic::{GeodesicOptions, Monitor};
use qcshape::similarity::{Event, Stage};

/// What the worker shares with the polling thread: the stop flag (set on Ctrl-C or an error of
/// the progress reporter) and, when iterations are shown, the solver iterations done.
pub struct Watch {
    stop: Arc<AtomicBool>,
    iterations: Option<Arc<AtomicUsize>>,
}

impl Watch {
    /// The stop flag the library's pair loops check.
    pub fn flag(&self) -> &AtomicBool {
        &self.stop
    }

    /// `options` with a monitor that every solver calls once per iteration: it counts the
    /// iteration for the progress display and stops the solve
    /// ([`qcshape::geodesic::GeodesicError::Interrupted`]) once the stop flag is set, so that
    /// Ctrl-C reaches a single long geodesic between two iterations.
    pub fn geodesic(&self, options: &GeodesicOptions) -> GeodesicOptions {
        let stop = self.stop.clone();
        let count = self.iterations.clone();
        GeodesicOptions {
            monitor: Some(Monitor::new(move |_, _| {
                if let Some(c) = &count {
                    c.fetch_add(1, Ordering::Relaxed);
                }
                if stop.load(Ordering::Relaxed) {
                    ControlFlow::Break(())
                } else {
                    ControlFlow::Continue(())
                }
            })),
            ..options.clone()
        }
    }
}

/// Runs `work(watch)` on `threads` worker threads (None: rayon's global pool, all cores) with
/// the GIL released, honouring Ctrl-C.
pub fn detached<T, F>(py: Python<'_>, threads: Option<usize>, work: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce(&Watch) -> PyResult<T> + Send,
{
    detached_with(py, threads, None, work)
}

/// [`detached`] that also shows `progress` (its counts, ticked by `work`) every 50 ms and once
/// more at the end. An exception of the progress reporter (a user's callable) stops the work as
/// Ctrl-C does and is raised.
pub fn detached_with<T, F>(
    py: Python<'_>,
    threads: Option<usize>,
    progress: Option<&Progress>,
    work: F,
) -> PyResult<T>
where
    T: Send,
    F: FnOnce(&Watch) -> PyResult<T> + Send,
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
    let watch = Watch {
        stop: Arc::new(AtomicBool::new(false)),
        iterations: progress.and_then(|p| p.iterations.as_ref().map(|(c, _)| c.clone())),
    };
    let (out, interrupt) = py.detach(|| {
        std::thread::scope(|s| {
            let (tx, rx) = mpsc::channel::<()>();
            let watch = &watch;
            let pool = pool.as_ref();
            let handle = s.spawn(move || {
                let r = match pool {
                    Some(p) => p.install(|| work(watch)),
                    None => work(watch),
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
                            let polled = Python::attach(|py| {
                                py.check_signals()?;
                                match progress {
                                    Some(p) => p.report(py),
                                    None => Ok(()),
                                }
                            });
                            if let Err(e) = polled {
                                watch.stop.store(true, Ordering::Relaxed);
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
    if let Some(e) = interrupt {
        if let Some(p) = progress {
            // The display is closed; an error of the reporter itself loses to the interrupt.
            let _ = p.close(py);
        }
        return Err(e);
    }
    if let Some(p) = progress {
        if out.is_ok() {
            p.report(py)?;
        }
        p.close(py)?;
    }
    out
}

/// The stages of a long call, in order, as the reporter names them.
const LABELS: [&str; 3] = ["interpolating", "transferring", "pairs"];

/// The counts of a long call and the Python reporter that shows them (`progress=`: None for
/// auto, True, False or a callable `(stage, done, total)`; see `qcshape._progress`).
pub struct Progress {
    reporter: Option<Py<PyAny>>,
    totals: [usize; 3],
    counts: [AtomicUsize; 3],
    shown: Mutex<[usize; 3]>,
    /// Solver iterations (stage "iterations"): the count the monitors of [`Watch::geodesic`]
    /// tick, and the total shown with it (the iteration limit of one geodesic; 0 when the
    /// call solves several and the total is not known).
    iterations: Option<(Arc<AtomicUsize>, usize)>,
    shown_iterations: AtomicUsize,
}

impl Progress {
    /// `totals`: deformations to interpolate, to transfer, pairs. `progress`: the keyword's value
    /// (None: auto); a value that is neither None, a bool nor a callable is a `ValueError`.
    pub fn new(py: Python<'_>, progress: Option<&Bound<'_, PyAny>>, totals: [usize; 3]) -> PyResult<Self> {
        let arg = match progress {
            Some(p) => p.clone(),
            None => py.None().into_bound(py),
        };
        let r = py
            .import("qcshape._progress")?
            .getattr("reporter")?
            .call1((arg,))?;
        Ok(Progress {
            reporter: if r.is_none() { None } else { Some(r.unbind()) },
            totals,
            counts: Default::default(),
            shown: Mutex::new([0; 3]),
            iterations: None,
            shown_iterations: AtomicUsize::new(0),
        })
    }

    /// Progress of geodesic solves: the solver iterations (stage "iterations"), out of `limit`
    /// (one geodesic's iteration limit; 0 when unknown: several solves), ticked by the monitor
    /// of [`Watch::geodesic`]; `pairs` geodesics to solve (0: none shown).
    pub fn solving(
        py: Python<'_>,
        progress: Option<&Bound<'_, PyAny>>,
        limit: usize,
        pairs: usize,
    ) -> PyResult<Self> {
        let mut p = Progress::new(py, progress, [0, 0, pairs])?;
        if p.reporter.is_some() {
            p.iterations = Some((Arc::new(AtomicUsize::new(0)), limit));
        }
        Ok(p)
    }

    /// Only pairs (pairwise distances).
    pub fn pairs(py: Python<'_>, progress: Option<&Bound<'_, PyAny>>, n: usize) -> PyResult<Self> {
        Progress::new(py, progress, [0, 0, n])
    }

    /// One more item of `stage` done (from any thread; no GIL, no output).
    pub fn tick(&self, stage: Stage) {
        if self.reporter.is_none() {
            return;
        }
        let s = match stage {
            Stage::Interpolation => 0,
            Stage::Transfer => 1,
            Stage::Similarity => 2,
        };
        self.counts[s].fetch_add(1, Ordering::Relaxed);
    }

    /// Counts a pipeline event: a prepared deformation or a finished pair.
    pub fn event(&self, e: Event<'_>) {
        match e {
            Event::Prepared { stage, .. } => self.tick(stage),
            Event::Pair(_) => self.tick(Stage::Similarity),
            Event::Journal { .. } => {}
        }
    }

    /// Hands the counts that changed since the last report to the reporter, stage by stage.
    fn report(&self, py: Python<'_>) -> PyResult<()> {
        let Some(r) = &self.reporter else {
            return Ok(());
        };
        let Ok(mut shown) = self.shown.lock() else {
            return Ok(());
        };
        for s in 0..3 {
            let n = self.counts[s].load(Ordering::Relaxed).min(self.totals[s]);
            if n != shown[s] {
                shown[s] = n;
                r.bind(py)
                    .call_method1("update", (LABELS[s], n, self.totals[s]))?;
            }
        }
        if let Some((count, limit)) = &self.iterations {
            let n = count.load(Ordering::Relaxed);
            if n != self.shown_iterations.swap(n, Ordering::Relaxed) {
                r.bind(py).call_method1("update", ("iterations", n, *limit))?;
            }
        }
        Ok(())
    }

    /// Closes the display (a bar's last line).
    fn close(&self, py: Python<'_>) -> PyResult<()> {
        match &self.reporter {
            Some(r) => r.bind(py).call_method0("close").map(|_| ()),
            None => Ok(()),
        }
    }
}
