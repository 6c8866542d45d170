//! `swarmfl config`: the fully resolved configuration as TOML.

use std::process::ExitCode;

use crate::cli::ConfigArgs;

/// Runs `swarmfl config`.
pub fn command(args: &ConfigArgs) -> anyhow::Result<ExitCode> {
    let config = args.resolve()?;
    print!("{}", config.to_toml_full());
    Ok(ExitCode::SUCCESS)
}
