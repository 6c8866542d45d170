//! Progress of long commands (`run`, `fork`, `sweep`) on stderr: an indicatif bar on a
//! terminal, plain lines otherwise (a batch log, `2>err.txt`, CI).
//!
//! Plain lines follow one rule ([`Ticker`]): a line every [`LINE_PERIOD_S`] seconds of wall
//! time, however far the work has come, plus a first and a last line. A long run is therefore
//! never silent for more than a few seconds (a share of the work would be: a tenth of a
//! 1e7-second run takes minutes), and a short one prints at most one line per period. The
//! clock lives here, never in the core: the driver only reports how far it is.

use std::io::IsTerminal;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};

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

/// Progress on stderr: a bar on a terminal, plain lines otherwise, nothing when quiet.
pub struct Progress {
    bar: Option<ProgressBar>,
    ticker: Option<Ticker>,
    started: Instant,
    last_update: Instant,
}

impl Progress {
    /// Progress of `total` `unit`s of `label`; `quiet` shows nothing.
    pub fn new(label: &str, unit: &'static str, total: u64, quiet: bool) -> Progress {
        let terminal = std::io::stderr().is_terminal();
        let bar = (!quiet && terminal).then(|| {
            let bar = ProgressBar::new(total);
            bar.set_style(
                ProgressStyle::with_template(&format!(
                    "{{spinner}} [{{elapsed_precise}}] {{bar:40}} {{pos}}/{{len}} {unit}  {{msg}}  ETA {{eta}}"
                ))
                .expect("valid template"),
            );
            bar.set_prefix(label.to_string());
            bar
        });
        let ticker = (!quiet && !terminal).then(|| {
            let ticker = Ticker::new(label, unit, total);
            eprintln!("{}", ticker.start_line());
            ticker
        });
        let now = Instant::now();
        Progress {
            bar,
            ticker,
            started: now,
            last_update: now,
        }
    }

    /// Reports `done` units finished with a message for the bar; cheap to call often (the
    /// bar is redrawn at most every 100 ms).
    pub fn set(&mut self, done: u64, message: impl FnOnce() -> String) {
        if self.bar.is_none() && self.ticker.is_none() {
            return;
        }
        if self.last_update.elapsed().as_millis() < 100 {
            return;
        }
        self.last_update = Instant::now();
        let elapsed_s = self.started.elapsed().as_secs_f64();
        if let Some(bar) = &self.bar {
            bar.set_position(done);
            bar.set_message(message());
        }
        if let Some(ticker) = &mut self.ticker {
            if let Some(line) = ticker.tick(done, elapsed_s) {
                eprintln!("{line}");
            }
        }
    }

    /// Prints a line above the bar (or as a plain line).
    pub fn println(&self, line: &str) {
        match &self.bar {
            Some(bar) => bar.println(line),
            None => eprintln!("{line}"),
        }
    }

    /// Ends the progress: clears the bar, or writes the last plain line.
    pub fn finish(self, done: u64) {
        if let Some(bar) = self.bar {
            bar.finish_and_clear();
        }
        if let Some(ticker) = self.ticker {
            eprintln!(
                "{} (done)",
                ticker.line(done, self.started.elapsed().as_secs_f64())
            );
        }
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
