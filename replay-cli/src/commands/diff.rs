//! `swarmfl diff`: two logs' header differences and first diverging record, or one log against
//! its re-simulation under this build (exit codes fit `git bisect run`).

use std::path::Path;
use std::process::ExitCode;

use swarmfl_core::replay::{self, ReplayError};

use crate::cli::DiffArgs;
use crate::exit::{EXIT_CANNOT_TEST, EXIT_DIVERGED, EXIT_ERROR};

/// Runs `swarmfl diff`.
pub fn command(args: DiffArgs) -> anyhow::Result<ExitCode> {
    diff(&args.a, args.b.as_deref(), args.resimulate).map(ExitCode::from)
}

/// Compares two logs, or one with its re-simulation, printing the outcome; returns the exit code.
fn diff(a: &Path, b: Option<&Path>, resimulate: bool) -> anyhow::Result<u8> {
    match (b, resimulate) {
        (None, true) => match replay::resimulate(a) {
            Ok(report) => {
                println!(
                    "identical: {} records re-simulated bit-exactly; final hash {}",
                    report.records, report.final_hash
                );
                Ok(0)
            }
            Err(ReplayError::Diverged {
                index,
                kind,
                time,
                component,
                detail,
                ..
            }) => {
                println!("first divergence from the re-simulation: record {index} ({kind} at t = {time}): {component} differs{detail}");
                Ok(EXIT_DIVERGED)
            }
            Err(e @ ReplayError::Apply { .. }) => {
                println!("first divergence from the re-simulation: {e}");
                Ok(EXIT_DIVERGED)
            }
            Err(e) => {
                // The log cannot be read (damaged, foreign, or a header this build does not
                // accept): nothing was compared, so this is not a divergence. 125 is
                // `git bisect run`'s "cannot test this commit, skip it".
                eprintln!("error: {e}");
                eprintln!(
                    "(exit {EXIT_CANNOT_TEST}: the log could not be compared; `git bisect run` \
                     skips this commit)"
                );
                Ok(EXIT_CANNOT_TEST)
            }
        },
        (Some(b), false) => {
            let report = match swarmfl_core::diff::diff_logs(a, b) {
                Ok(report) => report,
                Err(e) => {
                    // A damaged or unreadable log was not compared: that is an error (2), not
                    // "the logs differ" (1), so a script can tell the two apart.
                    eprintln!("error: {e:#}");
                    eprintln!(
                        "(exit {EXIT_ERROR}: a log could not be compared; exit {EXIT_DIVERGED} \
                         means the logs were read and differ)"
                    );
                    return Ok(EXIT_ERROR);
                }
            };
            if report.header_differences.is_empty() {
                println!("headers: same seed and configuration");
            } else {
                println!("headers differ:");
                for d in &report.header_differences {
                    println!("  {d}");
                }
            }
            match &report.divergence {
                None => {
                    println!(
                        "identical: {} records; final hashes {} / {}",
                        report.identical_records,
                        report.final_hashes.0.short(),
                        report.final_hashes.1.short()
                    );
                    Ok(if report.final_hashes.0 == report.final_hashes.1 {
                        0
                    } else {
                        EXIT_DIVERGED
                    })
                }
                Some(d) => {
                    println!(
                        "{} identical records, then the first divergence:",
                        report.identical_records
                    );
                    println!(
                        "  record {} at t = {} (byte offsets {} / {}), kinds {} / {}",
                        d.index, d.time, d.offsets.0, d.offsets.1, d.kinds.0, d.kinds.1
                    );
                    println!("  {}", d.explanation);
                    Ok(EXIT_DIVERGED)
                }
            }
        }
        (None, false) => anyhow::bail!("diff needs two logs, or one log and --resimulate"),
        (Some(_), true) => {
            anyhow::bail!("--resimulate compares one log with a re-simulation; give only one log")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use swarmfl_core::config::Config;
    use swarmfl_study::run;

    #[test]
    fn diff_resimulate_exits_125_on_a_log_it_cannot_read_and_1_on_divergence() {
        let dir = std::env::temp_dir().join(format!("swarmfl-diff-exit-{}", std::process::id()));
        let config = Config::resolve(
            Some("smoke"),
            None,
            &["run.duration_s=30".into(), "world.robots=4".into()],
        )
        .unwrap();
        let out = run::RunRequest::new(config.clone(), 1, &dir.join("a"))
            .run(&swarmfl_study::progress::Quiet)
            .unwrap();
        assert_eq!(diff(&out.log_path, None, true).unwrap(), 0);
        // Truncated, foreign and missing logs: git bisect's "skip", never "bad".
        let bytes = std::fs::read(&out.log_path).unwrap();
        let cut = dir.join("cut.swlog");
        std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
        assert_eq!(diff(&cut, None, true).unwrap(), EXIT_CANNOT_TEST);
        std::fs::write(&cut, b"not a log at all").unwrap();
        assert_eq!(diff(&cut, None, true).unwrap(), EXIT_CANNOT_TEST);
        assert_eq!(
            diff(&dir.join("missing.swlog"), None, true).unwrap(),
            EXIT_CANNOT_TEST
        );
        // A log whose header says seed 1 but whose records are seed 2's: it reads fine and
        // the re-simulation diverges.
        let header = swarmfl_core::log::Header::new(1, config.to_toml());
        let wrong = dir.join("wrong.swlog");
        let mut writer = swarmfl_core::log::LogWriter::create(&wrong, &header).unwrap();
        for record in swarmfl_core::sim::Sim::new(config, 2).unwrap() {
            writer.append(&record).unwrap();
        }
        writer.finish().unwrap();
        assert_eq!(diff(&wrong, None, true).unwrap(), EXIT_DIVERGED);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
