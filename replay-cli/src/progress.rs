//! Progress of long commands (`run`, `fork`, `sweep`) on stderr: an indicatif bar on a
//! terminal, plain lines otherwise (a batch log, `2>err.txt`, CI).
//!
//! Plain lines follow one rule, the study crate's [`Ticker`]: a line every few seconds of wall
//! time, however far the work has come, plus a first and a last line. The clock lives here,
//! never in the core: the driver only reports how far it is.

use std::io::IsTerminal;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use swarmfl_study::progress::{Meter, Ticker, Watch};

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

/// The command line's front end for a job of the study crate: a [`Progress`] per meter (a bar
/// on a terminal, plain lines otherwise, nothing when quiet), and its lines on stderr.
#[derive(Clone, Copy, Debug)]
pub struct Bar {
    quiet: bool,
}

impl Bar {
    /// Meters and lines shown unless `quiet`; warnings always.
    pub fn new(quiet: bool) -> Bar {
        Bar { quiet }
    }
}

impl Watch for Bar {
    fn start(&self, label: &str, unit: &'static str, total: u64) -> Box<dyn Meter> {
        Box::new(Progress::new(label, unit, total, self.quiet))
    }

    fn say(&self, line: &str) {
        if !self.quiet {
            eprintln!("{line}");
        }
    }

    fn warn(&self, line: &str) {
        eprintln!("{line}");
    }
}

impl Meter for Progress {
    fn set(&mut self, done: u64, message: &dyn Fn() -> String) {
        Progress::set(self, done, message);
    }

    fn say(&self, line: &str) {
        self.println(line);
    }

    fn finish(self: Box<Self>, done: u64) {
        Progress::finish(*self, done);
    }
}

/// Says on stderr that a log is truncated and that what follows is of its intact prefix.
pub fn warn_if_truncated(index: &swarmfl_core::inspect::RunIndex) {
    swarmfl_study::progress::warn_if_truncated(&Bar::new(false), index);
}
