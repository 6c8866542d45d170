//! `swarmfl recheck`: checks committed studies ([`swarmfl_study::recheck`]) and prints what
//! it found, one study a paragraph; exit code 3 when one diverged.

use std::process::ExitCode;

use swarmfl_study::recheck::{check_study, stale_reason};

use crate::cli::RecheckArgs;
use crate::exit::EXIT_DIVERGED;

/// Problems printed per study (the count says how many more there are).
const SHOWN: usize = 12;

/// Runs `swarmfl recheck`.
pub fn command(args: RecheckArgs) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(
        !args.dirs.is_empty(),
        "name at least one study directory (e.g. reproduction/full-study)"
    );
    let jobs = args
        .jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .max(1);
    let mut failed = 0usize;
    for dir in &args.dirs {
        if let Some(reason) = stale_reason(dir)? {
            println!(
                "{}: marked stale in README.md, not checked: {reason}",
                dir.display()
            );
            continue;
        }
        let findings = check_study(dir, args.tasks, args.max_task_s, &args.experiments, jobs)?;
        for (experiment, files) in &findings.needs_evm {
            println!(
                "{}: experiment {experiment} not checked ({files} result files): its runs use \
                 contract.engine = evm, which this build lacks; `recheck` from a build with \
                 `--features evm` checks them",
                dir.display()
            );
        }
        for (experiment, fastest) in &findings.not_rerun {
            println!(
                "{}: experiment {experiment} not re-run: its fastest task took {fastest:.0} s, \
                 over --max-task-s (configurations and report still checked; recheck without \
                 --max-task-s to re-run it)",
                dir.display()
            );
        }
        if findings.problems.is_empty() {
            println!(
                "{}: ok ({} result files match today's configurations, the report matches, \
                 re-ran {} task(s) bit-exactly)",
                dir.display(),
                findings.files,
                findings.reran
            );
        } else {
            failed += 1;
            println!(
                "{}: {} problems (re-make the study with `swarmfl sweep` and `swarmfl report`, \
                 or add a `Stale: <why>` line to its README.md)",
                dir.display(),
                findings.problems.len()
            );
            for p in findings.problems.iter().take(SHOWN) {
                println!("  {p}");
            }
            if findings.problems.len() > SHOWN {
                println!("  ... and {} more", findings.problems.len() - SHOWN);
            }
        }
    }
    Ok(if failed == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(EXIT_DIVERGED)
    })
}
