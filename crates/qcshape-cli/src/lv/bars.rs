//! Progress bars for the library's progress callbacks ([`qcshape_studies::lv::study::Tick`]): one bar
//! per stage name, created at its first tick, all cleared by `Tick::DONE`.

use std::sync::Mutex;

use indicatif::ProgressBar;
use qcshape_studies::lv::study::Tick;

use crate::progress::bar;

/// The bars of the running stages.
#[derive(Default)]
pub(crate) struct Bars {
    bars: Mutex<Vec<(String, ProgressBar)>>,
}

impl Bars {
    /// Advances the bar of `t.what` (or clears every bar on `Tick::DONE`).
    pub(crate) fn tick(&self, t: Tick<'_>) {
        let mut bars = self.bars.lock().unwrap_or_else(|e| e.into_inner());
        if t.what.is_empty() {
            for (_, b) in bars.drain(..) {
                b.finish_and_clear();
            }
            return;
        }
        match bars.iter().find(|(w, _)| w == t.what) {
            Some((_, b)) => b.inc(1),
            None => {
                let b = bar(t.total, t.what);
                b.inc(1);
                bars.push((t.what.to_string(), b));
            }
        }
    }
}
