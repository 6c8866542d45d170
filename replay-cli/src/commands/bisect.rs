//! `swarmfl bisect`: the first block of the final canonical chain where a predicate holds (in a
//! baseline run, the first checkpoint by time).

use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;

use swarmfl_core::inspect::{self, timeline, Expr};

use crate::cli::BisectArgs;
use crate::exit::EXIT_DIVERGED;
use crate::progress::warn_if_truncated;

/// Runs `swarmfl bisect`: exit 1 when the predicate holds nowhere.
pub fn command(args: BisectArgs) -> anyhow::Result<ExitCode> {
    let BisectArgs {
        log,
        until,
        monotone,
        json,
    } = args;
    Ok(if bisect(&log, &until, monotone, json)? {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(EXIT_DIVERGED)
    })
}

/// Prints the first block where `expr` holds.
fn bisect(log: &Path, expr: &str, monotone: bool, json: bool) -> anyhow::Result<bool> {
    let predicate = Expr::parse(expr)?;
    if is_baseline(log)? {
        return bisect_by_time(log, expr, &predicate, monotone, json);
    }
    let start = Instant::now();
    let index = inspect::index_run(log, None)?;
    warn_if_truncated(&index);
    let fold_ms = start.elapsed().as_secs_f64() * 1000.0;
    let values = index.values();
    let search = Instant::now();
    let hit = inspect::bisect(&values, &predicate, monotone)?;
    let search_ms = search.elapsed().as_secs_f64() * 1000.0;
    // Every block's values are in memory: checking the whole chain costs microseconds and
    // tells whether the binary search's premise holds.
    let profile = inspect::profile(&values, &predicate)?;
    if json {
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "expression": expr,
                "monotone": monotone,
                "hit": hit,
                "profile": profile,
                "last_height": index.last_height(),
                "truncated": index.truncated,
                "why_not": if hit.is_none() { why_not(&index, &values, &predicate) } else { Vec::new() },
                "fold_ms": fold_ms,
                "search_ms": search_ms,
            }))?
        );
    } else {
        match &hit {
            Some(h) => {
                println!(
                    "first block where `{expr}` holds{}: height {} at t = {:.3} s",
                    if monotone {
                        " (binary search, monotone)"
                    } else {
                        " (scan)"
                    },
                    h.height,
                    h.time_s
                );
                for (name, value) in &h.values {
                    println!("  {name} = {}", readable(*value));
                }
                println!(
                    "{} evaluations; fold {fold_ms:.0} ms, search {search_ms:.1} ms",
                    h.evaluations
                );
            }
            None => {
                println!(
                    "`{expr}` holds at no block of the final canonical chain (heights 0..={}){}",
                    index.last_height(),
                    if monotone {
                        "; with --monotone only the last block is tested"
                    } else {
                        ""
                    }
                );
                for line in why_not(&index, &values, &predicate) {
                    println!("  {line}");
                }
            }
        }
        if profile.monotone {
            println!("the predicate is monotone over the chain: scan and --monotone agree");
        } else {
            println!(
                "warning: the predicate is NOT monotone over the chain (it turns false again {} times): first true at {}, true for good from {}{}",
                profile.relapses,
                describe(&index, profile.first),
                describe(&index, profile.for_good_from),
                if monotone {
                    "; the binary search's answer is only a change to true"
                } else {
                    ""
                }
            );
        }
    }
    Ok(hit.is_some())
}

/// Why a predicate holds nowhere: for each value it reads, the range it takes over the chain,
/// or why it is NaN at every block (no Byzantine robots, no closed round, ...).
fn why_not(
    index: &inspect::RunIndex,
    values: &inspect::ChainValues<'_>,
    predicate: &Expr,
) -> Vec<String> {
    let mut ranges: Vec<(String, f64, f64)> = Vec::new();
    for h in 0..values.len() as u64 {
        for (name, v) in predicate.leaves(&values.at(h)) {
            let slot = match ranges.iter().position(|r| r.0 == name) {
                Some(i) => &mut ranges[i],
                None => {
                    ranges.push((name, f64::NAN, f64::NAN));
                    ranges.last_mut().expect("just pushed")
                }
            };
            if !v.is_nan() {
                slot.1 = if slot.1.is_nan() { v } else { slot.1.min(v) };
                slot.2 = if slot.2.is_nan() { v } else { slot.2.max(v) };
            }
        }
    }
    let byzantine = index.byzantine.iter().filter(|&&b| b).count();
    ranges
        .into_iter()
        .map(|(name, lo, hi)| {
            if !lo.is_nan() {
                return format!("`{name}` ranges over [{lo}, {hi}] on the chain");
            }
            let why = if name.starts_with("byzantine_") && byzantine == 0 {
                ": this run has no Byzantine robots (byzantine.count = 0); run one with \
                 e.g. --set byzantine.kind=malicious --set byzantine.count=3"
                    .to_string()
            } else if name.starts_with("honest_") && byzantine == index.byzantine.len() {
                ": every robot of this run is Byzantine".to_string()
            } else if name == "loss" {
                ": no round closed on the chain".to_string()
            } else {
                String::new()
            };
            format!("`{name}` is NaN at every block (a comparison with NaN is false){why}")
        })
        .collect()
}

/// A block of the chain and its time, for the search profile's lines.
fn describe(index: &inspect::RunIndex, height: Option<u64>) -> String {
    match height {
        Some(h) => format!(
            "block {h} (t = {:.3} s)",
            index.chain[h as usize].time.secs()
        ),
        None => "no block".to_string(),
    }
}

/// Whether the log is a baseline run (`learn.aggregation` other than `chain`): no blocks, so
/// it is inspected and bisected by time.
fn is_baseline(log: &Path) -> anyhow::Result<bool> {
    let reader = swarmfl_core::log::LogReader::open(log)?;
    let config = swarmfl_core::replay::header_config(&reader, &log.display().to_string())?;
    Ok(config.learn.aggregation != swarmfl_core::config::Aggregation::Chain)
}

/// `bisect` over the checkpoints of a baseline run (one every block period).
fn bisect_by_time(
    log: &Path,
    expr: &str,
    predicate: &Expr,
    monotone: bool,
    json: bool,
) -> anyhow::Result<bool> {
    let start = Instant::now();
    let (hit, evaluations) = timeline::bisect_by_time(log, predicate, monotone)?;
    let took_ms = start.elapsed().as_secs_f64() * 1000.0;
    if json {
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "expression": expr,
                "monotone": monotone,
                "by": "time",
                "hit": hit.as_ref().map(|(t, values)| serde_json::json!({"time_s": t, "values": values})),
                "evaluations": evaluations,
                "ms": took_ms,
            }))?
        );
    } else {
        match &hit {
            Some((t, values)) => {
                println!(
                    "first checkpoint where `{expr}` holds: t = {t:.1} s (a baseline run: by time)"
                );
                for (name, value) in values {
                    println!("  {name} = {}", readable(*value));
                }
                println!("{evaluations} evaluations; {took_ms:.0} ms");
            }
            None => println!("`{expr}` holds at no checkpoint of the run"),
        }
    }
    Ok(hit.is_some())
}

/// A predicate value as a person reads it: integers as integers, other values to nine
/// decimals (a token's smallest unit) without trailing zeros, so a wealth prints as
/// `21.124822031`, not `21.124822030799997`.
fn readable(value: f64) -> String {
    if !value.is_finite() || value == value.trunc() && value.abs() < 1e15 {
        return format!("{value}");
    }
    let text = format!("{value:.9}");
    text.trim_end_matches('0').trim_end_matches('.').to_string()
}

#[cfg(test)]
mod tests {
    use super::readable;

    #[test]
    fn values_print_to_a_tokens_smallest_unit_without_float_noise() {
        assert_eq!(readable(21.124822030799997), "21.124822031");
        assert_eq!(readable(5.0), "5");
        assert_eq!(readable(0.25), "0.25");
        assert_eq!(readable(-0.6666666671333336), "-0.666666667");
        assert_eq!(readable(f64::NAN), "NaN");
    }
}
