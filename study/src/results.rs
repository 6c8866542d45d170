//! The results directory a sweep writes and a report reads: one file per task,
//! `DIR/<experiment>/<point>/seed<N>.json` (the run's summary JSON plus a `sweep` section
//! naming the task: [`ResultFile`]), written atomically (temporary file + rename); the logs a
//! sweep keeps beside them, and the `.tmp` folder of those in progress ([`find_logs`], which
//! `ranking` and `traffic` read).

use std::path::{Path, PathBuf};

use anyhow::Context;

use crate::summary::{self, ResultFile, SweepTask};

/// The result file of a task: `DIR/<experiment>/<point>/seed<N>.json`.
pub fn result_path(dir: &Path, experiment: &str, point: &str, seed: u64) -> PathBuf {
    dir.join(experiment)
        .join(point)
        .join(format!("seed{seed}.json"))
}

/// Whether a result file exists and reads as one ([`ResultFile`]): a truncated or damaged
/// file, or one an older version wrote without a field this one reads, is a task to redo.
pub fn is_done(path: &Path) -> bool {
    ResultFile::read(path).is_ok()
}

/// The sweep-wide `--set` overrides a result file was made with: its `sweep.overrides` minus
/// the point's own (which every result of the point shares).
pub fn extra_overrides(sweep: &SweepTask, point_overrides: &[String]) -> Vec<String> {
    sweep
        .overrides
        .iter()
        .filter(|o| !point_overrides.contains(o))
        .cloned()
        .collect()
}

/// Shows overrides as the user typed them: `--set a=1 --set b=2`, or `no --set`.
pub fn show_overrides(overrides: &[String]) -> String {
    if overrides.is_empty() {
        "no --set".to_string()
    } else {
        overrides
            .iter()
            .map(|o| format!("--set {o}"))
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// Writes `value` to `path` atomically ([`summary::to_json`]'s bytes): a temporary file in the
/// same directory, then rename.
pub fn write_atomic(path: &Path, value: &impl serde::Serialize) -> anyhow::Result<()> {
    let dir = path.parent().context("result path has no directory")?;
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let name = path
        .file_name()
        .context("result path has no file name")?
        .to_string_lossy();
    let tmp = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    std::fs::write(&tmp, summary::to_json(value)?)
        .with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, path)
        .with_context(|| format!("cannot rename {} to {}", tmp.display(), path.display()))?;
    Ok(())
}

/// The folder of a sweep's output that holds the logs of runs in progress (without
/// `--keep-logs`); readers of logs pass over it.
pub const TMP_DIR: &str = ".tmp";

/// Every `run.swlog` named by `inputs` (a log itself, or a directory searched recursively), in
/// path order, each with its path relative to its input. A sweep's in-progress logs (its
/// `.tmp` folders) are passed over, unless `.tmp` itself is an input. None found is an error
/// that names the inputs.
pub fn find_logs(inputs: &[PathBuf]) -> anyhow::Result<Vec<(PathBuf, String)>> {
    let mut out = Vec::new();
    for input in inputs {
        if input.is_file() {
            out.push((input.clone(), input.display().to_string()));
            continue;
        }
        anyhow::ensure!(
            input.is_dir(),
            "{} is neither a log nor a directory",
            input.display()
        );
        let mut stack = vec![input.clone()];
        let mut found = Vec::new();
        while let Some(dir) = stack.pop() {
            let entries = std::fs::read_dir(&dir)
                .with_context(|| format!("cannot read {}", dir.display()))?;
            for entry in entries {
                let path = entry?.path();
                if path.is_dir() {
                    if path.file_name().is_none_or(|n| n != TMP_DIR) {
                        stack.push(path);
                    }
                } else if path.file_name().is_some_and(|n| n == "run.swlog") {
                    found.push(path);
                }
            }
        }
        found.sort();
        for path in found {
            let name = path
                .strip_prefix(input)
                .unwrap_or(&path)
                .display()
                .to_string();
            out.push((path, name));
        }
    }
    anyhow::ensure!(
        !out.is_empty(),
        "no run.swlog found under {} (give logs, or a sweep's results made with --keep-logs)",
        inputs
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn result_files_are_written_atomically_and_recognised() {
        let dir = std::env::temp_dir().join(format!("swarmfl-sweep-test-{}", std::process::id()));
        let path = result_path(&dir, "e2-faulty", "byzantine-3", 7);
        assert!(path.ends_with("e2-faulty/byzantine-3/seed7.json"));
        assert!(!is_done(&path));
        let made = crate::summary::tests::example();
        write_atomic(&path, &made).unwrap();
        assert!(is_done(&path));
        let bytes = std::fs::read_to_string(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
        assert!(!is_done(&path), "a truncated file is not a finished task");
        std::fs::write(&path, bytes.replace("\"log_bytes\"", "\"log_size\"")).unwrap();
        assert!(!is_done(&path), "a file without a field is a task to redo");
        write_atomic(&path, &made).unwrap();
        assert!(is_done(&path));
        let leftovers: Vec<_> = std::fs::read_dir(path.parent().unwrap())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(leftovers.len(), 1, "no temporary file left: {leftovers:?}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A sweep's in-progress logs sit in its `.tmp` folder: a search passes over them (they
    /// are not runs yet), but names them when given `.tmp` itself; none found is an error.
    #[test]
    fn find_logs_passes_over_in_progress_logs() {
        let root = std::env::temp_dir().join(format!("swarmfl-find-logs-{}", std::process::id()));
        let done = root.join("e4/point/seed1");
        let running = root.join(TMP_DIR).join("e4-point-seed2-1");
        std::fs::create_dir_all(&done).unwrap();
        std::fs::create_dir_all(&running).unwrap();
        std::fs::write(done.join("run.swlog"), b"").unwrap();
        std::fs::write(running.join("run.swlog"), b"").unwrap();

        let found = find_logs(std::slice::from_ref(&root)).unwrap();
        assert_eq!(found.len(), 1);
        assert_eq!(found[0].0, done.join("run.swlog"));
        let found = find_logs(&[root.join(TMP_DIR)]).unwrap();
        assert_eq!(found[0].0, running.join("run.swlog"));

        let empty = root.join("empty");
        std::fs::create_dir_all(&empty).unwrap();
        let err = find_logs(std::slice::from_ref(&empty))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("no run.swlog found under") && err.contains("empty"),
            "{err}"
        );
        std::fs::remove_dir_all(&root).unwrap();
    }
}
