//! The first block where a predicate holds (`swarmfl bisect`), and how it behaves over the
//! whole chain.

use serde::Serialize;

use super::error::InspectError;
use super::expr::Expr;
use super::values::ChainValues;

/// The first block of the final canonical chain where `predicate` holds.
#[derive(Clone, Debug, Serialize)]
pub struct BisectHit {
    /// Its height.
    pub height: u64,
    /// Its timestamp, s.
    pub time_s: f64,
    /// The values the predicate read there.
    pub values: Vec<(String, f64)>,
    /// Predicate evaluations done.
    pub evaluations: u64,
}

/// Finds the first block where `predicate` holds: a scan from genesis, or with `monotone`
/// a binary search (which assumes that once it holds, it holds at every later block; it then
/// evaluates O(log n) blocks). `None` when it holds nowhere (for `monotone`: not at the last
/// block).
pub fn bisect(
    values: &ChainValues<'_>,
    predicate: &Expr,
    monotone: bool,
) -> Result<Option<BisectHit>, InspectError> {
    let mut evaluations = 0u64;
    let mut holds = |h: u64| -> Result<bool, InspectError> {
        evaluations += 1;
        predicate
            .holds(&values.at(h))
            .map_err(|source| InspectError::Eval {
                block: h,
                cause: source,
            })
    };
    let found = first_holding(values.len() as u64 - 1, monotone, &mut holds)?;
    Ok(found.map(|h| {
        let env = values.at(h);
        BisectHit {
            height: h,
            time_s: values.index.chain[h as usize].time.secs(),
            values: predicate.leaves(&env),
            evaluations,
        }
    }))
}

/// The first point in `0..=last` where `holds` is true, or None. With `monotone` (the
/// predicate, once true, stays true) a binary search that evaluates it about log2(last) + 1
/// times; otherwise a scan from 0. Evaluation errors stop the search.
pub(super) fn first_holding<E>(
    last: u64,
    monotone: bool,
    mut holds: impl FnMut(u64) -> Result<bool, E>,
) -> Result<Option<u64>, E> {
    if !monotone {
        for i in 0..=last {
            if holds(i)? {
                return Ok(Some(i));
            }
        }
        return Ok(None);
    }
    if !holds(last)? {
        return Ok(None);
    }
    // Invariant: the predicate holds at `hi`; it does not hold below `lo`.
    let (mut lo, mut hi) = (0u64, last);
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if holds(mid)? {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    Ok(Some(hi))
}

/// How a predicate behaves over the whole final canonical chain.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Profile {
    /// The first block where it holds.
    pub first: Option<u64>,
    /// The first block from which it holds at every later block ("for good").
    pub for_good_from: Option<u64>,
    /// Whether it is monotone (false, then true for good).
    pub monotone: bool,
    /// How many times it turns from true to false.
    pub relapses: u64,
}

/// Evaluates `predicate` at every block (cheap: the values are in memory once the log is
/// folded) to tell whether a `--monotone` answer can be trusted.
pub fn profile(values: &ChainValues<'_>, predicate: &Expr) -> Result<Profile, InspectError> {
    let mut truth = Vec::with_capacity(values.len());
    for h in 0..values.len() as u64 {
        truth.push(
            predicate
                .holds(&values.at(h))
                .map_err(|source| InspectError::Eval {
                    block: h,
                    cause: source,
                })?,
        );
    }
    let first = truth.iter().position(|&t| t).map(|h| h as u64);
    let for_good_from = match truth.iter().rposition(|&t| !t) {
        None => Some(0),
        Some(last_false) if last_false + 1 < truth.len() => Some(last_false as u64 + 1),
        Some(_) => None,
    };
    let relapses = truth.windows(2).filter(|w| w[0] && !w[1]).count() as u64;
    Ok(Profile {
        first,
        for_good_from,
        monotone: relapses == 0,
        relapses,
    })
}
