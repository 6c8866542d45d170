//! `swarmfl data-volume`: how much trajectory data the robots collect
//! ([`swarmfl_study::data_volume`]), as a table or as JSON.

use std::process::ExitCode;

use swarmfl_core::config::Preset;
use swarmfl_study::data_volume::{behaviours, list, measure, table, Plan};

use crate::cli::DataVolumeArgs;

/// Runs `swarmfl data-volume`.
pub fn command(args: DataVolumeArgs) -> anyhow::Result<ExitCode> {
    let base = args.config.resolve()?;
    let plan = Plan {
        robots: list("robots", &args.robots)?,
        seeds: list("seeds", &args.seeds)?,
        behaviours: behaviours(&args.behaviours)?,
        duration_s: args.duration_s,
    };
    let rows = measure(&plan, |behaviour| {
        if args.experiments {
            let mut named = args.config.clone();
            named.preset = Some(Preset::flowfl_experiment(behaviour).name().to_string());
            named.resolve()
        } else {
            Ok(base.clone())
        }
    })?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
    } else {
        let presets = if args.experiments {
            "each behaviour's Flow-FL experiment (flowfl, flowfl-flocking, flowfl-foraging, flowfl-mixed)".to_string()
        } else {
            format!("preset {}", base.preset)
        };
        print!("{}", table(&rows, &presets, &plan));
    }
    Ok(ExitCode::SUCCESS)
}
