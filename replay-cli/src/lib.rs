//! The `swarmfl` command as a library: the binary (`main.rs`) is [`main`]; the integration
//! tests reach its parts through it. The work is the core's and the study crate's
//! (`swarmfl-study`, which the Python package calls too); this crate parses arguments,
//! dispatches, draws progress, prints and maps errors to exit codes.

mod cli;
mod commands;
mod exit;
mod live;
mod progress;
mod summary;

use std::process::ExitCode;

use clap::Parser;

use crate::cli::{Cli, Command};
use crate::commands::*;

/// The `swarmfl` command: parses the process's arguments, runs the subcommand and maps an
/// error to its exit code (`exit.rs`).
pub fn main() -> ExitCode {
    // Output piped into `head` and the like ends quietly, as other command-line tools do,
    // instead of panicking on the broken pipe.
    // SAFETY: called once at start-up, before any other thread exists; SIG_DFL is a valid
    // disposition for SIGPIPE.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    match dispatch(cli.command) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(exit::of_error(&e))
        }
    }
}

/// Runs one subcommand.
fn dispatch(command: Command) -> anyhow::Result<ExitCode> {
    match command {
        Command::Run(args) => run::command(args),
        Command::Replay(args) => replay::command(args),
        Command::Snapshot(args) => snapshot::command(args),
        Command::View(args) => view::command(args),
        Command::Diff(args) => diff::command(args),
        Command::Fixtures(args) => fixtures::command(args),
        Command::Inspect(args) => inspect::command(args),
        Command::Bisect(args) => bisect::command(args),
        Command::Fork(args) => fork::command(args),
        Command::Blame(args) => blame::command(args),
        Command::Contributions(args) => contributions::command(args),
        Command::Export(args) => export::command(args),
        Command::Ranking(args) => ranking::command(args),
        Command::Traffic(args) => traffic::command(args),
        Command::Sweep(args) => sweep::command(args),
        Command::Report(args) => report::command(args),
        Command::Chaos(args) => chaos::command(args),
        Command::Recheck(args) => recheck::command(args),
        Command::Presets => presets::command(),
        Command::Config { config } => config::command(&config),
        Command::Bench(args) => bench::command(args),
        Command::DataVolume(args) => data_volume::command(args),
        Command::BenchScaleOne(args) => bench::scale_one(args),
    }
}
