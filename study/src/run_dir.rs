//! The folder a run or a fork writes into: its default name, and what becomes of a run that is
//! already there.
//!
//! Default folders are distinct per configuration: `runs/<preset>-seed<N>` for a preset as it
//! is, `runs/<preset>-seed<N>-<digest>` with `--set` or `--config` ([`digest`]), and a fork's
//! `<parent folder>-fork-at-<H>-<digest>` beside its parent. A run is never replaced by another
//! configuration's unless the user says so: in a default folder a run of another configuration
//! (another seed, configuration, fork origin or plug-in) is refused without `--force`, while
//! the same configuration's run is replaced (it makes the same records) and said so; a folder
//! named with `--out` is the user's explicit choice, so its run is replaced, with a word on what
//! it was. A fork never writes into its parent's folder. Replacing removes every file a run
//! writes ([`RUN_FILES`]) and names the other files left beside the new run.

use std::path::{Path, PathBuf};

use anyhow::Context;
use swarmfl_core::config::parse_config;
use swarmfl_core::diff::config_differences;
use swarmfl_core::log::{Header, LogReader};

/// The files a run leaves in its folder: the log, its sidecar index, the summary and the
/// viewer page that `run` suggests writing beside them.
pub const RUN_FILES: [&str; 4] = ["run.swlog", "run.swlog.idx", "summary.json", "run.html"];

/// Where the folder's name came from, which decides what may be replaced in it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Chosen {
    /// The command's default name: a run there of another configuration is refused.
    Default,
    /// Named by the user (`--out`, or the Python package's `out=`): the run there is replaced,
    /// and the replacement says what it was.
    Explicit,
    /// `--force`: the run there is replaced whatever it is, and said so.
    Forced,
}

/// The folder of a command's `--out` and `--force`: `out` if given (explicit), else
/// `default()`.
pub fn choose(
    out: Option<PathBuf>,
    force: bool,
    default: impl FnOnce() -> anyhow::Result<PathBuf>,
) -> anyhow::Result<(PathBuf, Chosen)> {
    let chosen = match (&out, force) {
        (_, true) => Chosen::Forced,
        (Some(_), false) => Chosen::Explicit,
        (None, false) => Chosen::Default,
    };
    let out = match out {
        Some(out) => out,
        None => default()?,
    };
    Ok((out, chosen))
}

/// Hex digits of [`digest`] in a default folder's name: 32 bits, so that two configurations
/// of one preset and seed share a folder by chance about once in four billion pairs (and even
/// then [`prepare`] refuses instead of replacing).
const DIGEST_HEX: usize = 8;

/// A short digest of what changes a configuration: blake3 over the overrides (each `key=value`
/// with the spaces around key and value trimmed, sorted, so that the same `--set`s in another
/// order or spacing give the same name) and the bytes of the configuration file, if any.
pub fn digest(overrides: &[String], config_file: Option<&[u8]>) -> String {
    let mut sorted: Vec<String> = overrides
        .iter()
        .map(|o| match o.split_once('=') {
            Some((key, value)) => format!("{}={}", key.trim(), value.trim()),
            None => o.trim().to_string(),
        })
        .collect();
    sorted.sort();
    let mut h = blake3::Hasher::new();
    h.update(b"swarmfl run folder v1\0");
    // Lengths before contents: no two lists hash the same bytes.
    h.update(&(sorted.len() as u64).to_le_bytes());
    for o in &sorted {
        h.update(&(o.len() as u64).to_le_bytes());
        h.update(o.as_bytes());
    }
    if let Some(bytes) = config_file {
        h.update(b"config file\0");
        h.update(&(bytes.len() as u64).to_le_bytes());
        h.update(bytes);
    }
    h.finalize().to_hex()[..DIGEST_HEX].to_string()
}

/// The default folder of `swarmfl run`: `runs/<preset>-seed<N>` for the preset as it is (the
/// README's main job writes `runs/paper-seed1`), `runs/<preset>-seed<N>-<digest>` when
/// `--set` or `--config` changes it.
pub fn default_run_dir(
    preset: &str,
    seed: u64,
    overrides: &[String],
    config_file: Option<&[u8]>,
) -> PathBuf {
    let base = format!("{preset}-seed{seed}");
    if overrides.is_empty() && config_file.is_none() {
        return Path::new("runs").join(base);
    }
    Path::new("runs").join(format!("{base}-{}", digest(overrides, config_file)))
}

/// The folder that holds the log at `log` (`.` for a bare file name).
fn folder_of(log: &Path) -> &Path {
    match log.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// The default folder of a fork of the log at `parent` at block `height`: beside the parent's
/// folder, `<parent folder>-fork-at-<H>-<digest of the overrides>` (`runs/s7/run.swlog` at 20
/// gives `runs/s7-fork-at-20-1a2b3c4d`).
pub fn default_fork_dir(parent: &Path, height: u64, overrides: &[String]) -> PathBuf {
    let folder = folder_of(parent);
    let name = folder
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "run".to_string());
    let name = format!("{name}-fork-at-{height}-{}", digest(overrides, None));
    match folder.parent() {
        Some(up) if folder.file_name().is_some() => up.join(name),
        // `.` or `/`: the parent's folder has no name to stand beside; the fork goes into it.
        _ => folder.join(name),
    }
}

/// Refuses a fork's `out` that is the folder of the `parent` log or holds it: the fork would
/// replace the run it continues (and reads while it runs). `default` is the fork's default
/// folder, offered as the fix.
pub fn refuse_parent_folder(parent: &Path, out: &Path, default: &Path) -> anyhow::Result<()> {
    let (Ok(parent_abs), Ok(out_abs)) = (parent.canonicalize(), out.canonicalize()) else {
        // A folder that does not exist yet holds nothing, the parent least of all.
        return Ok(());
    };
    if parent_abs.starts_with(&out_abs) {
        anyhow::bail!(
            "fork --out {} would write over its parent: that folder holds the parent log {}, \
             which the fork reads and would replace. Give a new folder (or leave --out out: the \
             default is {})",
            out.display(),
            parent.display(),
            default.display()
        );
    }
    Ok(())
}

/// How the run already in a folder compares with the one about to be written there.
#[derive(Debug, PartialEq)]
enum Previous {
    /// No run in the folder (it does not exist or is empty).
    None,
    /// The same seed, configuration, fork origin and plug-ins: the same records.
    Same,
    /// Another run: what differs, as `what: old -> new` lines.
    Different(Vec<String>),
    /// A log whose header cannot be read: why.
    Unreadable(String),
}

/// What differs between the run of header `old` and the run of header `new`, as
/// `what: old -> new` lines (empty when they make the same records). The build that wrote the
/// log is not compared: the same configuration under another build is the same run.
fn differences(old: &Header, new: &Header) -> Vec<String> {
    let mut out = Vec::new();
    if old.seed != new.seed {
        out.push(format!("seed: {} -> {}", old.seed, new.seed));
    }
    if old.config_toml != new.config_toml {
        let parsed = (
            parse_config(&old.config_toml, "the previous run's header"),
            parse_config(&new.config_toml, "the new run's configuration"),
        );
        let keys = match parsed {
            (Ok(a), Ok(b)) => config_differences(&a, &b),
            _ => Vec::new(),
        };
        if keys.is_empty() {
            out.push("the recorded configuration text".to_string());
        }
        out.extend(keys);
    }
    if old.parent != new.parent {
        let origin = |h: &Header| match &h.parent {
            None => "a run".to_string(),
            Some(p) => format!("a fork at block {} ({})", p.height, p.overrides.join(", ")),
        };
        out.push(format!("origin: {} -> {}", origin(old), origin(new)));
    }
    if old.plugins != new.plugins {
        out.push("the plug-ins".to_string());
    }
    out
}

/// Compares the run in `out` (if any) with the run of `header`. A folder with files but no
/// `run.swlog` is refused, so a mistyped `--out` never mixes a run into someone's files.
fn previous(out: &Path, header: &Header) -> anyhow::Result<Previous> {
    let Ok(entries) = std::fs::read_dir(out) else {
        return Ok(Previous::None);
    };
    let names: Vec<String> = entries
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    if names.is_empty() {
        return Ok(Previous::None);
    }
    if !names.iter().any(|n| n == "run.swlog") {
        anyhow::bail!(
            "--out {} is a folder that holds other files ({}) but no run: choose a new or empty \
             folder, or a previous run's folder to replace that run",
            out.display(),
            list(&names)
        );
    }
    let log = out.join("run.swlog");
    if std::fs::metadata(&log).is_ok_and(|m| m.len() == 0) {
        // A run stopped before its first write left nothing to keep.
        return Ok(Previous::Same);
    }
    Ok(match LogReader::open(&log) {
        Ok(reader) => match differences(reader.header(), header) {
            d if d.is_empty() => Previous::Same,
            d => Previous::Different(d),
        },
        Err(e) => Previous::Unreadable(e.to_string()),
    })
}

/// At most three names, then `...`.
fn list(names: &[String]) -> String {
    let mut shown = names.iter().take(3).cloned().collect::<Vec<_>>().join(", ");
    if names.len() > 3 {
        shown.push_str(", ...");
    }
    shown
}

/// `seed S, final hash H...` from the folder's `summary.json`, or why not.
fn describe(out: &Path) -> String {
    /// The two fields it names (read alone, so a summary of any version names them).
    #[derive(serde::Deserialize)]
    struct Named {
        seed: u64,
        final_hash: String,
    }
    std::fs::read_to_string(out.join("summary.json"))
        .ok()
        .and_then(|t| serde_json::from_str::<Named>(&t).ok())
        .and_then(|s| {
            let hash = s.final_hash.get(..12)?;
            Some(format!("seed {}, final hash {hash}...", s.seed))
        })
        .unwrap_or_else(|| "no summary: an interrupted run".to_string())
}

/// Makes `out` ready for the run of `header`, whose folder was `chosen` so. Returns what to
/// tell the user when a run is replaced (see the module's comment for when it is refused).
pub fn prepare(out: &Path, header: &Header, chosen: Chosen) -> anyhow::Result<Option<String>> {
    let previous = previous(out, header)?;
    let what = describe(out);
    let note = match (&previous, chosen) {
        (Previous::None, _) => return Ok(None),
        (Previous::Same, _) => format!(
            "replacing the previous run in {} ({what}): the same configuration and seed, so the \
             same records from the same build",
            out.display()
        ),
        (Previous::Different(d), Chosen::Default) => anyhow::bail!(
            "{} holds a run of another configuration ({what}; {}): nothing was replaced. Give \
             --out DIR to write this run elsewhere, or --force to replace that run",
            out.display(),
            differing(d)
        ),
        (Previous::Unreadable(why), Chosen::Default) => anyhow::bail!(
            "{} holds a log this build cannot read ({why}): nothing was replaced. Give --out DIR \
             to write this run elsewhere, or --force to replace that log",
            out.display()
        ),
        (Previous::Different(d), Chosen::Explicit | Chosen::Forced) => format!(
            "replacing the previous run in {} ({what}; {})",
            out.display(),
            differing(d)
        ),
        (Previous::Unreadable(why), Chosen::Explicit | Chosen::Forced) => format!(
            "replacing the previous run in {} (its log is unreadable: {why})",
            out.display()
        ),
    };
    for name in RUN_FILES {
        let path = out.join(name);
        match std::fs::remove_file(&path) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(e).with_context(|| format!("cannot remove {}", path.display())),
        }
    }
    let kept: Vec<String> = std::fs::read_dir(out)
        .map(|entries| {
            entries
                .filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    Ok(Some(match kept.is_empty() {
        true => note,
        false => format!(
            "{note}; other files are kept beside the new run (they may describe the old one): \
             {}",
            list(&kept)
        ),
    }))
}

/// `its configuration differs: a: x -> y, ...` (at most three, then how many more).
fn differing(d: &[String]) -> String {
    let mut text = format!(
        "differs: {}",
        d.iter().take(3).cloned().collect::<Vec<_>>().join(", ")
    );
    if d.len() > 3 {
        text.push_str(&format!(" and {} more", d.len() - 3));
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strings(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn the_presets_own_run_keeps_its_name_and_every_change_gets_its_own() {
        assert_eq!(
            default_run_dir("paper", 1, &[], None),
            Path::new("runs/paper-seed1")
        );
        let median = default_run_dir("paper", 1, &strings(&["contract.rule=median"]), None);
        let krum = default_run_dir("paper", 1, &strings(&["contract.rule=krum"]), None);
        let name = median.file_name().unwrap().to_str().unwrap();
        assert!(name.starts_with("paper-seed1-"), "{name}");
        assert_eq!(name.len(), "paper-seed1-".len() + DIGEST_HEX, "{name}");
        assert!(name["paper-seed1-".len()..]
            .chars()
            .all(|c| c.is_ascii_hexdigit()));
        assert_ne!(median, krum);
        // The same overrides in another order or spacing: the same folder.
        let ab = strings(&["a.x=1", "b.y=2"]);
        let ba = strings(&["b.y = 2", "a.x=1"]);
        assert_eq!(digest(&ab, None), digest(&ba, None));
        // A configuration file is a change too, told apart by its contents.
        assert_ne!(
            default_run_dir("paper", 1, &[], Some(b"[world]\nrobots = 30\n")),
            default_run_dir("paper", 1, &[], None)
        );
        assert_ne!(
            digest(&[], Some(b"[world]\nrobots = 30\n")),
            digest(&[], Some(b"[world]\nrobots = 31\n"))
        );
        // Lengths are hashed: moving bytes between an override and the file changes the name.
        assert_ne!(
            digest(&strings(&["a=1"]), Some(b"2")),
            digest(&strings(&["a=12"]), None)
        );
        // Seeds and presets stay in the name.
        assert_ne!(
            default_run_dir("smoke", 2, &ab, None),
            default_run_dir("smoke", 3, &ab, None)
        );
    }

    #[test]
    fn a_forks_default_folder_stands_beside_its_parents() {
        let set = strings(&["contract.security=false"]);
        let fork = default_fork_dir(Path::new("runs/s7/run.swlog"), 20, &set);
        let expected = format!("runs/s7-fork-at-20-{}", digest(&set, None));
        assert_eq!(fork, Path::new(&expected));
        let bare = default_fork_dir(Path::new("run.swlog"), 20, &set);
        assert_eq!(
            bare,
            Path::new(".").join(format!("run-fork-at-20-{}", digest(&set, None)))
        );
        assert_ne!(
            default_fork_dir(Path::new("runs/s7/run.swlog"), 20, &strings(&["x=1"])),
            fork
        );
    }

    fn header(seed: u64, config: &swarmfl_core::config::Config) -> Header {
        Header::new(seed, config.to_toml())
    }

    /// A fresh folder of this test under the system's temporary folder.
    fn scratch(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("swarmfl-run-dir-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// A folder holding a run (a header-only log of `header`, its summary and page) and a file
    /// of the user's.
    fn folder_with_run(name: &str, header: &Header) -> PathBuf {
        let dir = scratch(name);
        let writer = swarmfl_core::log::LogWriter::create(&dir.join("run.swlog"), header).unwrap();
        writer.finish().unwrap();
        let summary = r#"{"seed": 7, "final_hash": "0123456789abcdef"}"#;
        std::fs::write(dir.join("summary.json"), summary).unwrap();
        std::fs::write(dir.join("run.html"), "the old run's page").unwrap();
        std::fs::write(dir.join("notes.txt"), "mine").unwrap();
        dir
    }

    #[test]
    fn a_default_folder_keeps_another_configurations_run_unless_forced() {
        use swarmfl_core::config::Config;
        let smoke = Config::resolve(Some("smoke"), None, &[]).unwrap();
        // Another seed in the default folder: refused, every file left as it was.
        let dir = folder_with_run("refused", &header(7, &smoke));
        let refused = prepare(&dir, &header(8, &smoke), Chosen::Default).unwrap_err();
        let message = format!("{refused:#}");
        assert!(message.contains("holds a run of another configuration (seed 7, final hash 0123456789ab...; differs: seed: 7 -> 8): nothing was replaced"), "{message}");
        assert!(
            message.contains("--out DIR") && message.contains("--force"),
            "{message}"
        );
        for name in ["run.swlog", "summary.json", "run.html", "notes.txt"] {
            assert!(dir.join(name).exists(), "{name}");
        }
        // The same with --force, or named with --out: replaced, saying what it was; the
        // run's files go, the user's stay and are named.
        for chosen in [Chosen::Forced, Chosen::Explicit] {
            let dir = folder_with_run("forced", &header(7, &smoke));
            let note = prepare(&dir, &header(8, &smoke), chosen).unwrap().unwrap();
            assert!(note.starts_with("replacing the previous run in "), "{note}");
            assert!(
                note.contains("(seed 7, final hash 0123456789ab...; differs: seed: 7 -> 8)"),
                "{note}"
            );
            assert!(
                note.ends_with("(they may describe the old one): notes.txt"),
                "{note}"
            );
            let files: Vec<String> = std::fs::read_dir(&dir)
                .unwrap()
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect();
            assert_eq!(files, vec!["notes.txt".to_string()], "{chosen:?}");
            let _ = std::fs::remove_dir_all(&dir);
        }
        // The same configuration again in the default folder: replaced, and said so.
        let note = prepare(&dir, &header(7, &smoke), Chosen::Default)
            .unwrap()
            .unwrap();
        assert!(note.contains("the same configuration and seed"), "{note}");
        assert!(!dir.join("run.html").exists());
        // An empty folder, or none: nothing to say.
        assert_eq!(
            prepare(&dir.join("new"), &header(7, &smoke), Chosen::Default).unwrap(),
            None
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_run_differs_by_seed_configuration_and_origin_but_not_by_build() {
        use swarmfl_core::config::Config;
        let smoke = Config::resolve(Some("smoke"), None, &[]).unwrap();
        let median =
            Config::resolve(Some("smoke"), None, &strings(&["contract.rule=median"])).unwrap();
        assert!(differences(&header(7, &smoke), &header(7, &smoke)).is_empty());
        let mut other_build = header(7, &smoke);
        other_build.crate_version = "0.0.0".to_string();
        assert!(differences(&other_build, &header(7, &smoke)).is_empty());
        assert_eq!(
            differences(&header(7, &smoke), &header(8, &smoke)),
            vec!["seed: 7 -> 8".to_string()]
        );
        let d = differences(&header(7, &smoke), &header(7, &median));
        assert_eq!(d, vec![r#"contract.rule: "paper" -> "median""#.to_string()]);
    }
}
