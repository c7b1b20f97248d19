//! Progress on stderr for the library's progress callbacks, in three modes: bars with an ETA when
//! stderr is a terminal; plain lines (`step  done/total [elapsed, ETA]`) at most every 10 s
//! (`QCSHAPE_PROGRESS_SECONDS` overrides the interval) when it is not, so that the log of a batch
//! job shows where a run is; nothing with `--quiet`. The ETA is the time left at the average
//! rate of everything finished so far (`{eta}` of [`style`]), so it does not jump while one
//! slow item runs; the solver iterations of the command ([`monitor`], on every geodesic's
//! options) are shown beside (`{solver}`), so a line appears while the first item is still
//! being solved.

use std::io::{IsTerminal, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, TermLike};
use qcshape::similarity::{Event, Stage};

static QUIET: AtomicBool = AtomicBool::new(false);

mod keys;
pub(crate) use keys::{iterations, monitor, style};

/// Silences every progress bar and line (the global `--quiet`).
pub(crate) fn set_quiet(quiet: bool) {
    QUIET.store(quiet, Ordering::Relaxed);
}

/// Whether `--quiet` was given.
pub(crate) fn is_quiet() -> bool {
    QUIET.load(Ordering::Relaxed)
}

/// Interval of the plain progress lines on a non-terminal stderr.
fn line_interval() -> Duration {
    std::env::var("QCSHAPE_PROGRESS_SECONDS")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s >= 0.0)
        .map_or(Duration::from_secs(10), Duration::from_secs_f64)
}

/// A draw target for logs: each redraw of a bar becomes one plain line, at most one per interval,
/// the first one interval after the bar was made, and none while nothing is done yet (a run
/// shorter than the interval prints no progress line).
#[derive(Debug)]
struct LogLines {
    every: Duration,
    last: Mutex<Instant>,
}

/// Whether a rendered line (`{msg} {bar} {pos}/{len} [...]`) reports no finished step yet.
fn nothing_done(line: &str) -> bool {
    line.split_whitespace().any(|w| {
        w.split_once('/').is_some_and(|(pos, len)| {
            pos == "0" && !len.is_empty() && len.bytes().all(|b| b.is_ascii_digit())
        })
    })
}

impl LogLines {
    fn emit(&self, s: &str) -> std::io::Result<()> {
        let s = s.trim();
        // A line with no item done is still news while the solver iterates.
        if s.is_empty() || (nothing_done(s) && iterations() == 0) {
            return Ok(());
        }
        let mut last = self.last.lock().unwrap_or_else(|e| e.into_inner());
        if last.elapsed() >= self.every {
            *last = Instant::now();
            let mut err = std::io::stderr().lock();
            writeln!(err, "{s}")?;
            err.flush()?;
        }
        Ok(())
    }
}

impl TermLike for LogLines {
    fn width(&self) -> u16 {
        100
    }
    fn move_cursor_up(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_down(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_right(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_left(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn write_line(&self, s: &str) -> std::io::Result<()> {
        self.emit(s)
    }
    fn write_str(&self, s: &str) -> std::io::Result<()> {
        self.emit(s)
    }
    fn clear_line(&self) -> std::io::Result<()> {
        Ok(())
    }
    fn flush(&self) -> std::io::Result<()> {
        std::io::stderr().flush()
    }
}

/// A progress bar of `len` steps in the mode of this run (module docs), unstyled.
pub(crate) fn new_bar(len: usize) -> ProgressBar {
    if QUIET.load(Ordering::Relaxed) {
        return ProgressBar::hidden();
    }
    if std::io::stderr().is_terminal() {
        return ProgressBar::new(len as u64);
    }
    let target = ProgressDrawTarget::term_like_with_hz(
        Box::new(LogLines {
            every: line_interval(),
            last: Mutex::new(Instant::now()),
        }),
        4,
    );
    ProgressBar::with_draw_target(Some(len as u64), target)
}

/// Call after styling a bar of [`new_bar`]: in the plain-line mode it is then redrawn every
/// second even when no step ends, so that a slow step still gets its line every interval.
pub(crate) fn start(pb: &ProgressBar) {
    if !QUIET.load(Ordering::Relaxed) && !std::io::stderr().is_terminal() {
        pb.enable_steady_tick(Duration::from_secs(1));
    }
}

/// Clears `pb` and, in the plain-line mode when it ran at least one interval (so lines of it
/// were printed), prints `last` as its closing line (a solve that ends between two lines still
/// says where it ended).
pub(crate) fn finish_with_line(pb: &ProgressBar, last: &str) {
    pb.finish_and_clear();
    if !is_quiet() && !std::io::stderr().is_terminal() && pb.elapsed() >= line_interval() {
        eprintln!("{last}");
    }
}

/// A progress bar of `len` steps labelled `what`.
pub(crate) fn bar(len: usize, what: &str) -> ProgressBar {
    let pb = new_bar(len);
    if let Some(style) = style("{msg:>14} {bar:40} {pos}/{len} [{elapsed_precise}, ETA {eta}{solver}]") {
        pb.set_style(style);
    }
    pb.set_message(what.to_string());
    start(&pb);
    pb
}

/// The bars of pipeline runs on `n` deformations: `interpolating` and `transferring` (n each),
/// then the pairs (n (n - 1) / 2) labelled with the run's name. Each bar appears at its first
/// tick; a tick of another run, or of the pairs, clears the bars before it.
pub(crate) struct PipelineBars {
    n: usize,
    state: Mutex<State>,
}

#[derive(Default)]
struct State {
    run: String,
    interpolation: Option<ProgressBar>,
    transfer: Option<ProgressBar>,
    pairs: Option<ProgressBar>,
}

impl State {
    fn clear_prepare(&mut self) {
        for b in [self.interpolation.take(), self.transfer.take()]
            .into_iter()
            .flatten()
        {
            b.finish_and_clear();
        }
    }

    fn clear(&mut self) {
        self.clear_prepare();
        if let Some(b) = self.pairs.take() {
            b.finish_and_clear();
        }
    }

    /// Makes `run` the current run: a tick of another run clears the bars before it.
    fn enter(&mut self, run: &str) {
        if self.run != run {
            self.clear();
            self.run = run.to_string();
        }
    }
}

impl PipelineBars {
    /// Bars for runs on `n` deformations.
    pub(crate) fn new(n: usize) -> PipelineBars {
        PipelineBars {
            n,
            state: Mutex::new(State::default()),
        }
    }

    /// Advances the bar of `stage` of the run `run`.
    pub(crate) fn tick(&self, run: &str, stage: Stage) {
        let mut s = self.state.lock().unwrap_or_else(|e| e.into_inner());
        s.enter(run);
        let n = self.n;
        match stage {
            Stage::Interpolation => s
                .interpolation
                .get_or_insert_with(|| bar(n, "interpolating"))
                .inc(1),
            Stage::Transfer => s.transfer.get_or_insert_with(|| bar(n, "transferring")).inc(1),
            Stage::Similarity => {
                s.clear_prepare();
                s.pairs
                    .get_or_insert_with(|| bar(n * n.saturating_sub(1) / 2, run))
                    .inc(1)
            }
        }
    }

    /// Shows the library's similarity-run [`Event`] on the bars of the run `run`: preparation
    /// stages and pairs advance their bars; a journal opened with `recorded` of `total` pairs
    /// done starts the pairs bar there.
    pub(crate) fn event(&self, run: &str, e: &Event<'_>) {
        match *e {
            Event::Prepared { stage, .. } => self.tick(run, stage),
            Event::Pair(_) => self.tick(run, Stage::Similarity),
            Event::Journal { recorded, total, .. } => {
                let mut s = self.state.lock().unwrap_or_else(|e| e.into_inner());
                s.enter(run);
                s.clear();
                let pb = bar(total, run);
                pb.set_position(recorded as u64);
                s.pairs = Some(pb);
            }
        }
    }

    /// Clears every bar.
    pub(crate) fn finish(&self) {
        self.state.lock().unwrap_or_else(|e| e.into_inner()).clear();
    }
}

#[cfg(test)]
mod tests {
    use super::nothing_done;

    #[test]
    fn lines_without_progress_are_recognized() {
        assert!(nothing_done("pairs ░░░░ 0/1128 [00:00:00, ETA 0s]"));
        assert!(!nothing_done("pairs ██░░ 307/1128 [00:00:10, ETA 27s]"));
        assert!(!nothing_done("pairs ██░░ 10/1128 [00:00:10, ETA 27s]"));
        assert!(!nothing_done("a 0/b path"));
    }
}
