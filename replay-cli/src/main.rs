//! The `swarmfl` command: run, replay and inspect swarmfl simulations (the commands live in
//! the crate's library, `lib.rs`, which the Python package shares).

use std::process::ExitCode;

fn main() -> ExitCode {
    swarmfl_cli::main()
}
