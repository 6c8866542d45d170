//! `swarmfl bench train`: one local training of the reference workload (issue: learning).

/// Runs the training benchmark and prints its figures (JSON with `json`).
pub fn run(json: bool) -> anyhow::Result<()> {
    let _ = json;
    anyhow::bail!("the training benchmark is not built yet")
}
