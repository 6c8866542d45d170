//! `swarmfl run`: simulate a run into `DIR/run.swlog` and `DIR/summary.json`.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use swarmfl_core::config::Config;
use swarmfl_core::log::{Header, LogWriter};
use swarmfl_core::sim::{RunSummary, Sim};

/// What a finished run reports.
pub struct RunOutcome {
    /// The summary written to `summary.json`.
    pub summary: serde_json::Value,
    /// The log's path.
    pub log_path: PathBuf,
}

/// Runs `config` with `seed`, writing the log and summary into `out`.
pub fn run(config: Config, seed: u64, out: &Path, quiet: bool) -> anyhow::Result<RunOutcome> {
    std::fs::create_dir_all(out)
        .with_context(|| format!("cannot create output directory {}", out.display()))?;
    let log_path = out.join("run.swlog");
    let started = Instant::now();
    let header = Header::new(seed, config.to_toml());
    let mut writer = LogWriter::create(&log_path, &header)?;
    let mut sim = Sim::new(config.clone(), seed)?;
    let (_, total_ms) = sim.progress();
    let bar = (!quiet && std::io::stderr().is_terminal()).then(|| {
        let bar = ProgressBar::new(total_ms / 1000);
        bar.set_style(
            ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} sim s  {msg}  ETA {eta}",
            )
            .expect("valid template"),
        );
        bar
    });
    let mut last_update = Instant::now();
    while let Some(record) = sim.next() {
        writer.append(&record)?;
        if let Some(bar) = &bar {
            if last_update.elapsed().as_millis() >= 100 {
                last_update = Instant::now();
                let (done_ms, _) = sim.progress();
                bar.set_position(done_ms / 1000);
                let rate = writer.records() as f64 / started.elapsed().as_secs_f64().max(1e-9);
                bar.set_message(format!("{rate:.0} events/s"));
            }
        }
    }
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    let records = writer.records();
    let log_bytes = writer.bytes();
    let (footer, _) = writer.finish()?;
    let wall_s = started.elapsed().as_secs_f64();
    let core = RunSummary::new(&config, seed, sim.state(), records, footer.final_hash);
    let mut summary = serde_json::to_value(&core)?;
    let map = summary.as_object_mut().expect("summary is an object");
    map.insert("wall_s".into(), serde_json::json!(wall_s));
    map.insert("log_bytes".into(), serde_json::json!(log_bytes));
    let summary_path = out.join("summary.json");
    std::fs::write(
        &summary_path,
        serde_json::to_string_pretty(&summary)? + "\n",
    )
    .with_context(|| format!("cannot write {}", summary_path.display()))?;
    Ok(RunOutcome { summary, log_path })
}

/// Prints the short human summary of a run.
pub fn print_summary(outcome: &RunOutcome) {
    let s = &outcome.summary;
    println!("log:        {}", outcome.log_path.display());
    println!(
        "run:        preset {} seed {}, {} robots, {} simulated s",
        s["preset"].as_str().unwrap_or("?"),
        s["seed"],
        s["robots"],
        s["sim_time_s"]
    );
    println!("records:    {} ({} bytes)", s["records"], s["log_bytes"]);
    if let Some(world) = s.get("world") {
        println!(
            "world:      collisions {}, mean neighbours {:.2}, samples/robot/600 s {:.1}",
            world["collisions"],
            world["mean_neighbours"].as_f64().unwrap_or(0.0),
            world["samples_per_robot_per_600s"].as_f64().unwrap_or(0.0)
        );
    }
    println!("final hash: {}", s["final_hash"].as_str().unwrap_or("?"));
    println!("wall time:  {:.2} s", s["wall_s"].as_f64().unwrap_or(0.0));
}
