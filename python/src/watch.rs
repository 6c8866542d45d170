//! The Python package's front end for the study crate's jobs
//! ([`swarmfl_study::progress::Watch`]): plain progress lines on stderr, as the command prints
//! them off a terminal, or none when `quiet`; warnings always.

use std::time::Instant;

use swarmfl_study::progress::{Meter, Quiet, Ticker, Watch};

/// Plain lines on stderr unless `quiet`; warnings always.
#[derive(Clone, Copy, Debug)]
pub struct Lines {
    /// No progress lines.
    pub quiet: bool,
}

impl Watch for Lines {
    fn start(&self, label: &str, unit: &'static str, total: u64) -> Box<dyn Meter> {
        if self.quiet {
            return Box::new(Quiet);
        }
        let ticker = Ticker::new(label, unit, total);
        eprintln!("{}", ticker.start_line());
        Box::new(Plain {
            ticker,
            started: Instant::now(),
        })
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

/// A meter that prints a [`Ticker`]'s lines.
struct Plain {
    ticker: Ticker,
    started: Instant,
}

impl Meter for Plain {
    fn set(&mut self, done: u64, _message: &dyn Fn() -> String) {
        if let Some(line) = self.ticker.tick(done, self.started.elapsed().as_secs_f64()) {
            eprintln!("{line}");
        }
    }

    fn say(&self, line: &str) {
        eprintln!("{line}");
    }

    fn finish(self: Box<Self>, done: u64) {
        eprintln!(
            "{} (done)",
            self.ticker.line(done, self.started.elapsed().as_secs_f64())
        );
    }
}
