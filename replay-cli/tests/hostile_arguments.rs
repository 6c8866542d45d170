//! Arguments from the security review (issue #37) that crashed `swarmfl` or made it pass
//! without checking anything: each must now be refused with a clear error and exit code 2.

use std::process::Output;

mod common;
use common::swarmfl;

/// Asserts that `out` is a refusal (exit code 2, not a crash or a pass) whose stderr contains
/// `needle`.
fn assert_refused(out: &Output, needle: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{:?}: {stderr}", out.status);
    assert!(stderr.contains(needle), "{needle:?} not in: {stderr}");
}

#[test]
fn bisect_refuses_a_deeply_nested_predicate_instead_of_overflowing_the_stack() {
    let parens = format!("{}1{}", "(".repeat(5000), ")".repeat(5000));
    let nots = format!("{}1", "!".repeat(40_000));
    // Within the length limit but too deep: refused at the 129th level.
    let deep = format!("{}1{}", "(".repeat(1000), ")".repeat(1000));
    for (until, needle) in [
        (parens.as_str(), "bytes long; expected at most 4096"),
        (nots.as_str(), "bytes long; expected at most 4096"),
        (
            deep.as_str(),
            "at column 129: expression nests deeper than 128",
        ),
    ] {
        // The log does not exist: the predicate is refused before it is opened.
        let out = swarmfl(&["bisect", "absent.swlog", "--until", until]);
        assert_refused(&out, needle);
    }
}

#[test]
fn chaos_refuses_a_seed_range_that_wraps() {
    let out = swarmfl(&[
        "chaos",
        "--seeds",
        "2",
        "--first-seed",
        "18446744073709551615",
        "--json",
    ]);
    assert_refused(
        &out,
        "with --seeds 2 the largest allowed --first-seed is 18446744073709551614",
    );
    assert!(out.stdout.is_empty(), "no report on a refused range");
}
