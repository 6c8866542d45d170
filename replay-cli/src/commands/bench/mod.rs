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
    } = args;
    match target {
        BenchTarget::Scale => scale::run(
            &scale::parse_robots(robots.as_deref().unwrap_or(scale::DEFAULT_ROBOTS))?,
            duration_s.unwrap_or(scale::DEFAULT_DURATION_S),
            json,
        )?,
        _ if robots.is_some() || duration_s.is_some() => {
            anyhow::bail!("--robots and --duration belong to `bench scale` only")
        }
        BenchTarget::World => world::run(json)?,
        BenchTarget::Train => train::run(json)?,
    }
    Ok(ExitCode::SUCCESS)
}

/// Runs the hidden `swarmfl bench-scale-one`: one size of `bench scale`, in its own process.
pub fn scale_one(args: BenchScaleOneArgs) -> anyhow::Result<ExitCode> {
    scale::one(args.robots, args.duration_s)?;
    Ok(ExitCode::SUCCESS)
}
