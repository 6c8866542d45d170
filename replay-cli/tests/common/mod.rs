//! What the command-line tests share: running the built `swarmfl` as a user types it, reading
//! its output as text, and a scratch folder per test.

// Each test binary uses a part of this module.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// `swarmfl ARGS` run in the test's own working folder.
pub fn swarmfl(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_swarmfl"))
        .args(args)
        .output()
        .expect("running swarmfl")
}

/// `swarmfl ARGS` run in the folder `cwd` (where a default `runs/` goes).
pub fn swarmfl_in(cwd: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_swarmfl"))
        .current_dir(cwd)
        .args(args)
        .output()
        .expect("running swarmfl")
}

/// Bytes a command printed, as text.
pub fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// What a command printed on its standard output.
pub fn stdout(out: &Output) -> String {
    text(&out.stdout)
}

/// What a command printed on its standard error.
pub fn stderr(out: &Output) -> String {
    text(&out.stderr)
}

/// A fresh folder of this test binary and process under the system's temporary folder.
pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "swarmfl-{}-{name}-{}",
        env!("CARGO_CRATE_NAME"),
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}
