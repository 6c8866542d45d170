//! `swarmfl traffic`: what the radio and the chain carry over time ([`swarmfl_study::traffic`]),
//! as tables, CSV or a study folder.

use std::process::ExitCode;

use swarmfl_core::SimTime;
use swarmfl_study::traffic::{csv_text, measure, tables, write_study};

use crate::cli::TrafficArgs;
use crate::progress::Bar;

/// Runs `swarmfl traffic`.
pub fn command(args: TrafficArgs) -> anyhow::Result<ExitCode> {
    let every = SimTime((args.every * 1000.0).round() as u64);
    let runs = measure(&args.inputs, every, &Bar::new(false))?;
    match (&args.out, args.csv) {
        (Some(out), _) => print!("{}", write_study(&runs, out)?),
        (None, true) => print!("{}", csv_text(&runs)?),
        (None, false) => print!("{}", tables(&runs)),
    }
    Ok(ExitCode::SUCCESS)
}
