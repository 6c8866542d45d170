//! `swarmfl blame`: each robot's influence on an outcome, by exact counterfactual
//! re-simulation (the logic is `swarmfl_study::blame`).

use std::process::ExitCode;

use swarmfl_study::blame::{self, At, BlameReport, BlameRequest};

use crate::cli::BlameArgs;
use crate::progress::Bar;

/// Runs `swarmfl blame`.
pub fn command(args: BlameArgs) -> anyhow::Result<ExitCode> {
    let BlameArgs {
        outcome: o,
        robots,
        no_honest,
    } = args;
    let request = BlameRequest {
        outcome: o.outcome,
        at: At::from_flags(o.until, o.block),
        robots: (!robots.is_empty()).then_some(robots),
        as_honest: !no_honest,
    };
    let report = blame::blame(&o.log, &request, &Bar::new(o.quiet || o.json))?;
    if o.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print_table(&report);
    }
    Ok(ExitCode::SUCCESS)
}

/// The ranking as a table, then the cost.
fn print_table(r: &BlameReport) {
    println!(
        "{}: {} = {} at block {} (t = {} s)",
        r.log, r.expr, r.outcome, r.block, r.time_s
    );
    println!(
        "{:>5} {:>4} {:>14} {:>14} {:>14} {:>5} {:>9} {:>8}  accepted rounds",
        "robot", "byz", "influence", "without", "as if honest", "subm", "accepted", "outliers"
    );
    for b in &r.robots {
        println!(
            "{:>5} {:>4} {:>14.6e} {:>14.6e} {:>14} {:>5} {:>9} {:>8}  {}",
            b.robot,
            if b.byzantine { "yes" } else { "" },
            b.influence,
            b.without,
            b.influence_as_honest
                .map_or(String::new(), |v| format!("{v:.6e}")),
            b.submissions,
            b.accepted_rounds.len(),
            b.outlier_rounds.len(),
            rounds(&b.accepted_rounds)
        );
    }
    println!(
        "cost: {} counterfactual runs, {:.1} s wall, {:.1} s CPU",
        r.counterfactuals, r.wall_s, r.cpu_s
    );
}

/// A list of rounds, shortened past 12.
fn rounds(list: &[u64]) -> String {
    let shown: Vec<String> = list.iter().take(12).map(u64::to_string).collect();
    let more = list.len().saturating_sub(12);
    if more > 0 {
        format!("{} (+{more})", shown.join(","))
    } else {
        shown.join(",")
    }
}
