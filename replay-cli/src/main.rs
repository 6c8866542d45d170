//! The `swarmfl` command: run, replay and inspect swarmfl simulations.

mod bench_train;
mod bench_world;
mod snapshot;

use clap::{Parser, Subcommand, ValueEnum};

/// swarmfl: a deterministic, event-sourced replay engine for blockchain-secured federated
/// learning in robot swarms.
#[derive(Parser, Debug)]
#[command(name = "swarmfl", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Time one subsystem and print its figures.
    Bench {
        /// Which subsystem.
        target: BenchTarget,
        /// Print machine-readable JSON.
        #[arg(long)]
        json: bool,
    },
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum BenchTarget {
    /// Physics + sensing + data.
    World,
    /// One local training of the reference workload.
    Train,
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Some(Command::Bench { target: BenchTarget::World, json }) => bench_world::run(json),
        Some(Command::Bench { target: BenchTarget::Train, json }) => bench_train::run(json),
        None => Ok(()),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::from(2)
        }
    }
}
