//! `swarmfl replay`: fold a log and check every checkpoint, or re-simulate it record by record.

use std::process::ExitCode;

use swarmfl_core::byzantine::plugin::Plugins;
use swarmfl_core::log::LogReader;
use swarmfl_core::replay;

use crate::cli::ReplayArgs;

/// Runs `swarmfl replay` and prints what it verified.
pub fn command(args: ReplayArgs) -> anyhow::Result<ExitCode> {
    let ReplayArgs { log, resimulate } = args;
    // A run with plug-ins (the Python package's attacks) is replayed from Python, which has
    // them: the command names them rather than fail somewhere in the log.
    let reader = LogReader::open(&log).map_err(replay::ReplayError::from)?;
    replay::check_plugins(&reader, &log.display().to_string(), &Plugins::none())?;
    drop(reader);
    let report = if resimulate {
        replay::resimulate(&log)?
    } else {
        replay::replay(&log)?
    };
    println!(
        "bit-exact: {} records, {} sealings on all forks ({} checkpoints verified{}); final hash {}",
        report.records,
        report.blocks,
        report.checkpoints,
        if resimulate {
            ", every record re-simulated"
        } else {
            ""
        },
        report.final_hash
    );
    Ok(ExitCode::SUCCESS)
}
