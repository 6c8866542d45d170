//! `swarmfl bench`: time one subsystem (the world, one training, whole runs at growing swarm
//! sizes) and print its figures.

mod scale;
mod train;
mod world;

use std::process::ExitCode;

use crate::cli::{BenchArgs, BenchScaleOneArgs, BenchTarget};

/// Runs `swarmfl bench`.
pub fn command(args: BenchArgs) -> anyhow::Result<ExitCode> {
    let BenchArgs {
        target,
        json,
        robots,
        duration_s,
        seed,
        set,
    } = args;
    match target {
        BenchTarget::Scale => scale::run(
            &scale::parse_robots(robots.as_deref().unwrap_or(scale::DEFAULT_ROBOTS))?,
            &scale::Workload {
                duration_s: duration_s.unwrap_or(scale::DEFAULT_DURATION_S),
                seed: seed.unwrap_or(scale::DEFAULT_SEED),
                overrides: set,
            },
            json,
        )?,
        _ if robots.is_some() || duration_s.is_some() || seed.is_some() || !set.is_empty() => {
            anyhow::bail!("--robots, --duration, --seed and --set belong to `bench scale` only")
        }
        BenchTarget::World => world::run(json)?,
        BenchTarget::Train => train::run(json)?,
    }
    Ok(ExitCode::SUCCESS)
}

/// Runs the hidden `swarmfl bench-scale-one`: one size of `bench scale`, in its own process.
pub fn scale_one(args: BenchScaleOneArgs) -> anyhow::Result<ExitCode> {
    let workload = scale::Workload {
        duration_s: args.duration_s,
        seed: args.seed,
        overrides: args.set,
    };
    scale::one(args.robots, &workload)?;
    Ok(ExitCode::SUCCESS)
}
