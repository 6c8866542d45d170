//! A results directory as one tidy table (Python's `swarmfl.results(dir)`): one row per result
//! file, in the report's order, with every override as a column of its own and the scalar
//! metrics `numbers.csv` averages, per run.

use std::collections::BTreeSet;
use std::path::Path;

use swarmfl_core::inspect::Column;

use super::load;
use super::stats::run_metrics;

/// A table with columns named at run time (override keys): `(name, column)` in order.
pub type Frame = Vec<(String, Column)>;

/// The results under `dir` as one table: `experiment, point, seed, x`, one column per override
/// key (in order of first appearance; typed: integers, floats (NaN where a run lacks the key),
/// booleans, else text ("" where missing)), then `duration_s`, each metric of `numbers.csv`
/// (NaN where a run lacks it), `wall_s`, `final_hash` and `config_hash`. Refuses what `report`
/// refuses (damaged files, a point that mixes configurations), with its message.
pub fn results_frame(dir: &Path) -> anyhow::Result<Frame> {
    let (results, _) = load::load(dir)?;
    anyhow::ensure!(
        !results.is_empty(),
        "no result files found under {} (expected <experiment>/<point>/seed<N>.json)",
        dir.display()
    );
    let overrides: Vec<Vec<(String, String)>> = results
        .iter()
        .map(|r| {
            r.result
                .sweep
                .overrides
                .iter()
                .filter_map(|o| o.split_once('='))
                .map(|(k, v)| (k.trim().to_string(), v.trim().to_string()))
                .collect()
        })
        .collect();
    let mut keys: Vec<String> = Vec::new();
    for (k, _) in overrides.iter().flatten() {
        if !keys.contains(k) {
            keys.push(k.clone());
        }
    }
    let per_run: Vec<_> = results
        .iter()
        .map(|r| run_metrics(&r.result.summary))
        .collect();
    let metric_names: BTreeSet<&'static str> = per_run
        .iter()
        .flat_map(|(m, _)| m.keys().copied())
        .collect();

    let text = |f: &dyn Fn(&load::RunResult) -> String| -> Column {
        Column::Str(results.iter().map(f).collect())
    };
    let number = |f: &dyn Fn(&load::RunResult) -> Option<f64>| -> Column {
        Column::F64(results.iter().map(|r| f(r).unwrap_or(f64::NAN)).collect())
    };
    let mut frame: Frame = vec![
        ("experiment".into(), text(&|r| r.experiment.clone())),
        ("point".into(), text(&|r| r.point.clone())),
        (
            "seed".into(),
            Column::U64(results.iter().map(|r| r.seed).collect()),
        ),
        ("x".into(), number(&|r| r.result.sweep.x)),
    ];
    for key in &keys {
        let values: Vec<Option<&str>> = overrides
            .iter()
            .map(|o| o.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str()))
            .collect();
        frame.push((key.clone(), typed(&values)));
    }
    frame.push((
        "duration_s".into(),
        number(&|r| Some(r.result.summary.run.sim_time_s)),
    ));
    for name in &metric_names {
        frame.push((
            (*name).to_string(),
            Column::F64(
                per_run
                    .iter()
                    .map(|(m, _)| m.get(name).copied().unwrap_or(f64::NAN))
                    .collect(),
            ),
        ));
    }
    frame.push((
        "wall_s".into(),
        Column::F64(per_run.iter().map(|(_, w)| w.unwrap_or(f64::NAN)).collect()),
    ));
    frame.push((
        "final_hash".into(),
        text(&|r| r.result.summary.run.final_hash.clone()),
    ));
    frame.push((
        "config_hash".into(),
        text(&|r| r.result.summary.run.config_hash.clone()),
    ));
    Ok(frame)
}

/// An override's values as one typed column: integers if every run has an integer, floats if
/// every present value is a number (NaN where missing), booleans if every run has one, else
/// text (a TOML string's quotes removed; "" where missing).
fn typed(values: &[Option<&str>]) -> Column {
    if let Some(v) = values
        .iter()
        .map(|v| v.and_then(|t| t.parse::<i64>().ok()))
        .collect::<Option<Vec<i64>>>()
    {
        return Column::I64(v);
    }
    let floats: Option<Vec<f64>> = values
        .iter()
        .map(|v| match v {
            None => Some(f64::NAN),
            Some(t) => t.parse::<f64>().ok(),
        })
        .collect();
    if let Some(v) = floats {
        return Column::F64(v);
    }
    if let Some(v) = values
        .iter()
        .map(|v| match *v {
            Some("true") => Some(true),
            Some("false") => Some(false),
            _ => None,
        })
        .collect::<Option<Vec<bool>>>()
    {
        return Column::Bool(v);
    }
    Column::Str(
        values
            .iter()
            .map(|v| {
                let t = v.unwrap_or("");
                t.strip_prefix('"')
                    .and_then(|t| t.strip_suffix('"'))
                    .unwrap_or(t)
                    .to_string()
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn override_columns_are_typed_by_their_values() {
        assert_eq!(typed(&[Some("1"), Some("3")]), Column::I64(vec![1, 3]));
        let Column::F64(f) = typed(&[Some("1.5"), None]) else {
            panic!("floats")
        };
        assert_eq!(f[0], 1.5);
        assert!(f[1].is_nan());
        assert_eq!(
            typed(&[Some("true"), Some("false")]),
            Column::Bool(vec![true, false])
        );
        assert_eq!(
            typed(&[Some("median"), Some("\"krum\""), None]),
            Column::Str(vec!["median".into(), "krum".into(), String::new()])
        );
    }
}
