//! The typed summary of a run (`summary.json`) and of a sweep's task (its result file): core's
//! [`RunSummary`] with the figures the run adds (wall time, log size, timing, EVM gas), and a
//! result file's `sweep` section. Read once where the file is read ([`Summary::read`],
//! [`ResultFile::read`]) and passed typed to every report, table, figure and text; written
//! through [`to_json`], whose bytes are those of the summaries written before these types
//! (`serde_json` sorts a map's keys, the flattened sections included).

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::Context;
use serde::{Deserialize, Deserializer, Serialize};
use swarmfl_core::summary::RunSummary;

/// A finished run's `summary.json`: core's figures of the run, then what the driver measured.
/// Read through a JSON map ([`TryFrom`]) rather than serde's `flatten`, whose buffer cannot
/// hold the `u128` token totals.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(try_from = "JsonMap")]
pub struct Summary {
    /// The figures of the run ([`RunSummary::new`]), at the top level of the file.
    #[serde(flatten)]
    pub run: RunSummary,
    /// Wall seconds of the whole run (simulation, log and summary).
    pub wall_s: f64,
    /// Bytes of the log.
    pub log_bytes: u64,
    /// Wall and CPU seconds per part of the driver.
    pub timing: Timing,
    /// With `contract.engine = "evm"` only: the gas of the contract calls on the final
    /// canonical chain by kind (`accepted`, `aggregated`, `outlier`, the refusals, `deploy`).
    /// Absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub evm_gas: Option<BTreeMap<String, EvmGas>>,
}

/// The `timing` section: wall seconds of the driver thread per part (`<part>_s`) and CPU
/// seconds (`<part>_cpu_s`: the driver thread's in that part, and for learning also every
/// other thread's). A CPU clock that was unavailable wrote NaN, which JSON holds as `null`
/// and which reads back as NaN.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Timing {
    /// Moving the robots, sensing and the radio.
    #[serde(deserialize_with = "nan_if_null")]
    pub world_s: f64,
    /// The ledger (a baseline's aggregation protocol).
    #[serde(deserialize_with = "nan_if_null")]
    pub ledger_s: f64,
    /// Training, or waiting for trainings on the pool.
    #[serde(deserialize_with = "nan_if_null")]
    pub learning_s: f64,
    /// Checkpoints of the state.
    #[serde(deserialize_with = "nan_if_null")]
    pub checkpoint_s: f64,
    /// Writing the log and the summary.
    #[serde(deserialize_with = "nan_if_null")]
    pub log_and_summary_s: f64,
    /// CPU seconds of [`Timing::world_s`].
    #[serde(deserialize_with = "nan_if_null")]
    pub world_cpu_s: f64,
    /// CPU seconds of [`Timing::ledger_s`].
    #[serde(deserialize_with = "nan_if_null")]
    pub ledger_cpu_s: f64,
    /// CPU seconds of [`Timing::learning_s`] (the background trainings included).
    #[serde(deserialize_with = "nan_if_null")]
    pub learning_cpu_s: f64,
    /// CPU seconds of [`Timing::checkpoint_s`].
    #[serde(deserialize_with = "nan_if_null")]
    pub checkpoint_cpu_s: f64,
    /// CPU seconds of [`Timing::log_and_summary_s`].
    #[serde(deserialize_with = "nan_if_null")]
    pub log_and_summary_cpu_s: f64,
}

/// The parts of [`Timing`] in the order the driver runs them, by the name `summary.json` gives
/// them (`<name>_s`, `<name>_cpu_s`).
pub const TIMING_PARTS: [&str; 5] = [
    "world",
    "ledger",
    "learning",
    "checkpoint",
    "log_and_summary",
];

impl Timing {
    /// `(wall s, CPU s)` of each part of [`TIMING_PARTS`], in that order.
    pub fn parts(&self) -> [(f64, f64); 5] {
        [
            (self.world_s, self.world_cpu_s),
            (self.ledger_s, self.ledger_cpu_s),
            (self.learning_s, self.learning_cpu_s),
            (self.checkpoint_s, self.checkpoint_cpu_s),
            (self.log_and_summary_s, self.log_and_summary_cpu_s),
        ]
    }
}

/// The gas of the contract calls of one kind, as `summary.json`'s `evm_gas` holds it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct EvmGas {
    /// Number of calls.
    pub calls: u64,
    /// Mean gas per call (0 without calls).
    pub mean_gas: u64,
    /// The smallest.
    pub min_gas: u64,
    /// The largest.
    pub max_gas: u64,
    /// The sum.
    pub total_gas: u64,
}

/// A sweep's result file, `DIR/<experiment>/<point>/seed<N>.json`: the run's summary, and the
/// `sweep` section naming the task.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(try_from = "JsonMap")]
pub struct ResultFile {
    /// The run's summary, at the top level of the file.
    #[serde(flatten)]
    pub summary: Summary,
    /// The task that made it.
    pub sweep: SweepTask,
}

/// The `sweep` section of a result file: the task that made it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SweepTask {
    /// The experiment (a built-in one, or a `--grid` sweep's name).
    pub experiment: String,
    /// The point of its grid.
    pub point: String,
    /// The seed.
    pub seed: u64,
    /// The task's index in the sweep.
    pub task: usize,
    /// Every `--set` of the run: the point's own, then the sweep-wide ones.
    pub overrides: Vec<String>,
    /// The preset the experiment starts from.
    pub preset: String,
    /// The point's position in its grid.
    pub point_index: usize,
    /// The point's x value (`null` where it has none, e.g. a grid over a text key).
    pub x: Option<f64>,
}

/// A JSON object as read, before it is typed.
type JsonMap = serde_json::Map<String, serde_json::Value>;

/// Takes the field `key` of `map` as a `T` (an absent one as `null`: `None` for an option);
/// the error names the field.
fn take<T: for<'de> Deserialize<'de>>(map: &mut JsonMap, key: &str) -> Result<T, String> {
    match map.remove(key) {
        Some(value) => T::deserialize(value).map_err(|e| format!("field `{key}`: {e}")),
        None => {
            T::deserialize(serde_json::Value::Null).map_err(|_| format!("missing field `{key}`"))
        }
    }
}

impl TryFrom<JsonMap> for Summary {
    type Error = String;

    fn try_from(mut map: JsonMap) -> Result<Summary, String> {
        let wall_s = take(&mut map, "wall_s")?;
        let log_bytes = take(&mut map, "log_bytes")?;
        let timing = take(&mut map, "timing")?;
        let evm_gas = take(&mut map, "evm_gas")?;
        let run =
            RunSummary::deserialize(serde_json::Value::Object(map)).map_err(|e| e.to_string())?;
        Ok(Summary {
            run,
            wall_s,
            log_bytes,
            timing,
            evm_gas,
        })
    }
}

impl TryFrom<JsonMap> for ResultFile {
    type Error = String;

    fn try_from(mut map: JsonMap) -> Result<ResultFile, String> {
        let sweep = take(&mut map, "sweep")?;
        let summary = Summary::try_from(map)?;
        Ok(ResultFile { summary, sweep })
    }
}

/// The JSON of a summary or result file as written to disk (pretty, a final newline). A
/// `serde_json::Value` sorts every map's keys, so the bytes do not depend on the order of the
/// fields in the types (nor on `flatten`).
pub fn to_json(value: &impl Serialize) -> anyhow::Result<String> {
    Ok(serde_json::to_string_pretty(&serde_json::to_value(value)?)? + "\n")
}

impl Summary {
    /// Reads a run's `summary.json` at `path`; the error names the file and what is wrong
    /// (a missing or mistyped field by name).
    pub fn read(path: &Path) -> anyhow::Result<Summary> {
        read_json(path, "a run's summary")
    }
}

impl ResultFile {
    /// Reads a sweep's result file at `path`; the error names the file and what is wrong
    /// (a missing or mistyped field by name).
    pub fn read(path: &Path) -> anyhow::Result<ResultFile> {
        read_json(path, "a sweep's result file")
    }

    /// Parses the bytes of the result file at `path` (named in the error).
    pub fn parse(bytes: &[u8], path: &Path) -> anyhow::Result<ResultFile> {
        parse_json(bytes, path, "a sweep's result file")
    }
}

fn read_json<T: for<'de> Deserialize<'de>>(path: &Path, what: &str) -> anyhow::Result<T> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    parse_json(&bytes, path, what)
}

fn parse_json<T: for<'de> Deserialize<'de>>(
    bytes: &[u8],
    path: &Path,
    what: &str,
) -> anyhow::Result<T> {
    serde_json::from_slice(bytes).map_err(|e| {
        anyhow::anyhow!(
            "{} is not {what} this version reads: {e} (written by another version, or damaged; \
             run it again to rewrite it)",
            path.display()
        )
    })
}

/// An `f64` written as `null` (serde_json writes NaN and infinities so) reads back as NaN.
pub fn nan_if_null<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// A count of a map by outcome or reason name (a summary's `contract.submissions`, `skipped`,
/// `evm_gas`: maps whose keys are the names core gives its outcomes, not fields).
pub fn count(map: &BTreeMap<String, u64>, name: &str) -> Option<u64> {
    map.get(name).copied()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A result file as a sweep wrote it (reduced study, e1-faulty, one faulty robot, seed 1).
    pub(crate) fn example() -> ResultFile {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../reproduction/reduced-study/results/e1-faulty/faulty-1/seed1.json");
        ResultFile::read(&path).unwrap()
    }

    /// Every result file under `reproduction/*/results`.
    fn committed_results() -> Vec<std::path::PathBuf> {
        fn walk(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
            let Ok(entries) = std::fs::read_dir(dir) else {
                return;
            };
            for e in entries.map(|e| e.unwrap().path()) {
                if e.is_dir() {
                    walk(&e, out);
                } else if e.extension().is_some_and(|x| x == "json") {
                    out.push(e);
                }
            }
        }
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../reproduction");
        let mut out = Vec::new();
        for study in std::fs::read_dir(&root).unwrap() {
            walk(&study.unwrap().path().join("results"), &mut out);
        }
        out.sort();
        out
    }

    /// Every field of every committed result file is read and written back as it was: the
    /// typed file is the JSON the file holds (numbers as serde_json parses them, whose last
    /// digit can differ from the text's; the reports read them so before these types too).
    #[test]
    fn every_committed_result_file_reads_every_field_as_written() {
        let files = committed_results();
        assert!(files.len() > 3000, "{} result files", files.len());
        for path in files {
            let bytes = std::fs::read(&path).unwrap();
            let json: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
            let typed = ResultFile::parse(&bytes, &path).unwrap();
            let again = serde_json::to_value(&typed).unwrap();
            assert!(
                again == json,
                "{} does not write back as read",
                path.display()
            );
            assert_eq!(
                serde_json::to_string_pretty(&json).unwrap() + "\n",
                to_json(&typed).unwrap()
            );
        }
    }

    #[test]
    fn a_missing_field_is_named_with_the_file() {
        let path = Path::new("results/e1-faulty/faulty-1/seed1.json");
        let json = to_json(&example()).unwrap();
        for field in [
            "\"wall_s\"",
            "\"point_index\"",
            "\"canonical_height\"",
            "\"seed\"",
        ] {
            let renamed = json.replace(field, "\"renamed\"");
            let err = ResultFile::parse(renamed.as_bytes(), path)
                .unwrap_err()
                .to_string();
            assert!(
                err.contains("results/e1-faulty/faulty-1/seed1.json")
                    && err.contains(&format!("missing field `{}`", field.trim_matches('"'))),
                "{err}"
            );
        }
    }

    #[test]
    fn nan_is_written_as_null_and_read_back_as_nan() {
        let mut made = example();
        made.summary.timing.world_cpu_s = f64::NAN;
        made.summary.run.contract.loss_by_round = vec![0.5, f64::NAN];
        let json = to_json(&made).unwrap();
        assert!(json.contains("\"world_cpu_s\": null"), "{json}");
        let back = ResultFile::parse(json.as_bytes(), Path::new("x.json")).unwrap();
        assert!(back.summary.timing.world_cpu_s.is_nan());
        assert!(back.summary.run.contract.loss_by_round[1].is_nan());
        assert_eq!(to_json(&back).unwrap(), json);
    }
}
