//! `swarmfl --version` names the commit the binary was built from (issue #53): the commit every
//! log's header records, so a researcher can tell which code made a number.

use std::process::Command;

/// `git rev-parse HEAD` of the source tree, when git knows it.
fn source_commit() -> Option<String> {
    let out = Command::new("git")
        .args(["rev-parse", "HEAD"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .ok()?;
    let commit = String::from_utf8_lossy(&out.stdout).trim().to_owned();
    (out.status.success() && !commit.is_empty()).then_some(commit)
}

#[test]
fn version_names_the_crate_version_and_the_commit_it_was_built_from() {
    let expected = match source_commit() {
        Some(commit) => format!("swarmfl {} (commit {commit})\n", env!("CARGO_PKG_VERSION")),
        None => format!(
            "swarmfl {} (commit unknown: built outside a git checkout)\n",
            env!("CARGO_PKG_VERSION")
        ),
    };
    for flag in ["--version", "-V"] {
        let out = Command::new(env!("CARGO_BIN_EXE_swarmfl"))
            .arg(flag)
            .output()
            .expect("running swarmfl");
        assert!(out.status.success(), "swarmfl {flag}: {}", out.status);
        assert_eq!(
            String::from_utf8_lossy(&out.stdout),
            expected,
            "swarmfl {flag}"
        );
    }
}
