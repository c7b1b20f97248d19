//! The solver-iteration count and the keys every progress bar of the CLI shares (`{eta}`
//! averaged over finished items, `{solver}`, `{iterations}`, `{rate}`; issue 60).

use std::ops::ControlFlow;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

use indicatif::{ProgressState, ProgressStyle};
use qcshape::geodesic::Monitor;

/// Solver iterations of this command so far (every geodesic solve, all threads).
static ITERATIONS: AtomicUsize = AtomicUsize::new(0);

/// The monitor every command puts on its geodesic options
/// ([`qcshape::geodesic::GeodesicOptions::monitor`]): it counts the solver's iterations for the
/// progress lines. It never stops a solve (Ctrl-C ends the process).
pub(crate) fn monitor() -> Monitor {
    Monitor::new(|_, _| {
        ITERATIONS.fetch_add(1, Ordering::Relaxed);
        ControlFlow::Continue(())
    })
}

/// Solver iterations of this command so far.
pub(crate) fn iterations() -> usize {
    ITERATIONS.load(Ordering::Relaxed)
}

/// `template` with the keys every bar of the CLI shares: `{eta}`, the time left at the average
/// rate of the finished items (elapsed x left / done; indicatif's own estimate follows the
/// recent rate and jumped to days while a slow pair ran), `{solver}`, ", N solver
/// iterations" once a solver iterated, `{iterations}`, that count alone, and `{rate}`, the
/// iterations per second since the bar started.
pub(crate) fn style(template: &str) -> Option<ProgressStyle> {
    let style = ProgressStyle::with_template(template).ok()?;
    Some(
        style
            .with_key("eta", |s: &ProgressState, w: &mut dyn std::fmt::Write| {
                let _ = w.write_str(&smoothed_eta(s.pos(), s.len(), s.elapsed()));
            })
            .with_key("iterations", |_: &ProgressState, w: &mut dyn std::fmt::Write| {
                let _ = write!(w, "{}", iterations());
            })
            .with_key("rate", |s: &ProgressState, w: &mut dyn std::fmt::Write| {
                let secs = s.elapsed().as_secs_f64();
                if secs > 0.0 {
                    let _ = write!(w, "{:.0} iterations/s", iterations() as f64 / secs);
                }
            })
            .with_key("solver", |_: &ProgressState, w: &mut dyn std::fmt::Write| {
                let n = iterations();
                if n > 0 {
                    let _ = write!(w, ", {n} solver iterations");
                }
            }),
    )
}

/// The time left when `done` of `total` items took `elapsed`, at their average rate: "?" before
/// the first item, else like "3m 05s".
fn smoothed_eta(done: u64, total: Option<u64>, elapsed: Duration) -> String {
    let Some(total) = total else {
        return "?".into();
    };
    if done == 0 {
        return "?".into();
    }
    let left = elapsed.as_secs_f64() * total.saturating_sub(done) as f64 / done as f64;
    let s = left.round() as u64;
    match s {
        0..=59 => format!("{s}s"),
        60..=3599 => format!("{}m {:02}s", s / 60, s % 60),
        _ => format!("{}h {:02}m", s / 3600, s % 3600 / 60),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_eta_is_the_average_rate_of_finished_items() {
        use std::time::Duration;
        // 2 of 6 pairs in 165 s: 4 more at 82.5 s each (issue 60 saw "ETA 3d" here).
        assert_eq!(
            super::smoothed_eta(2, Some(6), Duration::from_secs(165)),
            "5m 30s"
        );
        assert_eq!(super::smoothed_eta(0, Some(6), Duration::from_secs(165)), "?");
        assert_eq!(super::smoothed_eta(5, Some(6), Duration::from_secs(50)), "10s");
        assert_eq!(
            super::smoothed_eta(1, Some(100), Duration::from_secs(3600)),
            "99h 00m"
        );
    }
}
