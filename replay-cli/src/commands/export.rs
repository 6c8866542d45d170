//! `swarmfl export`: CSV tables of a run ([`swarmfl_study::export`]), and a line that says
//! what it wrote.

use std::process::ExitCode;

use swarmfl_study::export::export;

use crate::cli::ExportArgs;
use crate::progress::Bar;

/// Runs `swarmfl export`.
pub fn command(args: ExportArgs) -> anyhow::Result<ExitCode> {
    println!("{}", export(&args.log, &args.out, &Bar::new(false))?);
    Ok(ExitCode::SUCCESS)
}
