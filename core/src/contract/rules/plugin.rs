//! `plugin`: an aggregation rule supplied by the program that runs the simulation rather than
//! built into the core (the Python package implements [`RulePlugin`] for a Python function).
//! A run with `contract.rule = "plugin"` names it in `contract.rule_plugin`; the contract's
//! parameters (committed by the genesis block) record its [`RuleId`], name and blake3 digest
//! of its source, so a run with another rule, or another source, has another genesis.
//!
//! The rule is integers in, integers out, like the built-in ones: it is given the shared model,
//! the round's accepted models in submission order and `f`, and answers the next shared model.
//! What it *used* (the reward rule pays exactly those) is decided here, as for the built-in
//! rules that produce an aggregate without selecting models: the `q - f` submissions nearest
//! (L1) to the answer ([`super::nearest`]). A plug-in computing the coordinate-wise median
//! therefore reproduces `median`'s rounds, models and payouts exactly.
//!
//! Where the rule is found. The contract runs on every node and in every fold of a log (the
//! loaders, the viewer, a fork's prefix check), far from the program that offers plug-ins, so
//! plug-in rules live in a process-wide registry keyed by name *and* digest: a lookup is
//! content-addressed, so a changed source is never picked up under the old parameters, and
//! nothing is iterated into state. [`ContractParams::check`](super::super::ContractParams)
//! refuses parameters whose rule is not registered, naming it, before a contract is built.
//!
//! Failure. A reducer must not panic on its input, and a plug-in's answer is input: when the
//! plug-in fails (it raises, answers another length, a weight outside int48), the round keeps
//! the shared model it was opened on ([`fallback`]). The implementation keeps its first error
//! and the program that offered it stops the run before its next record (the Python package
//! raises `swarmfl.PluginError`), so a fallback never reaches a finished record.

use std::collections::BTreeMap;
use std::sync::{Arc, RwLock};

use serde::{Deserialize, Serialize};

use super::{nearest, Aggregate, Input};
use crate::contract::MAX_WEIGHT_MAGNITUDE;

/// A plug-in rule as the contract's parameters record it.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct RuleId {
    /// Its name, as `contract.rule_plugin` names it.
    pub name: String,
    /// The hex blake3 digest of its source.
    pub digest: String,
}

/// An aggregation rule supplied from outside the core.
pub trait RulePlugin: Send + Sync {
    /// The next shared model of a round: `current` the model the round was opened on, `inputs`
    /// the accepted submissions in submission order (non-empty, each of `current`'s length),
    /// `f` the assumed Byzantine count (`contract.assumed_f`). An `Err` means the plug-in
    /// failed: the implementation keeps the error for the program that offered it, which
    /// stops the run.
    fn aggregate(&self, current: &[i64], inputs: &[Input], f: usize) -> Result<Vec<i64>, String>;
}

type Registry = BTreeMap<RuleId, Arc<dyn RulePlugin>>;

/// The registered rules, and per name the id registered last (what a configuration naming
/// only the rule gets).
static REGISTRY: RwLock<(Registry, BTreeMap<String, RuleId>)> =
    RwLock::new((BTreeMap::new(), BTreeMap::new()));

/// Registers `rule` under `id` (replacing an earlier registration of the same id) and makes it
/// the one `contract.rule_plugin = id.name` gets from now on.
pub fn register(id: RuleId, rule: Arc<dyn RulePlugin>) {
    let mut r = REGISTRY.write().unwrap_or_else(|p| p.into_inner());
    r.1.insert(id.name.clone(), id.clone());
    r.0.insert(id, rule);
}

/// The id registered last under `name`, if any.
pub fn current(name: &str) -> Option<RuleId> {
    let r = REGISTRY.read().unwrap_or_else(|p| p.into_inner());
    r.1.get(name).cloned()
}

/// Whether `id` is registered.
pub fn is_registered(id: &RuleId) -> bool {
    let r = REGISTRY.read().unwrap_or_else(|p| p.into_inner());
    r.0.contains_key(id)
}

/// Why the plug-in rule `name` cannot be found.
pub fn missing(name: &str, digest: Option<&str>) -> String {
    let which = match digest {
        Some(d) => format!("`{name}` (blake3 {d})"),
        None => format!("`{name}`"),
    };
    format!(
        "contract.rule = \"plugin\" names the plug-in rule {which} (contract.rule_plugin), which \
         is not given: plug-in rules run only from the Python package (swarmfl.run(..., \
         rule=...), and for its logs swarmfl.open/replay/fork(..., rule=...), with \
         swarmfl.open(..., rule=...).view(OUT) and .snapshot(OUT, ...) to draw one: every \
         reading of a log re-executes the contract, whose aggregates the rule computes); the \
         swarmfl command cannot run plug-ins"
    )
}

/// The rule as its line in the [`Rule`](crate::config::Rule) registry names it, when the
/// plug-in is not at hand: a plug-in is found by the id in the contract's parameters, which
/// `ContractParams::round_aggregate` passes to [`aggregate`]; validation keeps plug-in rules
/// out of the pre-aggregator chain, the only other caller. Without an id the round keeps its
/// model ([`fallback`]) rather than panic in a reducer.
pub struct Plugin;

impl super::AggregationRule for Plugin {
    fn aggregate(&self, round: &super::Round) -> Aggregate {
        fallback(round.current, round.inputs, round.f)
    }
}

/// What a round keeps when the plug-in failed: the model it was opened on, and as used the
/// `q - f` submissions nearest to it (the run stops before this reaches a record).
pub fn fallback(current: &[i64], inputs: &[Input], f: usize) -> Aggregate {
    Aggregate {
        weights: current.to_vec(),
        used: nearest(inputs, current, inputs.len().saturating_sub(f).max(1)),
    }
}

/// The plug-in rule `id`'s aggregate, or [`fallback`] when it is not registered or fails.
pub fn aggregate(id: &RuleId, current: &[i64], inputs: &[Input], f: usize) -> Aggregate {
    let rule = {
        let r = REGISTRY.read().unwrap_or_else(|p| p.into_inner());
        r.0.get(id).cloned()
    };
    let Some(rule) = rule else {
        return fallback(current, inputs, f);
    };
    match rule.aggregate(current, inputs, f) {
        Ok(weights)
            if weights.len() == current.len()
                && weights
                    .iter()
                    .all(|w| w.unsigned_abs() < MAX_WEIGHT_MAGNITUDE) =>
        {
            let used = nearest(inputs, &weights, inputs.len().saturating_sub(f).max(1));
            Aggregate { weights, used }
        }
        _ => fallback(current, inputs, f),
    }
}

#[cfg(test)]
mod tests {
    use super::super::{inputs_of, median};
    use super::*;

    /// The median, as a plug-in would write it.
    struct Median;
    impl RulePlugin for Median {
        fn aggregate(&self, _: &[i64], inputs: &[Input], f: usize) -> Result<Vec<i64>, String> {
            Ok(median::aggregate(inputs, f).weights)
        }
    }

    /// A plug-in that answers one weight too many.
    struct TooLong;
    impl RulePlugin for TooLong {
        fn aggregate(&self, c: &[i64], _: &[Input], _: usize) -> Result<Vec<i64>, String> {
            Ok(vec![0; c.len() + 1])
        }
    }

    fn id(name: &str, digest: &str) -> RuleId {
        RuleId {
            name: name.into(),
            digest: digest.into(),
        }
    }

    #[test]
    fn a_registered_median_aggregates_and_uses_as_median_does() {
        let models: [(&[i64], u64); 3] = [(&[1, -5], 1), (&[9, 0], 1), (&[2, 100], 4)];
        let inputs = inputs_of(&models);
        register(id("test-median", "aa"), Arc::new(Median));
        assert_eq!(current("test-median"), Some(id("test-median", "aa")));
        let a = aggregate(&id("test-median", "aa"), &[0, 0], &inputs, 1);
        assert_eq!(a, median::aggregate(&inputs, 1));
        // Another digest of the same name is another rule: not registered, so the fallback.
        assert!(!is_registered(&id("test-median", "bb")));
        let b = aggregate(&id("test-median", "bb"), &[0, 0], &inputs, 1);
        assert_eq!(b, fallback(&[0, 0], &inputs, 1));
        assert_eq!(b.weights, vec![0, 0]);
    }

    #[test]
    fn a_wrong_length_answer_keeps_the_model() {
        let models: [(&[i64], u64); 2] = [(&[1, 2], 1), (&[3, 4], 1)];
        let inputs = inputs_of(&models);
        register(id("test-too-long", "cc"), Arc::new(TooLong));
        let a = aggregate(&id("test-too-long", "cc"), &[7, 8], &inputs, 0);
        assert_eq!(a.weights, vec![7, 8]);
        assert_eq!(a.used.len(), 2);
    }
}
