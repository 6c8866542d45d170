//! `swarmfl replay`: fold a log and check every checkpoint, or re-simulate it record by record.

use std::process::ExitCode;

use swarmfl_core::byzantine::plugin::Plugins;
use swarmfl_core::log::LogReader;
use swarmfl_core::{metrics, replay};

use crate::cli::ReplayArgs;

/// Runs `swarmfl replay` and prints what it verified.
pub fn command(args: ReplayArgs) -> anyhow::Result<ExitCode> {
    let ReplayArgs { log, resimulate } = args;
    // A re-simulation runs every plug-in, a fold only a plug-in rule (the contract's
    // aggregates); the Python package has them, the command names them rather than fail
    // somewhere in the log. A plug-in attack's log folds here: its submissions are records.
    let reader = LogReader::open(&log).map_err(replay::ReplayError::from)?;
    let name = log.display().to_string();
    if resimulate {
        replay::check_plugins(&reader, &name, &Plugins::none())?;
    } else {
        replay::check_fold_plugins(&reader, &name, &Plugins::none())?;
    }
    drop(reader);
    let report = if resimulate {
        replay::resimulate(&log)?
    } else {
        replay::replay(&log)?
    };
    let ledger = &report.state.ledger;
    let height = ledger.head(metrics::best_node(ledger)).1;
    println!(
        "{}",
        verdict(
            &Verified {
                records: report.records,
                sealings: report.blocks,
                height,
                checkpoints: report.checkpoints,
                final_hash: report.final_hash.to_string(),
            },
            resimulate,
            &log.display().to_string(),
        )
    );
    Ok(ExitCode::SUCCESS)
}

/// What a replay checked, for its closing words.
struct Verified {
    records: u64,
    sealings: u64,
    height: u64,
    checkpoints: u64,
    final_hash: String,
}

/// The closing words of `replay`: no more than the mode checked. A fold shows that the hash
/// chain is intact and that the events reproduce every checkpoint; the chain is unkeyed, so
/// it cannot show that the header (seed, configuration) or the records are the ones the run
/// made: whoever edits a log can recompute the chain. Only a re-simulation shows that.
fn verdict(v: &Verified, resimulate: bool, log: &str) -> String {
    let counts = format!(
        "{} records, {} sealings on all forks (every block any node sealed, genesis apart; the \
         final canonical chain has height {})",
        v.records, v.sealings, v.height
    );
    if resimulate {
        format!(
            "bit-exact: {counts}: every record re-simulated from the header's seed and \
             configuration and equal byte for byte ({} checkpoints verified); final hash {}",
            v.checkpoints, v.final_hash
        )
    } else {
        format!(
            "consistent: {counts}: hash chain and checkpoints consistent (the events fold to \
             all {} checkpoints); final hash {}\nheader not authenticated: the hash chain is \
             not keyed, so a log whose header or records were edited and its chain recomputed \
             also passes; use `swarmfl replay --resimulate {log}` to check that the records \
             are those of the header's seed and configuration",
            v.checkpoints, v.final_hash
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_replay_claims_consistency_not_bit_exactness() {
        let v = Verified {
            records: 10,
            sealings: 3,
            height: 2,
            checkpoints: 4,
            final_hash: "ab12".to_string(),
        };
        let fold = verdict(&v, false, "r/run.swlog");
        assert!(!fold.contains("bit-exact"), "{fold}");
        assert!(!fold.contains("verified"), "{fold}");
        for words in [
            "consistent: 10 records, 3 sealings on all forks",
            "the final canonical chain has height 2",
            "hash chain and checkpoints consistent (the events fold to all 4 checkpoints)",
            "final hash ab12",
            "header not authenticated",
            "use `swarmfl replay --resimulate r/run.swlog` to check",
        ] {
            assert!(fold.contains(words), "{words:?} in {fold}");
        }
        let resim = verdict(&v, true, "r/run.swlog");
        assert!(resim.starts_with("bit-exact: 10 records"), "{resim}");
        assert!(resim.contains("every record re-simulated"), "{resim}");
        assert!(!resim.contains("not authenticated"), "{resim}");
    }
}
