//! `swarmfl ranking`: token gains of Byzantine and honest robots over logs
//! ([`swarmfl_study::ranking`]).

use std::process::ExitCode;

use swarmfl_study::ranking::ranking;

use crate::cli::RankingArgs;
use crate::progress::Bar;

/// Runs `swarmfl ranking`.
pub fn command(args: RankingArgs) -> anyhow::Result<ExitCode> {
    let summary = ranking(&args.inputs, &args.out, args.submissions, &Bar::new(false))?;
    print!("{summary}");
    Ok(ExitCode::SUCCESS)
}
