//! `swarmfl fixtures regenerate`: re-make the regression fixtures listed in
//! `fixtures/manifest.toml` and their expected hashes in `fixtures/expected.toml`.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use serde::{Deserialize, Serialize};
use swarmfl_core::config::Config;

use crate::cli::{FixturesAction, FixturesArgs};

/// The fixture list.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// The fixtures.
    pub fixture: Vec<FixtureSpec>,
}

/// One fixture run.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FixtureSpec {
    /// File stem of the log.
    pub name: String,
    /// Preset.
    pub preset: String,
    /// Seed.
    pub seed: u64,
    /// `key=value` overrides.
    pub overrides: Vec<String>,
    /// Whether the test also re-simulates it.
    #[serde(default)]
    pub resimulate: bool,
}

/// What a fixture must replay to.
#[derive(Debug, Serialize)]
struct Expected {
    name: String,
    final_hash: String,
    records: u64,
    blocks: u64,
    resimulate: bool,
}

/// Runs `swarmfl fixtures`.
pub fn command(args: FixturesArgs) -> anyhow::Result<ExitCode> {
    match args.action {
        FixturesAction::Regenerate => regenerate(&args.dir)?,
    }
    Ok(ExitCode::SUCCESS)
}

/// Regenerates every fixture under `dir` (the `fixtures/` folder).
pub fn regenerate(dir: &Path) -> anyhow::Result<()> {
    let manifest_path = dir.join("manifest.toml");
    let text = std::fs::read_to_string(&manifest_path)
        .with_context(|| format!("cannot read {}", manifest_path.display()))?;
    let manifest: Manifest =
        toml::from_str(&text).with_context(|| format!("invalid {}", manifest_path.display()))?;
    let logs = dir.join("logs");
    std::fs::create_dir_all(&logs)?;
    let scratch = std::env::temp_dir().join(format!("swarmfl-fixtures-{}", std::process::id()));
    let mut expected = Vec::new();
    for spec in &manifest.fixture {
        let config = Config::resolve(Some(&spec.preset), None, &spec.overrides)
            .with_context(|| format!("fixture {}", spec.name))?;
        let out = scratch.join(&spec.name);
        let outcome = swarmfl_study::run::RunRequest::new(config, spec.seed, &out)
            .run(&swarmfl_study::progress::Quiet)?;
        let target: PathBuf = logs.join(format!("{}.swlog", spec.name));
        std::fs::copy(&outcome.log_path, &target)
            .with_context(|| format!("cannot write {}", target.display()))?;
        let report = swarmfl_core::replay::replay(&target)?;
        println!(
            "{:<28} {} records, {} blocks, final hash {}",
            spec.name,
            report.records,
            report.blocks,
            report.final_hash.short()
        );
        expected.push(Expected {
            name: spec.name.clone(),
            final_hash: report.final_hash.to_hex(),
            records: report.records,
            blocks: report.blocks,
            resimulate: spec.resimulate,
        });
    }
    let _ = std::fs::remove_dir_all(&scratch);
    #[derive(Serialize)]
    struct File {
        fixture: Vec<Expected>,
    }
    let body = toml::to_string(&File { fixture: expected })?;
    let header =
        "# Written by `swarmfl fixtures regenerate`: what each fixture log must replay to.\n";
    std::fs::write(dir.join("expected.toml"), format!("{header}{body}"))?;
    println!("wrote {}", dir.join("expected.toml").display());
    Ok(())
}
