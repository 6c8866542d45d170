//! The layering test: imports run one way.
//!
//! Modules: it reads the module paths that each source file of core, of the study crate and of
//! the CLI names (`use` trees and paths in code; comments, string literals and `#[cfg(test)]`
//! items excluded) and fails, naming the file and line, when
//! - a top-level module of core names one that the layer order below puts above it, or one that
//!   the order does not list (a new module must be given its place), or
//! - modules that share a parent name each other in a loop (in core, in study or in the CLI).
//!
//! A parent and its own children may name each other (a child uses its parent's types, the parent
//! re-exports or calls its children): that is one module's inside, not a loop between modules.
//!
//! Crates: `core` < `study` < {`replay-cli`, `python`, `proptests`, `fuzz`} (`CRATES`). Every
//! `.rs` file of a crate (sources, tests, examples, build script; comments and string literals
//! excluded, test items included) and its Cargo.toml's dependency tables (`[dependencies]`,
//! `[dev-dependencies]`, `[build-dependencies]`, their `[target.*]` forms) may name only crates
//! below it, and the test fails, naming the file and line, on any other: core names no other
//! crate, study names no front end, and the front ends do not name each other. `proptests` and
//! `fuzz` are test front ends: they drive core (and may drive study) and nothing names them.
//! Every workspace member (and excluded crate) of the root Cargo.toml must have its place here.
//!
//! ARCHITECTURE.md ("Layers") states the same orders; they change together.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Core's top-level modules from the bottom up. A module may name only modules listed before it
/// (in its own layer or a lower one).
const LAYERS: &[(&str, &[&str])] = &[
    ("ground", &["types", "rng", "faults"]),
    ("config", &["config"]),
    (
        "domains",
        &[
            "data",
            "world",
            "radio",
            "learn",
            "contract",
            "ledger",
            "metrics",
            "byzantine",
            "aggregation",
        ],
    ),
    ("records", &["event", "log", "state", "summary"]),
    ("driver", &["sim"]),
    ("analysis", &["replay", "inspect", "fork", "diff", "chaos"]),
];

/// The workspace's crates from the bottom up: a crate may name only crates of a lower rank.
const CRATES: &[Crate] = &[
    Crate {
        dir: "core",
        package: "swarmfl-core",
        names: &["swarmfl_core"],
        rank: 0,
    },
    Crate {
        dir: "study",
        package: "swarmfl-study",
        names: &["swarmfl_study"],
        rank: 1,
    },
    Crate {
        dir: "replay-cli",
        package: "replay-cli",
        names: &["swarmfl_cli", "replay_cli"],
        rank: 2,
    },
    Crate {
        dir: "python",
        package: "swarmfl-python",
        names: &["_swarmfl", "swarmfl_python"],
        rank: 2,
    },
    // Test front ends: they drive core and may drive study; nothing names them.
    Crate {
        dir: "proptests",
        package: "swarmfl-proptests",
        names: &["swarmfl_proptests"],
        rank: 2,
    },
    Crate {
        dir: "fuzz",
        package: "swarmfl-fuzz",
        names: &["swarmfl_fuzz"],
        rank: 2,
    },
];

/// The names of each rank of `CRATES`, for messages.
const CRATE_RANKS: &[&str] = &["core", "study", "front ends"];

/// One crate of the workspace: its folder, its package name, the names its code is called by
/// (library name, package name with underscores) and its rank in the crate order.
struct Crate {
    dir: &'static str,
    package: &'static str,
    names: &'static [&'static str],
    rank: usize,
}

/// One source file: its path as shown in messages, its module path and its text.
struct Source {
    shown: String,
    module: Vec<String>,
    text: String,
}

/// A module path that a file names, and the line where it does.
struct Reference {
    target: Vec<String>,
    line: usize,
}

#[test]
fn core_modules_import_only_lower_layers_and_no_modules_import_each_other_in_a_loop() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let core = read_tree(&root.join("src"), "core/src");
    let study = read_tree(&root.join("../study/src"), "study/src");
    let cli = read_tree(&root.join("../replay-cli/src"), "replay-cli/src");
    assert!(
        core.len() > 50 && study.len() > 10 && cli.len() > 10,
        "the source trees were not found"
    );
    let mut problems = layer_violations(&core);
    problems.extend(loops(&core));
    problems.extend(loops(&study));
    problems.extend(loops(&cli));
    assert!(
        problems.is_empty(),
        "{} layering problem(s) (ARCHITECTURE.md, \"Layers\"):\n{}",
        problems.len(),
        problems.join("\n")
    );
}

#[test]
fn the_checker_finds_an_import_that_runs_up_and_a_loop() {
    let tree = vec![
        source(
            "core/src/config/mod.rs",
            &["config"],
            "use crate::types::RobotId;\n",
        ),
        source(
            "core/src/ledger/mod.rs",
            &["ledger"],
            "//! Uses crate::sim in a comment only.\nuse crate::{config::Config, sim::State};\n\
             #[cfg(test)]\nmod tests {\n    use crate::replay::x;\n}\n",
        ),
        source(
            "core/src/sim.rs",
            &["sim"],
            "fn f() { let s = \"crate::replay\"; crate::ledger::Ledger::new(); }\n",
        ),
    ];
    let problems = layer_violations(&tree);
    assert_eq!(problems.len(), 1, "{problems:?}");
    assert!(
        problems[0].starts_with("core/src/ledger/mod.rs:2: `ledger`"),
        "{}",
        problems[0]
    );
    let looped = loops(&tree);
    assert_eq!(looped.len(), 1, "{looped:?}");
    assert!(
        looped[0].contains("ledger -> sim") && looped[0].contains("sim -> ledger"),
        "{}",
        looped[0]
    );

    let unlisted = vec![source(
        "core/src/widget.rs",
        &["widget"],
        "use crate::types::Digest;\n",
    )];
    let problems = layer_violations(&unlisted);
    assert!(
        problems[0].contains("not in the layer order"),
        "{}",
        problems[0]
    );

    let siblings = vec![
        source(
            "cli/src/report/plots.rs",
            &["report", "plots"],
            "use super::defence::EXPERIMENT;\n",
        ),
        source(
            "cli/src/report/defence.rs",
            &["report", "defence"],
            "use super::plots::draw;\n",
        ),
        source(
            "cli/src/report/mod.rs",
            &["report"],
            "mod plots;\nmod defence;\npub use plots::draw;\n",
        ),
    ];
    let looped = loops(&siblings);
    assert_eq!(looped.len(), 1, "{looped:?}");
    assert!(looped[0].contains("report::defence"), "{}", looped[0]);
}

#[test]
fn crates_name_only_crates_below_them() {
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut problems = unplaced_crates(&read(&workspace.join("Cargo.toml")), "Cargo.toml");
    for krate in CRATES {
        let dir = workspace.join(krate.dir);
        let sources = read_crate(&dir, krate.dir);
        assert!(
            !sources.is_empty(),
            "no Rust file under {}: a crate of CRATES (core/tests/layering.rs) is gone; take it \
             out of CRATES and ARCHITECTURE.md (\"Layers\")",
            dir.display()
        );
        problems.extend(crate_code_violations(krate, &sources));
        let manifest = format!("{}/Cargo.toml", krate.dir);
        problems.extend(manifest_violations(
            krate,
            &read(&dir.join("Cargo.toml")),
            &manifest,
        ));
    }
    assert!(
        problems.is_empty(),
        "{} crate layering problem(s) (ARCHITECTURE.md, \"Layers\"):\n{}",
        problems.len(),
        problems.join("\n")
    );
}

#[test]
fn the_checker_finds_a_crate_that_names_one_not_below_it() {
    let study = crate_in("study");
    let problems = crate_code_violations(
        study,
        &[source(
            "study/src/run.rs",
            &[],
            "//! Not swarmfl_cli::main in a comment.\nuse swarmfl_core::sim::Sim;\n\
             use swarmfl_cli::main;\nfn f() { let s = \"swarmfl_cli::x\"; }\n",
        )],
    );
    assert_eq!(problems.len(), 1, "{problems:?}");
    assert!(
        problems[0].starts_with("study/src/run.rs:3: crate `study` (study) names `swarmfl_cli`"),
        "{}",
        problems[0]
    );

    let core = crate_in("core");
    let problems = crate_code_violations(
        core,
        &[source(
            "core/src/sim.rs",
            &[],
            "use swarmfl_study::run::run;\nuse crate::types::Digest;\n\
             #[cfg(test)]\nmod tests {\n    use ::swarmfl_cli as _;\n}\n",
        )],
    );
    assert_eq!(problems.len(), 2, "{problems:?}");
    assert!(
        problems[0].starts_with("core/src/sim.rs:1: crate `core` (core) names `swarmfl_study`"),
        "{}",
        problems[0]
    );
    assert!(
        problems[1].starts_with("core/src/sim.rs:5: crate `core` (core) names `swarmfl_cli`"),
        "{}",
        problems[1]
    );

    // The two front ends do not name each other; a front end names itself and what is below.
    let problems = crate_code_violations(
        crate_in("python"),
        &[source("python/src/lib.rs", &[], "use swarmfl_cli::run;\n")],
    );
    assert_eq!(problems.len(), 1, "{problems:?}");
    let problems = crate_code_violations(
        crate_in("replay-cli"),
        &[source(
            "replay-cli/tests/a.rs",
            &[],
            "use swarmfl_cli::main;\nuse swarmfl_study::run;\nuse swarmfl_core::sim;\n",
        )],
    );
    assert!(problems.is_empty(), "{problems:?}");

    let manifest = "[package]\nname = \"swarmfl-core\"\n\n[dependencies]\nserde.workspace = true\n\
                    swarmfl-study.workspace = true\n\n[dev-dependencies.cli]\n\
                    package = \"replay-cli\"\npath = \"../replay-cli\"\n\n[features]\n\
                    evm = [\"dep:revm\"]\n";
    let problems = manifest_violations(core, manifest, "core/Cargo.toml");
    assert_eq!(problems.len(), 2, "{problems:?}");
    assert!(
        problems[0].starts_with("core/Cargo.toml:6: crate `core` (core) names `swarmfl-study`"),
        "{}",
        problems[0]
    );
    assert!(
        problems[1].starts_with("core/Cargo.toml:8: crate `core` (core) names `replay-cli`"),
        "{}",
        problems[1]
    );
    let manifest = "[dependencies]\nswarmfl-core.workspace = true\n\n\
                    [target.'cfg(unix)'.dev-dependencies]\n\
                    \"swarmfl-python\" = { path = \"../python\" }\n";
    let problems = manifest_violations(study, manifest, "study/Cargo.toml");
    assert_eq!(problems.len(), 1, "{problems:?}");
    assert!(
        problems[0].starts_with("study/Cargo.toml:5: crate `study` (study) names `swarmfl-python`"),
        "{}",
        problems[0]
    );

    let root = "[workspace]\nmembers = [\"core\", \"study\",\n  \"bench\"]\nexclude = [\"fuzz\"]\n";
    let problems = unplaced_crates(root, "Cargo.toml");
    assert_eq!(problems.len(), 1, "{problems:?}");
    assert!(
        problems[0].starts_with("Cargo.toml:3: crate `bench` has no place"),
        "{}",
        problems[0]
    );
}

fn crate_in(dir: &str) -> &'static Crate {
    CRATES
        .iter()
        .find(|c| c.dir == dir)
        .expect("a crate of CRATES")
}

fn source(shown: &str, module: &[&str], text: &str) -> Source {
    Source {
        shown: shown.to_string(),
        module: module.iter().map(|m| m.to_string()).collect(),
        text: text.to_string(),
    }
}

/// Every `.rs` file under `dir`, test files (`tests.rs`, `tests/`) apart, sorted by path.
fn read_tree(dir: &Path, shown: &str) -> Vec<Source> {
    let mut files = Vec::new();
    collect(dir, &mut files);
    files.sort();
    let mut sources = Vec::new();
    for file in files {
        let relative = file.strip_prefix(dir).expect("a file under its tree");
        let mut module: Vec<String> = relative
            .iter()
            .map(|part| part.to_string_lossy().into_owned())
            .collect();
        let last = module.pop().expect("a file name");
        if module.iter().any(|m| m == "tests") || last == "tests.rs" {
            continue;
        }
        match last.as_str() {
            "mod.rs" | "lib.rs" | "main.rs" => {}
            name => module.push(name.trim_end_matches(".rs").to_string()),
        }
        let text = std::fs::read_to_string(&file)
            .unwrap_or_else(|e| panic!("cannot read {}: {e}", file.display()));
        sources.push(Source {
            shown: format!("{shown}/{}", relative.display()),
            module,
            text,
        });
    }
    sources
}

fn collect(dir: &Path, out: &mut Vec<PathBuf>) {
    let entries =
        std::fs::read_dir(dir).unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()));
    for entry in entries {
        let path = entry.expect("a directory entry").path();
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
        let skipped = name.is_some_and(|n| n == "target" || n.starts_with('.'));
        if path.is_dir() && skipped {
            continue; // Build outputs and hidden folders hold no source of the crate.
        } else if path.is_dir() {
            collect(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

fn read(file: &Path) -> String {
    std::fs::read_to_string(file).unwrap_or_else(|e| panic!("cannot read {}: {e}", file.display()))
}

/// Every `.rs` file of a crate (build outputs and hidden folders apart), sorted by path.
fn read_crate(dir: &Path, shown: &str) -> Vec<Source> {
    let mut files = Vec::new();
    collect(dir, &mut files);
    files.sort();
    files
        .into_iter()
        .map(|file| Source {
            shown: format!(
                "{shown}/{}",
                file.strip_prefix(dir)
                    .expect("a file under its crate")
                    .display()
            ),
            module: Vec::new(),
            text: read(&file),
        })
        .collect()
}

/// The crate of `CRATES` that a manifest's dependency key or `package` names.
fn crate_named(name: &str) -> Option<&'static Crate> {
    CRATES
        .iter()
        .find(|c| c.package == name || c.names.contains(&name))
}

/// The message for `from` naming `to` (as `name`) at `place`, if the crate order forbids it.
fn crate_violation(from: &Crate, to: &Crate, name: &str, place: &str) -> Option<String> {
    (to.dir != from.dir && to.rank >= from.rank).then(|| {
        format!(
            "{place}: crate `{}` ({}) names `{name}`, the crate `{}` ({}), which the crate order \
             does not put below it; move what it needs down into `{}` or a crate below it, or \
             let the front end pass it in",
            from.dir, CRATE_RANKS[from.rank], to.dir, CRATE_RANKS[to.rank], from.dir
        )
    })
}

/// Names in a crate's code (comments and string literals apart) of crates not below it.
fn crate_code_violations(from: &Crate, sources: &[Source]) -> Vec<String> {
    let mut problems = Vec::new();
    for file in sources {
        let mut seen = BTreeSet::new();
        for (token, line) in tokenize(&strip(&file.text)) {
            let Some(to) = CRATES.iter().find(|c| c.names.contains(&token.as_str())) else {
                continue;
            };
            if !seen.insert((line, to.dir)) {
                continue;
            }
            let place = format!("{}:{line}", file.shown);
            problems.extend(crate_violation(from, to, &token, &place));
        }
    }
    problems
}

/// Dependencies in a crate's manifest on crates not below it.
fn manifest_violations(from: &Crate, text: &str, shown: &str) -> Vec<String> {
    let manifest: toml::Table = match toml::from_str(text) {
        Ok(table) => table,
        Err(e) => return vec![format!("{shown}: not valid TOML: {e}")],
    };
    let mut tables: Vec<&toml::Value> = Vec::new();
    let kinds = ["dependencies", "dev-dependencies", "build-dependencies"];
    tables.extend(kinds.iter().filter_map(|k| manifest.get(*k)));
    if let Some(targets) = manifest.get("target").and_then(toml::Value::as_table) {
        for target in targets.values() {
            tables.extend(kinds.iter().filter_map(|k| target.get(*k)));
        }
    }
    let mut problems = Vec::new();
    for table in tables {
        for (key, spec) in table.as_table().into_iter().flatten() {
            let package = spec
                .get("package")
                .and_then(toml::Value::as_str)
                .unwrap_or(key);
            let by_path = spec
                .get("path")
                .and_then(toml::Value::as_str)
                .and_then(|p| Path::new(p).file_name())
                .and_then(|dir| CRATES.iter().find(|c| *c.dir == *dir));
            let Some(to) = crate_named(package).or(by_path) else {
                continue;
            };
            let place = format!("{shown}:{}", manifest_line(text, key));
            problems.extend(crate_violation(from, to, package, &place));
        }
    }
    problems
}

/// The line (from 1) where a manifest's dependency tables name `key`; 1 if none is found.
fn manifest_line(text: &str, key: &str) -> usize {
    let mut in_dependencies = false;
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if let Some(header) = line.strip_prefix('[') {
            let header = header.trim_end_matches(']').trim();
            let last = header
                .rsplit('.')
                .next()
                .unwrap_or(header)
                .trim_matches('"');
            if last == key && header.contains("dependencies.") {
                return n + 1;
            }
            in_dependencies = header.ends_with("dependencies");
            continue;
        }
        let named = line
            .strip_prefix(key)
            .or_else(|| line.strip_prefix(&format!("\"{key}\"")))
            .and_then(|rest| rest.trim_start().chars().next())
            .is_some_and(|c| c == '=' || c == '.');
        if in_dependencies && named {
            return n + 1;
        }
    }
    1
}

/// Workspace members and excluded crates of the root manifest that `CRATES` does not list.
fn unplaced_crates(text: &str, shown: &str) -> Vec<String> {
    let manifest: toml::Table = match toml::from_str(text) {
        Ok(table) => table,
        Err(e) => return vec![format!("{shown}: not valid TOML: {e}")],
    };
    let workspace = manifest.get("workspace");
    let mut problems = Vec::new();
    for list in ["members", "exclude"] {
        let dirs = workspace
            .and_then(|w| w.get(list))
            .and_then(toml::Value::as_array)
            .into_iter()
            .flatten()
            .filter_map(toml::Value::as_str);
        for dir in dirs {
            if CRATES.iter().any(|c| c.dir == dir) {
                continue;
            }
            let line = text
                .lines()
                .position(|l| l.contains(&format!("\"{dir}\"")))
                .map_or(1, |n| n + 1);
            problems.push(format!(
                "{shown}:{line}: crate `{dir}` has no place in the crate order; give it one in \
                 CRATES (core/tests/layering.rs) and in ARCHITECTURE.md (\"Layers\")"
            ));
        }
    }
    problems
}

/// Imports from a top-level module of core to one at its rank or above, or to an unlisted one.
fn layer_violations(tree: &[Source]) -> Vec<String> {
    let order: Vec<(&str, &str)> = LAYERS
        .iter()
        .flat_map(|(layer, modules)| modules.iter().map(move |m| (*m, *layer)))
        .collect();
    let rank = |module: &str| order.iter().position(|(m, _)| *m == module);
    let modules = module_set(tree);
    let mut problems = Vec::new();
    for file in tree {
        let Some(from) = file.module.first() else {
            continue;
        };
        let Some(from_rank) = rank(from) else {
            problems.push(format!(
                "{}:1: top-level module `{from}` is not in the layer order; give it a place in \
                 LAYERS (core/tests/layering.rs) and in ARCHITECTURE.md",
                file.shown
            ));
            continue;
        };
        let mut seen = BTreeSet::new();
        for reference in references(file, &modules) {
            let Some(to) = reference.target.first() else {
                continue;
            };
            if to == from || !seen.insert((reference.line, to.clone())) {
                continue;
            }
            match rank(to) {
                Some(to_rank) if to_rank < from_rank => {}
                Some(to_rank) => problems.push(format!(
                    "{}:{}: `{from}` ({}) names `{to}` ({}), which the layer order puts above it; \
                     move what it needs down to `{from}`'s layer or below, or pass it in",
                    file.shown, reference.line, order[from_rank].1, order[to_rank].1
                )),
                None => problems.push(format!(
                    "{}:{}: `{from}` names `{to}`, which is not in the layer order",
                    file.shown, reference.line
                )),
            }
        }
    }
    problems
}

/// Loops among modules that share a parent, one message per loop found, naming each step.
fn loops(tree: &[Source]) -> Vec<String> {
    let modules = module_set(tree);
    // (from, to) -> where the first reference is.
    let mut edges: BTreeMap<(Vec<String>, Vec<String>), String> = BTreeMap::new();
    for file in tree {
        for reference in references(file, &modules) {
            let common = file
                .module
                .iter()
                .zip(&reference.target)
                .take_while(|(a, b)| a == b)
                .count();
            if common >= file.module.len() || common >= reference.target.len() {
                continue; // Within one module, or between a module and its own ancestors.
            }
            let from = file.module[..=common].to_vec();
            let to = reference.target[..=common].to_vec();
            edges
                .entry((from, to))
                .or_insert_with(|| format!("{}:{}", file.shown, reference.line));
        }
    }
    let mut graph: BTreeMap<&Vec<String>, Vec<&Vec<String>>> = BTreeMap::new();
    for (from, to) in edges.keys() {
        graph.entry(from).or_default().push(to);
    }
    let mut problems = Vec::new();
    let mut reported: BTreeSet<Vec<Vec<String>>> = BTreeSet::new();
    for start in graph.keys() {
        let mut path = vec![*start];
        if let Some(cycle) = find_cycle(&graph, &mut path, start) {
            let mut key = cycle.iter().map(|m| (*m).clone()).collect::<Vec<_>>();
            key.sort();
            if !reported.insert(key) {
                continue;
            }
            let mut text = String::from("an import loop:");
            for pair in cycle.windows(2) {
                let at = &edges[&(pair[0].clone(), pair[1].clone())];
                let _ = write!(
                    text,
                    "\n    {} -> {} ({at})",
                    pair[0].join("::"),
                    pair[1].join("::")
                );
            }
            problems.push(text);
        }
    }
    problems
}

/// A path from the last module of `path` back to `start`, depth first in a fixed order.
fn find_cycle<'a>(
    graph: &BTreeMap<&'a Vec<String>, Vec<&'a Vec<String>>>,
    path: &mut Vec<&'a Vec<String>>,
    start: &'a Vec<String>,
) -> Option<Vec<&'a Vec<String>>> {
    let last = *path.last().expect("a non-empty path");
    for next in graph.get(last).into_iter().flatten() {
        if *next == start {
            let mut cycle = path.clone();
            cycle.push(start);
            return Some(cycle);
        }
        if path.contains(next) || *next < start {
            continue; // Visited on this path, or a loop through it was already searched from it.
        }
        path.push(next);
        if let Some(cycle) = find_cycle(graph, path, start) {
            return Some(cycle);
        }
        path.pop();
    }
    None
}

fn module_set(tree: &[Source]) -> BTreeSet<Vec<String>> {
    tree.iter().map(|s| s.module.clone()).collect()
}

/// The modules that `file` names: each path resolved to the longest known module it starts with.
fn references(file: &Source, modules: &BTreeSet<Vec<String>>) -> Vec<Reference> {
    let code = strip(&file.text);
    let code = without_test_items(&code);
    let children: BTreeSet<&str> = modules
        .iter()
        .filter(|m| m.len() == file.module.len() + 1 && m.starts_with(&file.module))
        .map(|m| m.last().expect("a child has a name").as_str())
        .collect();
    let mut out = Vec::new();
    for (path, line) in paths(&code) {
        let absolute = match path.first().map(String::as_str) {
            Some("crate") => path[1..].to_vec(),
            Some("self") => [file.module.as_slice(), &path[1..]].concat(),
            Some("super") => {
                let ups = path.iter().take_while(|p| *p == "super").count();
                if ups > file.module.len() {
                    continue;
                }
                [&file.module[..file.module.len() - ups], &path[ups..]].concat()
            }
            Some(first) if children.contains(first) => [file.module.as_slice(), &path].concat(),
            _ => continue,
        };
        let known = (1..=absolute.len())
            .rev()
            .map(|n| absolute[..n].to_vec())
            .find(|prefix| modules.contains(prefix));
        if let Some(target) = known {
            out.push(Reference { target, line });
        } else if let Some(first) = absolute.first() {
            // A top-level name that is no file (an item of the crate root): keep it for the
            // layer check, which reports names it does not know.
            let crate_root_name = path.first().is_some_and(|p| p == "crate")
                && modules.iter().all(|m| m.first() != Some(first))
                && first.chars().next().is_some_and(char::is_lowercase);
            if crate_root_name {
                out.push(Reference {
                    target: vec![first.clone()],
                    line,
                });
            }
        }
    }
    out
}

/// The text with comments, string and character literals blanked (line breaks kept).
fn strip(text: &str) -> String {
    let bytes = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    let blank = |out: &mut String, s: &[u8]| {
        for &b in s {
            out.push(if b == b'\n' { '\n' } else { ' ' });
        }
    };
    while i < bytes.len() {
        let rest = &bytes[i..];
        if rest.starts_with(b"//") {
            let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
            blank(&mut out, &rest[..end]);
            i += end;
        } else if rest.starts_with(b"/*") {
            let mut depth = 0;
            let mut j = 0;
            while j < rest.len() {
                if rest[j..].starts_with(b"/*") {
                    depth += 1;
                    j += 2;
                } else if rest[j..].starts_with(b"*/") {
                    depth -= 1;
                    j += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    j += 1;
                }
            }
            blank(&mut out, &rest[..j.min(rest.len())]);
            i += j;
        } else if rest[0] == b'r'
            && (rest.get(1) == Some(&b'"') || rest.get(1) == Some(&b'#'))
            && !prev_is_ident(bytes, i)
        {
            let hashes = rest[1..].iter().take_while(|&&b| b == b'#').count();
            if rest.get(1 + hashes) != Some(&b'"') {
                out.push('r');
                i += 1;
                continue;
            }
            let close: Vec<u8> = std::iter::once(b'"')
                .chain(std::iter::repeat_n(b'#', hashes))
                .collect();
            let body = 2 + hashes;
            let end = rest[body..]
                .windows(close.len())
                .position(|w| w == close.as_slice())
                .map_or(rest.len(), |p| body + p + close.len());
            blank(&mut out, &rest[..end]);
            i += end;
        } else if rest[0] == b'"' {
            let mut j = 1;
            while j < rest.len() && rest[j] != b'"' {
                j += if rest[j] == b'\\' { 2 } else { 1 };
            }
            let end = (j + 1).min(rest.len());
            blank(&mut out, &rest[..end]);
            i += end;
        } else if rest[0] == b'\'' {
            // A character literal ('x', '\n', '\u{..}', '"'); otherwise a lifetime.
            let end = if rest.get(1) == Some(&b'\\') {
                rest[2..].iter().position(|&b| b == b'\'').map(|p| p + 3)
            } else {
                let mut next = text[i + 1..].chars();
                let width = next.next().map_or(1, char::len_utf8);
                (next.next() == Some('\'')).then_some(2 + width)
            };
            match end {
                Some(end) => {
                    blank(&mut out, &rest[..end]);
                    i += end;
                }
                None => {
                    out.push('\'');
                    i += 1;
                }
            }
        } else {
            let ch = text[i..].chars().next().expect("a character");
            out.push(ch);
            i += ch.len_utf8();
        }
    }
    out
}

fn prev_is_ident(bytes: &[u8], i: usize) -> bool {
    i > 0 && (bytes[i - 1].is_ascii_alphanumeric() || bytes[i - 1] == b'_')
}

/// The code with every item marked `#[cfg(test)]` blanked (line breaks kept).
fn without_test_items(code: &str) -> String {
    let mut out = String::with_capacity(code.len());
    let mut rest = code;
    while let Some(at) = rest.find("#[cfg(test)]") {
        out.push_str(&rest[..at]);
        let item = &rest[at..];
        // The item ends at its first `;` outside braces, or where its first brace closes.
        let mut depth = 0usize;
        let mut end = item.len();
        for (j, ch) in item.char_indices().skip("#[cfg(test)]".len()) {
            match ch {
                '{' => depth += 1,
                '}' => {
                    depth = depth.saturating_sub(1);
                    if depth == 0 {
                        end = j + 1;
                        break;
                    }
                }
                ';' if depth == 0 => {
                    end = j + 1;
                    break;
                }
                _ => {}
            }
        }
        out.extend(
            item[..end]
                .chars()
                .map(|c| if c == '\n' { '\n' } else { ' ' }),
        );
        rest = &item[end..];
    }
    out.push_str(rest);
    out
}

/// Every path in the code (`a::b::c`, with `use` trees expanded), with its line.
fn paths(code: &str) -> Vec<(Vec<String>, usize)> {
    let tokens = tokenize(code);
    let mut out = Vec::new();
    let mut i = 0;
    while i < tokens.len() {
        let (token, line) = &tokens[i];
        if token == "use" {
            let end = tokens[i..]
                .iter()
                .position(|(t, _)| t == ";")
                .map_or(tokens.len(), |p| i + p);
            expand_use(&tokens[i + 1..end], &mut Vec::new(), &mut out);
            i = end + 1;
            continue;
        }
        if is_ident(token) && tokens.get(i + 1).is_some_and(|(t, _)| t == "::") {
            let start_line = *line;
            let mut path = vec![token.clone()];
            let mut j = i + 1;
            while tokens.get(j).is_some_and(|(t, _)| t == "::")
                && tokens.get(j + 1).is_some_and(|(t, _)| is_ident(t))
            {
                path.push(tokens[j + 1].0.clone());
                j += 2;
            }
            if !(i > 0 && tokens[i - 1].0 == "::") {
                out.push((path, start_line));
            }
            i = j;
            continue;
        }
        i += 1;
    }
    out
}

/// Expands a `use` tree (`a::{b, c::{d, e}}`) into its paths; `prefix` is the path so far.
fn expand_use(
    tokens: &[(String, usize)],
    prefix: &mut Vec<String>,
    out: &mut Vec<(Vec<String>, usize)>,
) {
    let mut i = 0;
    let depth_before = prefix.len();
    while i < tokens.len() {
        let (token, line) = &tokens[i];
        match token.as_str() {
            "{" => {
                let mut depth = 0;
                let mut j = i;
                let mut starts = vec![i + 1];
                while j < tokens.len() {
                    match tokens[j].0.as_str() {
                        "{" => depth += 1,
                        "}" => {
                            depth -= 1;
                            if depth == 0 {
                                break;
                            }
                        }
                        "," if depth == 1 => starts.push(j + 1),
                        _ => {}
                    }
                    j += 1;
                }
                starts.push(j + 1);
                for pair in starts.windows(2) {
                    let part = &tokens[pair[0]..pair[1] - 1];
                    expand_use(part, prefix, out);
                }
                prefix.truncate(depth_before);
                return;
            }
            "::" | "pub" | "as" | "*" => {}
            "self" if !prefix.is_empty() => {
                out.push((prefix.clone(), *line));
                break;
            }
            _ if is_ident(token) => {
                if i > 0 && tokens[i - 1].0 == "as" {
                    break;
                }
                prefix.push(token.clone());
                if tokens.get(i + 1).is_none_or(|(t, _)| t != "::") {
                    out.push((prefix.clone(), *line));
                    break;
                }
            }
            _ => {}
        }
        i += 1;
    }
    if prefix.len() > depth_before && out.last().is_none_or(|(p, _)| p != prefix) {
        out.push((prefix.clone(), tokens.first().map_or(0, |t| t.1)));
    }
    prefix.truncate(depth_before);
}

fn is_ident(token: &str) -> bool {
    token
        .chars()
        .next()
        .is_some_and(|c| c.is_alphabetic() || c == '_')
        && token.chars().all(|c| c.is_alphanumeric() || c == '_')
}

/// Identifiers, `::` and single punctuation characters, each with its line (from 1).
fn tokenize(code: &str) -> Vec<(String, usize)> {
    let mut tokens = Vec::new();
    let mut line = 1;
    let mut chars = code.char_indices().peekable();
    while let Some((at, ch)) = chars.next() {
        if ch == '\n' {
            line += 1;
        } else if ch.is_alphabetic() || ch == '_' {
            let mut end = at + ch.len_utf8();
            while let Some(&(j, c)) = chars.peek() {
                if c.is_alphanumeric() || c == '_' {
                    end = j + c.len_utf8();
                    chars.next();
                } else {
                    break;
                }
            }
            tokens.push((code[at..end].to_string(), line));
        } else if ch == ':' && chars.peek().is_some_and(|&(_, c)| c == ':') {
            chars.next();
            tokens.push(("::".to_string(), line));
        } else if !ch.is_whitespace() {
            tokens.push((ch.to_string(), line));
        }
    }
    tokens
}
