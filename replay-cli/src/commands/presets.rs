//! `swarmfl presets`: the presets, one a line with its description.

use std::process::ExitCode;

use swarmfl_core::config::Preset;

/// Runs `swarmfl presets`.
pub fn command() -> anyhow::Result<ExitCode> {
    for preset in Preset::ALL {
        println!("{:<14} {}", preset.name(), preset.description());
    }
    Ok(ExitCode::SUCCESS)
}
