//! `swarmfl view`: writes a run's viewer ([`swarmfl_study::view`]) and says what it holds.

use std::process::ExitCode;

use swarmfl_study::blame::read_report;
use swarmfl_study::view::view_blamed;

use crate::cli::ViewArgs;
use crate::progress::Bar;

/// Runs `swarmfl view`: writes the page and says what it holds.
pub fn command(args: ViewArgs) -> anyhow::Result<ExitCode> {
    let ViewArgs { log, out, blame } = args;
    let blame = blame.as_deref().map(read_report).transpose()?;
    let v = view_blamed(&log, &out, blame.as_ref(), &Bar::new(false))?;
    if let Some(note) = &v.rule_note {
        println!(
            "wrote {} ({:.1} MB: {} frames, one every {} s): the world only. {note}",
            out.display(),
            v.bytes as f64 / 1.0e6,
            v.frames,
            v.frame_s,
        );
        return Ok(ExitCode::SUCCESS);
    }
    if let Some((kind, count)) = v.aggregations {
        println!(
            "wrote {} ({:.1} MB: {} frames, one every {} s; a {kind} run has no blocks: its {count} \
             aggregations, as summary.json counts them); open it in a browser",
            out.display(),
            v.bytes as f64 / 1.0e6,
            v.frames,
            v.frame_s,
        );
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "wrote {} ({:.1} MB: {} frames, one every {} s plus one per block of the final \
         chain; {} sealings on all forks (every block any node sealed, genesis apart), final \
         canonical chain height {}); open it in a browser",
        out.display(),
        v.bytes as f64 / 1.0e6,
        v.frames,
        v.frame_s,
        v.sealings,
        v.height
    );
    Ok(ExitCode::SUCCESS)
}
