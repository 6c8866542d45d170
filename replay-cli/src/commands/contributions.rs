//! `swarmfl contributions`: leave-one-out and Shapley values per robot (the logic is
//! `swarmfl_study::blame::contributions`).

use std::process::ExitCode;

use swarmfl_study::blame::{self, At};

use crate::cli::ContributionsArgs;
use crate::progress::Bar;

/// Runs `swarmfl contributions`.
pub fn command(args: ContributionsArgs) -> anyhow::Result<ExitCode> {
    let ContributionsArgs {
        outcome: o,
        samples,
        seed,
    } = args;
    let at = At::from_flags(o.until, o.block);
    let c = blame::contributions(
        &o.log,
        &o.outcome,
        &at,
        samples,
        seed,
        &Bar::new(o.quiet || o.json),
    )?;
    if o.json {
        println!("{}", serde_json::to_string_pretty(&c)?);
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "{}: {} = {} at block {} (t = {} s){}",
        c.log,
        c.expr,
        c.outcome,
        c.block,
        c.time_s,
        c.nobody.map_or(String::new(), |v| format!(
            "; with no robot submitting: {v}"
        ))
    );
    println!(
        "{:>5} {:>4} {:>14} {:>14} {:>12}",
        "robot", "byz", "leave-one-out", "shapley", "shapley s.e."
    );
    let show = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.6e}"));
    for r in &c.robots {
        println!(
            "{:>5} {:>4} {:>14.6e} {:>14} {:>12}",
            r.robot,
            if r.byzantine { "yes" } else { "" },
            r.leave_one_out,
            show(r.shapley),
            show(r.shapley_se)
        );
    }
    println!(
        "Shapley from {} sampled orders (seed {}); sampling error: the s.e. column (largest {})",
        c.samples,
        c.seed,
        show(
            c.robots
                .iter()
                .filter_map(|r| r.shapley_se)
                .max_by(f64::total_cmp)
        )
    );
    println!(
        "cost: {} counterfactual runs, {:.1} s wall, {:.1} s CPU",
        c.counterfactuals, c.wall_s, c.cpu_s
    );
    Ok(ExitCode::SUCCESS)
}
