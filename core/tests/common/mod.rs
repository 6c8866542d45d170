//! Helpers shared by core's integration tests.

use std::path::PathBuf;

use swarmfl_core::config::Config;
use swarmfl_core::event::Record;
use swarmfl_core::log::{Header, LogWriter};

/// Writes `records` of a run of `config` and `seed` as a log in a fresh temporary folder named
/// after `name`, and returns its path.
pub fn write_log(name: &str, config: &Config, seed: u64, records: &[Record]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("swarmfl-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("run.swlog");
    let mut w = LogWriter::create(&path, &Header::new(seed, config.to_toml())).unwrap();
    for r in records {
        w.append(r).unwrap();
    }
    w.finish().unwrap();
    path
}
