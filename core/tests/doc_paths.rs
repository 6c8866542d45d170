//! The repository documents itself, and no document points at a file a clone does not have.
//!
//! Every Markdown file of the repository (outside `target/`, hidden folders and dependency
//! folders) is read, and the test fails, naming the file, line and path, when
//! - a relative link `[text](path)` does not resolve (from the linking file's folder), or
//! - an inline code span that names a path under one of the repository's own top-level folders
//!   (`core/src/sim/mod.rs`, `scripts/remake-studies.sh`, `reproduction/e4-benchmark/results`)
//!   names none.
//!
//! A span with a placeholder (`<`, `*`, `{`, `$`) is a pattern, not a path, and is skipped; a
//! `:line` or `#anchor` suffix is dropped. Go files are go-ethereum's (docs/CONTRACT.md cites
//! its sources, whose `core/` is not ours): this repository has none.

use std::path::{Path, PathBuf};

/// Folders that hold no document of ours.
const SKIP: &[&str] = &["target", "node_modules", "__pycache__"];

fn markdown_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("a directory entry").path())
        .collect();
    entries.sort();
    for path in entries {
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
        if path.is_dir() {
            if !name.starts_with('.') && !SKIP.contains(&name) {
                markdown_files(&path, out);
            }
        } else if name.ends_with(".md") {
            out.push(path);
        }
    }
}

/// The repository's own top-level folders (a path in a code span must start with one).
fn top_folders(root: &Path) -> Vec<String> {
    let mut tops: Vec<String> = std::fs::read_dir(root)
        .expect("the repository root")
        .map(|e| e.expect("a directory entry").path())
        .filter(|p| p.is_dir())
        .filter_map(|p| p.file_name()?.to_str().map(str::to_owned))
        .filter(|n| !n.starts_with('.') && !SKIP.contains(&n.as_str()))
        .collect();
    tops.push(".ci".into());
    tops
}

/// The targets of relative Markdown links `](target)` on a line.
fn links(line: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let mut rest = line;
    while let Some(i) = rest.find("](") {
        let after = &rest[i + 2..];
        let end = after.find(')').unwrap_or(after.len());
        let target = after[..end].split_whitespace().next().unwrap_or("");
        let is_url = target
            .split_once(':')
            .is_some_and(|(scheme, _)| scheme.chars().all(|c| c.is_ascii_alphabetic()));
        if !target.is_empty() && !target.starts_with('#') && !is_url {
            out.push(target.split('#').next().unwrap_or(target));
        }
        rest = &after[end..];
    }
    out
}

/// The contents of the inline code spans of a line (single backticks).
fn code_spans(line: &str) -> Vec<&str> {
    line.split('`').skip(1).step_by(2).collect()
}

#[test]
fn documents_name_only_files_a_clone_has() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("core sits in the workspace");
    let tops = top_folders(root);
    let mut files = Vec::new();
    markdown_files(root, &mut files);
    assert!(
        files.len() > 10,
        "found only {} Markdown files",
        files.len()
    );
    let mut missing = Vec::new();
    for file in &files {
        let text = std::fs::read_to_string(file).expect("a readable document");
        let dir = file.parent().expect("a file has a folder");
        let shown = file
            .strip_prefix(root)
            .unwrap_or(file)
            .display()
            .to_string();
        let mut fenced = false;
        for (n, line) in text.lines().enumerate() {
            if line.trim_start().starts_with("```") {
                fenced = !fenced;
                continue;
            }
            if fenced {
                continue;
            }
            for target in links(line) {
                if !dir.join(target).exists() {
                    missing.push(format!("{shown}:{}: link ({target})", n + 1));
                }
            }
            for span in code_spans(line) {
                let path = span.trim_end_matches(['.', ',', ';']);
                let path = path.split(['#', ':']).next().unwrap_or(path);
                let Some((first, _)) = path.split_once('/') else {
                    continue;
                };
                if !tops.iter().any(|t| t == first)
                    || path.contains(char::is_whitespace)
                    || path.contains(['<', '*', '{', '$'])
                    || path.ends_with(".go")
                {
                    continue;
                }
                if !root.join(path).exists() {
                    missing.push(format!("{shown}:{}: `{span}`", n + 1));
                }
            }
        }
    }
    assert!(
        missing.is_empty(),
        "documents name {} path(s) that this checkout does not have (fix the path, or write a \
         pattern with <placeholders>):\n{}",
        missing.len(),
        missing.join("\n")
    );
}
