//! The repository documents itself, and no document points at a file a clone does not have.
//!
//! Every Markdown file of the repository is read, and the test fails, naming the file, line
//! and path, when
//! - a relative link `[text](path)` does not resolve (from the linking file's folder), or
//! - an inline code span that names a path under one of the repository's own top-level folders
//!   (`core/src/sim/mod.rs`, `scripts/remake-studies.sh`, `reproduction/e4-benchmark/results`)
//!   names none.
//!
//! What belongs to the repository is what git tracks (`git ls-files`), not what the work tree
//! holds: the main job writes `runs/`, and a document naming `runs/claim12` names a user's
//! output, not a folder of the repository, so the test must not care what a user's runs left
//! behind. Without git (a source tarball, or a checkout inside another repository's tree) the
//! work tree is walked instead, leaving out hidden folders, `target/`, and the folders the
//! root's `.gitignore` names (`/runs`, `__pycache__/`). A document git does not track yet is
//! checked once it is added.
//!
//! A span with a placeholder (`<`, `*`, `{`, `$`) is a pattern, not a path, and is skipped; a
//! `:line` or `#anchor` suffix is dropped. Go files are go-ethereum's (docs/CONTRACT.md cites
//! its sources, whose `core/` is not ours): this repository has none.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Folders that hold no document of ours, whatever `.gitignore` says.
const SKIP: &[&str] = &["target", "node_modules", "__pycache__"];

/// The repository's files, as paths relative to its root.
struct Repository {
    root: PathBuf,
    /// Every file of the repository (tracked by git, or, without git, on disk and not ignored).
    files: Vec<PathBuf>,
}

/// How the repository's files are found.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Source {
    /// `git ls-files` when `root` is a git work tree's top level, else the walk.
    GitIfPresent,
    /// The walk of the work tree, minus `.gitignore`'s folders (a tarball has no `.git`).
    WorkTree,
}

impl Repository {
    fn at(root: &Path, source: Source) -> Repository {
        let tracked = match source {
            Source::GitIfPresent => git_files(root),
            Source::WorkTree => None,
        };
        let files = tracked.unwrap_or_else(|| {
            let ignored = Ignored::read(root);
            let mut files = Vec::new();
            walk(root, Path::new(""), &ignored, &mut files);
            files
        });
        Repository {
            root: root.to_path_buf(),
            files,
        }
    }

    /// The Markdown files (that the work tree still has).
    fn markdown(&self) -> Vec<PathBuf> {
        self.files
            .iter()
            .filter(|f| f.extension().is_some_and(|e| e == "md"))
            .filter(|f| self.root.join(f).is_file())
            .cloned()
            .collect()
    }

    /// The top-level folders (a path in a code span must start with one). `.ci` counts too.
    fn top_folders(&self) -> BTreeSet<String> {
        let mut tops: BTreeSet<String> = self
            .files
            .iter()
            .filter(|f| f.components().count() > 1)
            .filter_map(|f| {
                f.components()
                    .next()?
                    .as_os_str()
                    .to_str()
                    .map(str::to_owned)
            })
            .filter(|n| !SKIP.contains(&n.as_str()))
            .collect();
        tops.insert(".ci".into());
        tops
    }
}

/// The files git tracks under `root`, when `root` is the top level of a git work tree and git
/// runs; `None` otherwise (no git, no `.git`, or `root` inside another repository's tree).
fn git_files(root: &Path) -> Option<Vec<PathBuf>> {
    let git = |args: &[&str]| -> Option<Vec<u8>> {
        let out = Command::new("git")
            .arg("-C")
            .arg(root)
            .args(args)
            .output()
            .ok()?;
        out.status.success().then_some(out.stdout)
    };
    let top = git(&["rev-parse", "--show-toplevel"])?;
    let top = PathBuf::from(String::from_utf8(top).ok()?.trim_end());
    if top.canonicalize().ok()? != root.canonicalize().ok()? {
        return None;
    }
    let listed = git(&["ls-files", "-z", "--cached"])?;
    let files: Vec<PathBuf> = listed
        .split(|&b| b == 0)
        .filter(|name| !name.is_empty())
        .filter_map(|name| std::str::from_utf8(name).ok().map(PathBuf::from))
        .collect();
    (!files.is_empty()).then_some(files)
}

/// The folder names the root's `.gitignore` leaves out: `/name` or `/name/` at the root only,
/// `name/` or `name` anywhere. Patterns with a `/` inside or a glob are not folders we skip.
struct Ignored {
    at_root: Vec<String>,
    anywhere: Vec<String>,
}

impl Ignored {
    fn read(root: &Path) -> Ignored {
        let text = std::fs::read_to_string(root.join(".gitignore")).unwrap_or_default();
        let mut ignored = Ignored {
            at_root: Vec::new(),
            anywhere: Vec::new(),
        };
        for line in text.lines().map(str::trim) {
            if line.is_empty() || line.starts_with(['#', '!']) {
                continue;
            }
            let anchored = line.starts_with('/');
            let name = line.trim_start_matches('/').trim_end_matches('/');
            if name.is_empty() || name.contains(['/', '*', '?', '[']) {
                continue;
            }
            if anchored {
                ignored.at_root.push(name.to_owned());
            } else {
                ignored.anywhere.push(name.to_owned());
            }
        }
        ignored
    }

    fn skips(&self, relative: &Path, name: &str) -> bool {
        let at_root = relative.components().count() == 1;
        name.starts_with('.')
            || SKIP.contains(&name)
            || self.anywhere.iter().any(|n| n == name)
            || (at_root && self.at_root.iter().any(|n| n == name))
    }
}

/// The files under `root/relative`, as paths relative to `root`, in name order.
fn walk(root: &Path, relative: &Path, ignored: &Ignored, out: &mut Vec<PathBuf>) {
    let dir = root.join(relative);
    let mut entries: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("a directory entry").file_name())
        .collect();
    entries.sort();
    for name in entries {
        let path = relative.join(&name);
        let name = name.to_str().unwrap_or("");
        if root.join(&path).is_dir() {
            if !ignored.skips(&path, name) {
                walk(root, &path, ignored, out);
            }
        } else {
            out.push(path);
        }
    }
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

/// Every place a document of `repository` names a path it does not have, as
/// `file:line: link (target)` or ``file:line: `span` ``.
fn missing_paths(repository: &Repository) -> Vec<String> {
    let root = &repository.root;
    let tops = repository.top_folders();
    let mut missing = Vec::new();
    for relative in repository.markdown() {
        let file = root.join(&relative);
        let text =
            std::fs::read_to_string(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        let dir = file.parent().expect("a file has a folder");
        let shown = relative.display();
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
                if !tops.contains(first)
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
    missing
}

#[test]
fn documents_name_only_files_a_clone_has() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("core sits in the workspace");
    let repository = Repository::at(root, Source::GitIfPresent);
    let documents = repository.markdown().len();
    assert!(documents > 10, "found only {documents} Markdown files");
    let missing = missing_paths(&repository);
    assert!(
        missing.is_empty(),
        "documents name {} path(s) under the repository's folders that this checkout does not \
         have (fix the path, or write a pattern with <placeholders>):\n{}",
        missing.len(),
        missing.join("\n")
    );
}

/// The extension of the throwaway tree's documents.
const DOC: &str = "md";

/// A small repository in a fresh temporary folder: a document naming a run's output
/// (`runs/claim12`), a file it has and one it lacks, and what a user's runs leave behind (a
/// `runs/paper-seed1/` folder with a report whose link resolves nowhere).
fn user_tree(name: &str) -> PathBuf {
    let root =
        std::env::temp_dir().join(format!("swarmfl-doc-paths-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let write = |relative: &str, text: &str| {
        let path = root.join(relative);
        std::fs::create_dir_all(path.parent().expect("a folder")).expect("a temporary folder");
        std::fs::write(path, text).expect("a temporary file");
    };
    write(
        ".gitignore",
        "/target\n/runs\n__pycache__/\nreproduction/*/results/.tmp/\n",
    );
    // The tree's document names are built from `DOC` so that this file itself names no
    // document the repository lacks (a checker that reads sources would count them).
    let doc = |stem: &str| format!("{stem}.{DOC}");
    write(
        &doc("docs/GUIDE"),
        &format!(
            "The study keeps `runs/claim12`; see `{}` and `{}`.\n",
            doc("docs/NOTES"),
            doc("docs/GONE")
        ),
    );
    write(
        &doc("docs/NOTES"),
        &format!("[the guide]({})\n", doc("GUIDE")),
    );
    write(
        &doc("runs/paper-seed1/report"),
        "[a figure](figures/none.svg)\n",
    );
    write(
        &doc("docs/__pycache__/cache"),
        &format!("[nothing]({})\n", doc("nowhere")),
    );
    root
}

#[test]
fn a_users_run_folder_is_not_a_repository_folder() {
    // Without git (a source tarball), and with git when this machine has it: the same answer.
    let mut sources = vec![("work tree", Source::WorkTree)];
    let root = user_tree("check");
    let git = |args: &[&str]| {
        Command::new("git")
            .arg("-C")
            .arg(&root)
            .args(args)
            .output()
            .is_ok_and(|o| o.status.success())
    };
    if git(&["init", "-q"]) && git(&["add", "."]) {
        sources.push(("git", Source::GitIfPresent));
    }
    for (label, source) in sources {
        let repository = Repository::at(&root, source);
        let tops = repository.top_folders();
        assert!(!tops.contains("runs"), "{label}: {tops:?}");
        assert!(tops.contains("docs"), "{label}: {tops:?}");
        assert_eq!(
            missing_paths(&repository),
            vec![format!("docs/GUIDE.{DOC}:1: `docs/GONE.{DOC}`")],
            "{label}"
        );
    }
    std::fs::remove_dir_all(&root).expect("the temporary folder");
}
