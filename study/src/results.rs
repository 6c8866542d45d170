//! The results directory a sweep writes and a report reads: one file per task,
//! `DIR/<experiment>/<point>/seed<N>.json` (the run's summary JSON plus a `sweep` section
//! naming the task: [`ResultFile`]), written atomically (temporary file + rename).

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
}
