//! `swarmfl report`: a sweep's report ([`swarmfl_study::report`]); prints every file it wrote.

use std::process::ExitCode;

use swarmfl_study::report::{make, written_list};

use crate::cli::ReportArgs;

/// Runs `swarmfl report`: prints every file it wrote, one a line.
pub fn command(args: ReportArgs) -> anyhow::Result<ExitCode> {
    let files = make(&args.dir, &args.out)?;
    print!("{}", written_list(&args.out, &files));
    Ok(ExitCode::SUCCESS)
}
