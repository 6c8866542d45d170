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

/// A file at the workspace's root.
fn root_file(name: &str) -> String {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/..");
    let path = std::path::Path::new(path).join(name);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn the_license_texts_and_the_citation_match_the_manifest() {
    // Cargo.toml's `license` names the texts the repository must carry.
    let license = env!("CARGO_PKG_LICENSE");
    let ids: Vec<&str> = license.split(" OR ").collect();
    assert_eq!(
        ids,
        ["MIT", "Apache-2.0"],
        "Cargo.toml's license changed: {license}"
    );
    let mit = root_file("LICENSE-MIT");
    assert!(
        mit.starts_with("MIT License\n\nCopyright (c) the swarmfl developers\n"),
        "{mit}"
    );
    assert!(mit.contains("THE SOFTWARE IS PROVIDED \"AS IS\""), "{mit}");
    let apache = root_file("LICENSE-APACHE");
    assert!(apache.contains("Apache License\n                           Version 2.0, January 2004"));
    assert!(apache.contains("END OF TERMS AND CONDITIONS"));

    // CITATION.cff: CFF 1.2.0, this version, the same licenses, and the paper to cite.
    let cff = root_file("CITATION.cff");
    let lines: Vec<&str> = cff.lines().collect();
    assert!(lines.contains(&"cff-version: 1.2.0"), "{cff}");
    let version = format!("version: {}", env!("CARGO_PKG_VERSION"));
    assert!(
        lines.contains(&version.as_str()),
        "CITATION.cff should say `{version}`"
    );
    for id in ids {
        assert!(
            lines.contains(&format!("  - {id}").as_str()),
            "CITATION.cff's license: {id}"
        );
    }
    assert!(lines.contains(&"preferred-citation:"), "{cff}");
    assert!(
        cff.contains(
            "title: Securing Federated Learning in Robot Swarms using Blockchain Technology"
        ),
        "{cff}"
    );
}
