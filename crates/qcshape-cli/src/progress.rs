//! Progress bars on stderr (hidden when stderr is not a terminal) for the library's progress
//! callbacks.

use std::sync::Mutex;

use indicatif::{ProgressBar, ProgressStyle};
use qcshape::similarity::Stage;

/// A progress bar of `len` steps labelled `what`.
pub(crate) fn bar(len: usize, what: &str) -> ProgressBar {
    let pb = ProgressBar::new(len as u64);
    if let Ok(style) =
        ProgressStyle::with_template("{msg:>14} {bar:40} {pos}/{len} [{elapsed_precise}, ETA {eta}]")
    {
        pb.set_style(style);
    }
    pb.set_message(what.to_string());
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
        if s.run != run {
            s.clear();
            s.run = run.to_string();
        }
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

    /// Clears every bar.
    pub(crate) fn finish(&self) {
        self.state.lock().unwrap_or_else(|e| e.into_inner()).clear();
    }
}
