//! `swarmfl bench world`: physics + sensing + data throughput (issue: the world).

/// Runs the world benchmark and prints its figures (JSON with `json`).
pub fn run(json: bool) -> anyhow::Result<()> {
    let _ = json;
    anyhow::bail!("the world benchmark is not built yet")
}
