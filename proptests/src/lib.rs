//! Property-based tests across swarmfl-core live in `tests/`.
