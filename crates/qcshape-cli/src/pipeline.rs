//! The similarity pipeline as the commands run it: options from the command line, and the
//! library's steps (interpolation and transfer, the similarity engine with its journal) with
//! progress bars and the journal's notes.

use anyhow::Result;
use qcshape::dataset::Dataset;
use qcshape::similarity::{
    compute, prepare, Event, Outcome, PairDistance, PipelineOptions, Prepared, Run, Selection, ShareSummary,
    Sink,
};

use crate::progress::PipelineBars;

/// Interpolation and transfer with progress bars.
pub(crate) fn prepare_with_progress(data: &Dataset, opts: &PipelineOptions) -> Result<Prepared> {
    let bars = PipelineBars::new(data.deformations.len());
    let prepared = prepare(&data.deformations, opts, &|e| bars.event("pairs", &e))
        .map_err(|e| crate::template::hint(e.into()))?;
    bars.finish();
    Ok(prepared)
}

/// The similarity (eq. 13) of the `selection` of pairs of prepared deformations through the
/// library's one engine ([`compute`]), with a progress bar, recorded in `sink`; the journal's
/// notes (an earlier journal started over, torn records dropped, pairs resumed) on stderr.
/// Call [`Outcome::finish`] once the outputs are written.
pub(crate) fn matrix_with_progress(
    prepared: &Prepared,
    opts: &PipelineOptions,
    selection: Selection,
    sink: Sink,
) -> Result<Outcome> {
    let n = prepared.names.len();
    let shard = match selection {
        Selection::Shard(s) => Some(s),
        _ => None,
    };
    let resume = matches!(sink, Sink::Journal { resume: true, .. });
    let bars = PipelineBars::new(n);
    let events = |e: Event<'_>| {
        if let Event::Journal {
            path,
            recorded,
            dropped,
            total,
            discarded,
        } = e
        {
            if discarded {
                eprintln!(
                    "note: {} exists from an earlier run; starting over (use --resume to keep its pairs)",
                    path.display()
                );
            }
            for record in dropped {
                eprintln!(
                    "warning: {}: {record}; dropped, its pair is recomputed",
                    path.display()
                );
            }
            match (resume, shard) {
                (true, Some(s)) => {
                    eprintln!("resuming shard {s}: {recorded} of its {total} pairs already done")
                }
                (true, None) => eprintln!("resuming: {recorded} of {total} pairs already done"),
                _ => {}
            }
        }
        bars.event("pairs", &e);
    };
    let run = Run {
        selection,
        sink,
        cancel: None,
        events: &events,
    };
    let outcome = compute(&prepared.comparison(), opts, &run)?;
    bars.finish();
    Ok(outcome)
}

/// The L2 regularizer's share of the energy over `pairs` ([`ShareSummary`]), printed: one
/// stderr line with its distribution and, when the regularizer carries more than half of the
/// energy for more than half of the pairs, a warning naming the metric `metric`.
pub(crate) fn report_shares(pairs: &[PairDistance], metric: &str) -> ShareSummary {
    let s = ShareSummary::of(pairs);
    eprintln!("{}", s.line());
    if let Some(w) = s.warning(metric) {
        eprintln!("warning: {w}");
    }
    s
}
