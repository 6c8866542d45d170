//! Plug-in attacks: an [`Attack`] supplied by the program that runs the simulation rather than
//! built into the core (the Python package implements [`Attack`] for a Python class). A run
//! with `byzantine.kind = "plugin"` names its plug-in in `byzantine.plugin`; the driver takes
//! the agent of that name from the [`Plugins`] it is given, and the log header records the
//! plug-in's [`PluginId`] (name and source digest), so that a re-simulation or a fork can
//! refuse an absent or changed plug-in by name instead of diverging somewhere in the log.
//!
//! A plug-in attack is asked exactly as the built-in ones are: on the driver thread, in robot
//! order, with the same [`super::View`] and the robot's `Purpose::Byzantine` substream. What it
//! answers is therefore deterministic as long as the plug-in itself is a function of what it is
//! given (the Python package documents what holds for Python code).

use std::collections::BTreeMap;
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::Attack;
use crate::config::{ByzantineKind, Config, Rule};
use crate::contract::rules::plugin::{self as rule_plugin, RuleId, RulePlugin};

/// A plug-in as a log header records it.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct PluginId {
    /// What it plugs into: `attack` or `rule`.
    pub kind: String,
    /// Its name, as `byzantine.plugin` names it.
    pub name: String,
    /// The hex blake3 digest of its source.
    pub digest: String,
    /// What was hashed (for example `inspect.getsource(SignFlip)`), for the messages.
    pub source: String,
}

impl PluginId {
    /// The id of an attack plug-in.
    pub fn attack(name: &str, digest: &str, source: &str) -> PluginId {
        PluginId {
            kind: "attack".to_string(),
            name: name.to_string(),
            digest: digest.to_string(),
            source: source.to_string(),
        }
    }

    /// The id of an aggregation-rule plug-in.
    pub fn rule(name: &str, digest: &str, source: &str) -> PluginId {
        PluginId {
            kind: "rule".to_string(),
            ..PluginId::attack(name, digest, source)
        }
    }

    /// `attack `name` (blake3 abcd1234...)`, for messages.
    pub fn describe(&self) -> String {
        format!(
            "plug-in {} `{}` (blake3 {} of {})",
            self.kind, self.name, self.digest, self.source
        )
    }
}

/// The plug-ins a program offers a run, by name.
#[derive(Clone, Default)]
pub struct Plugins {
    attacks: BTreeMap<String, (PluginId, Arc<dyn Attack>)>,
    rules: BTreeMap<String, PluginId>,
}

impl std::fmt::Debug for Plugins {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list()
            .entries(self.attacks.values().map(|(id, _)| id))
            .entries(self.rules.values())
            .finish()
    }
}

impl Plugins {
    /// No plug-ins (what the command offers).
    pub fn none() -> Plugins {
        Plugins::default()
    }

    /// Offers `attack` under `id.name` (replacing one of the same name).
    pub fn add_attack(&mut self, id: PluginId, attack: Arc<dyn Attack>) {
        self.attacks.insert(id.name.clone(), (id, attack));
    }

    /// Offers the aggregation rule `rule` under `id.name`: registers it with the contract's
    /// plug-in rules ([`rule_plugin::register`]), where every node's contract and every fold
    /// of the run's log finds it by name and digest.
    pub fn add_rule(&mut self, id: PluginId, rule: Arc<dyn RulePlugin>) {
        let key = RuleId {
            name: id.name.clone(),
            digest: id.digest.clone(),
        };
        rule_plugin::register(key, rule);
        self.rules.insert(id.name.clone(), id);
    }

    /// The attack plug-in called `name`.
    pub fn attack(&self, name: &str) -> Option<&Arc<dyn Attack>> {
        self.attacks.get(name).map(|(_, a)| a)
    }

    /// The ids of the plug-ins `config` uses (what its log header records), or why one is
    /// missing.
    pub fn used_by(&self, config: &Config) -> Result<Vec<PluginId>, String> {
        let mut used = Vec::new();
        if config.byzantine.kind == ByzantineKind::Plugin {
            let name = &config.byzantine.plugin;
            match self.attacks.get(name) {
                Some((id, _)) => used.push(id.clone()),
                None => return Err(missing(name)),
            }
        }
        if config.rule() == Rule::Plugin {
            let name = &config.contract.rule_plugin;
            match self.rules.get(name) {
                Some(id) => used.push(id.clone()),
                None => return Err(rule_plugin::missing(name, None)),
            }
        }
        Ok(used)
    }

    /// Checks that every plug-in a log `recorded` is offered here with the same source: the
    /// error names the plug-in and both digests.
    pub fn check(&self, recorded: &[PluginId]) -> Result<(), String> {
        for id in recorded {
            let offered = match id.kind.as_str() {
                "attack" => self.attacks.get(&id.name).map(|(o, _)| o),
                "rule" => self.rules.get(&id.name),
                _ => None,
            };
            match offered {
                None => {
                    return Err(format!(
                        "the log was made with {}, which is not given: {}",
                        id.describe(),
                        if id.kind == "attack" {
                            "pass the same attack class (swarmfl.replay(..., attack=...) or \
                             swarmfl.fork(..., attack=...) in Python); the swarmfl command cannot \
                             run plug-ins (it reads the log from its records without the attack: \
                             replay without --resimulate, view, snapshot, inspect, export)"
                                .to_string()
                        } else if id.kind == "rule" {
                            "pass the same rule (swarmfl.open/replay/fork(..., rule=...) in \
                             Python; swarmfl.open(..., rule=...).view(OUT) and .snapshot(OUT, \
                             ...) draw it); every reading of the log re-executes the contract, \
                             whose aggregates the rule computes (the records hold the \
                             submissions, not the aggregates), and the swarmfl command cannot \
                             run plug-ins"
                                .to_string()
                        } else {
                            format!("this swarmfl does not know plug-ins of kind `{}`", id.kind)
                        }
                    ))
                }
                Some(o) if o.digest != id.digest => {
                    return Err(format!(
                        "plug-in {} `{}` changed: the log records blake3 {} of {}, the given one \
                         has {} of {}; replay with the source the run was made with, or re-run",
                        id.kind, id.name, id.digest, id.source, o.digest, o.source
                    ))
                }
                Some(_) => {}
            }
        }
        Ok(())
    }
}

/// Why the plug-in attack `name` cannot be found.
pub fn missing(name: &str) -> String {
    format!(
        "byzantine.kind = \"plugin\" names the plug-in attack `{name}` (byzantine.plugin), which \
         is not given: plug-in attacks run only from the Python package (swarmfl.run(..., \
         attack=...)); the swarmfl command cannot run plug-ins"
    )
}

/// What a run with `byzantine.kind = "plugin"` gets from [`super::attack`]: the offered agent.
pub(super) fn lookup(plugins: &Plugins, name: &str) -> Result<Arc<dyn Attack>, String> {
    plugins.attack(name).cloned().ok_or_else(|| missing(name))
}
