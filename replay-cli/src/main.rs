//! The `swarmfl` command.
fn main() {}
