//! How a long job tells its front end how far it is, and what it has to say on the way. The
//! study crate prints nothing: `replay-cli` draws a bar or plain lines on stderr
//! (`replay-cli/src/progress.rs`), the Python package plain lines or nothing.
//!
//! Plain lines follow one rule ([`Ticker`]): a line every [`LINE_PERIOD_S`] seconds of wall
//! time, however far the work has come, plus a first and a last line. A long run is therefore
//! never silent for more than a few seconds (a share of the work would be: a tenth of a
//! 1e7-second run takes minutes), and a short one prints at most one line per period.

/// The front end of a job: it starts a meter per piece of work and takes the lines the job has
/// to say (a warning, a replaced folder, a task that failed).
pub trait Watch: Sync {
    /// A meter for `total` `unit`s of `label` (say `run paper seed 1`, `sim s`).
    fn start(&self, label: &str, unit: &'static str, total: u64) -> Box<dyn Meter>;
    /// A line about the job as it goes (what it starts, where it forks); a quiet front end
    /// leaves it out.
    fn say(&self, line: &str);
    /// A line the user must see even when the front end is quiet: a folder whose run was
    /// replaced, a warning.
    fn warn(&self, line: &str);
}

/// How far one piece of work is.
pub trait Meter: Send {
    /// `done` units so far; `message` (say a rate) is asked for only when it is shown.
    fn set(&mut self, done: u64, message: &dyn Fn() -> String);
    /// A line for the user that does not disturb the meter.
    fn say(&self, line: &str);
    /// The work ended after `done` units.
    fn finish(self: Box<Self>, done: u64);
}

/// A front end that shows nothing and says nothing (the runs of a sweep, of a recheck).
#[derive(Clone, Copy, Debug, Default)]
pub struct Quiet;

impl Watch for Quiet {
    fn start(&self, _label: &str, _unit: &'static str, _total: u64) -> Box<dyn Meter> {
        Box::new(Quiet)
    }

    fn say(&self, _line: &str) {}

    fn warn(&self, _line: &str) {}
}

impl Meter for Quiet {
    fn set(&mut self, _done: u64, _message: &dyn Fn() -> String) {}

    fn say(&self, _line: &str) {}

    fn finish(self: Box<Self>, _done: u64) {}
}

/// Warns on `watch` that the log of `index` is truncated and that what follows is of its
/// intact prefix.
pub fn warn_if_truncated(watch: &dyn Watch, index: &swarmfl_core::inspect::RunIndex) {
    if let Some(why) = &index.truncated {
        watch.warn(&format!("warning: {why}"));
        watch.warn(&format!(
            "warning: using the intact prefix: {} records, the chain up to block {} (t = {:.3} s); \
             the run's later blocks are missing",
            index.records,
            index.last_height(),
            index.chain.last().map_or(0.0, |r| r.time.secs())
        ));
    }
}

/// Seconds of wall time between two plain progress lines.
pub const LINE_PERIOD_S: f64 = 5.0;

/// Decides when a plain progress line is due and writes it. Pure: the caller passes the time.
#[derive(Clone, Debug)]
pub struct Ticker {
    /// What is progressing, e.g. `run paper seed 1`.
    label: String,
    /// The unit of `done` and `total`, e.g. `sim s` or `tasks`.
    unit: &'static str,
    /// The total amount of work.
    total: u64,
    /// When the last line was written (the first line at 0), seconds since the start.
    last_line_s: f64,
}

impl Ticker {
    /// A ticker for `total` units of work.
    pub fn new(label: impl Into<String>, unit: &'static str, total: u64) -> Ticker {
        Ticker {
            label: label.into(),
            unit,
            total: total.max(1),
            last_line_s: 0.0,
        }
    }

    /// The first line.
    pub fn start_line(&self) -> String {
        format!("{}: started, {} {}", self.label, self.total, self.unit)
    }

    /// The line due at `elapsed_s` with `done` units finished: one when [`LINE_PERIOD_S`] have
    /// passed since the last line, whatever `done` is.
    pub fn tick(&mut self, done: u64, elapsed_s: f64) -> Option<String> {
        if elapsed_s - self.last_line_s < LINE_PERIOD_S {
            return None;
        }
        self.last_line_s = elapsed_s;
        Some(self.line(done, elapsed_s))
    }

    /// A progress line: percentage, amounts, elapsed time and the estimated time left.
    pub fn line(&self, done: u64, elapsed_s: f64) -> String {
        let done = done.min(self.total);
        let eta = if done == 0 {
            "?".to_string()
        } else {
            seconds(elapsed_s * (self.total - done) as f64 / done as f64)
        };
        format!(
            "{}: {:>3} % ({done}/{} {}) after {}, ETA {eta}",
            self.label,
            done * 100 / self.total,
            self.total,
            self.unit,
            seconds(elapsed_s)
        )
    }
}

/// `75 s`, `4 min 05 s`, `1 h 02 min`.
pub fn seconds(s: f64) -> String {
    let s = s.max(0.0).round() as u64;
    match s {
        0..60 => format!("{s} s"),
        60..3600 => format!("{} min {:02} s", s / 60, s % 60),
        _ => format!("{} h {:02} min", s / 3600, (s % 3600) / 60),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Drives a ticker with a simulated clock: `rate` units per second.
    fn lines(total: u64, duration_s: f64) -> Vec<(f64, String)> {
        let mut t = Ticker::new("run", "sim s", total);
        let mut out = Vec::new();
        let steps = 10_000;
        for k in 0..=steps {
            let elapsed = duration_s * k as f64 / steps as f64;
            let done = total * k / steps;
            if let Some(l) = t.tick(done, elapsed) {
                out.push((elapsed, l));
            }
        }
        out
    }

    #[test]
    fn long_runs_are_never_silent_for_more_than_a_period() {
        // A 1e6-second run that takes 310 s of wall time: a tenth of it is 31 s, but a line
        // comes every 5 s from the start.
        let step_s = 310.0 / 10_000.0;
        let long = lines(1_000_000, 310.0);
        assert!(long[0].0 <= LINE_PERIOD_S + step_s, "{long:?}");
        assert!(
            long[0].1.contains("  1 % (16200/1000000 sim s) after 5 s"),
            "{}",
            long[0].1
        );
        for pair in long.windows(2) {
            let gap = pair[1].0 - pair[0].0;
            assert!(gap <= LINE_PERIOD_S + step_s, "{pair:?}");
            assert!(gap >= LINE_PERIOD_S, "{pair:?}");
        }
        assert_eq!(long.len(), 61, "{:?}", long.last());
        // 12 s of wall time: a line at 5 s and at 10 s, never two within a period.
        let short = lines(1000, 12.0);
        assert_eq!(short.len(), 2, "{short:?}");
        assert!(short[1].0 - short[0].0 >= LINE_PERIOD_S);
        // Nothing before 5 s however fast the work goes.
        assert!(lines(1000, 4.9).is_empty());
    }

    #[test]
    fn lines_say_how_far_and_how_long_is_left() {
        let t = Ticker::new("sweep e2-faulty", "tasks", 160);
        assert_eq!(
            t.line(40, 600.0),
            "sweep e2-faulty:  25 % (40/160 tasks) after 10 min 00 s, ETA 30 min 00 s"
        );
        assert!(t.line(0, 1.0).ends_with("ETA ?"));
        assert_eq!(seconds(3725.0), "1 h 02 min");
    }
}
