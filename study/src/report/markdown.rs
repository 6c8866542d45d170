//! Markdown pieces the report's modules share (a leaf: it imports none of them).

use std::fmt::Write as _;

/// Writes a markdown table's header and its rule line: `| a | b |` then `|---|---|`.
pub fn header(md: &mut String, columns: &[String]) {
    let _ = writeln!(md, "| {} |", columns.join(" | "));
    let _ = writeln!(md, "|{}", "---|".repeat(columns.len()));
}
