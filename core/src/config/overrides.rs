//! How a configuration is resolved from a preset, a TOML file and `key.path=value` overrides,
//! and which keys a fork may change in the middle of a run.

use std::path::Path;

use super::error::ConfigError;
use super::hints::{self, SerdeMessage};
use super::preset::Preset;
use super::tree::Config;

impl Config {
    /// Resolves a configuration: the preset, then the file (a partial TOML overlaid on the
    /// preset; it may name its own `preset`), then each `key.path=value` override in order,
    /// then validation.
    pub fn resolve(
        preset: Option<&str>,
        file: Option<&Path>,
        overrides: &[String],
    ) -> Result<Config, ConfigError> {
        let text = match file {
            Some(path) => Some(std::fs::read_to_string(path).map_err(|e| ConfigError::Io {
                path: path.display().to_string(),
                message: e.to_string(),
            })?),
            None => None,
        };
        let source_name = file.map(|p| p.display().to_string()).unwrap_or_default();
        Config::resolve_text(
            preset,
            text.as_deref().map(|t| (t, source_name.as_str())),
            overrides,
        )
    }

    /// Parses the text of a configuration file (a partial TOML overlaid on its own `preset`, or
    /// on `paper`) and validates it; `source_name` names the text in errors. This is
    /// [`Config::resolve`] without the file system and without overrides.
    pub fn from_toml_str(text: &str, source_name: &str) -> Result<Config, ConfigError> {
        Config::resolve_text(None, Some((text, source_name)), &[])
    }

    /// [`Config::resolve`] on a file's text and name instead of its path.
    fn resolve_text(
        preset: Option<&str>,
        file: Option<(&str, &str)>,
        overrides: &[String],
    ) -> Result<Config, ConfigError> {
        let mut file_table: Option<(toml::Table, &str)> = None;
        let mut preset_name = preset.map(str::to_string);
        if let Some((text, source_name)) = file {
            let table: toml::Table = toml::from_str(text).map_err(|e| ConfigError::Parse {
                source_name: source_name.to_string(),
                message: e.to_string(),
            })?;
            if preset_name.is_none() {
                if let Some(p) = table.get("preset").and_then(|v| v.as_str()) {
                    preset_name = Some(p.to_string());
                }
            }
            file_table = Some((table, source_name));
        }
        let preset = Preset::from_name(preset_name.as_deref().unwrap_or("paper"))?;
        let mut config = preset.config();
        let mut explicit = std::collections::BTreeSet::new();
        if let Some((table, _)) = &file_table {
            collect_keys("", table, &mut explicit);
        }
        if let Some((table, source_name)) = file_table {
            let mut base = full_tree(&config);
            let keys = hints::dotted_keys(&base);
            merge(
                &mut base,
                toml::Value::Table(table.clone()),
                "",
                source_name,
                &keys,
            )?;
            config = base.try_into().map_err(|e: toml::de::Error| {
                locate(&config, &table, source_name, &keys).unwrap_or(ConfigError::Parse {
                    source_name: source_name.to_string(),
                    message: e.to_string(),
                })
            })?;
            config.preset = preset.name().to_string();
        }
        for assignment in overrides {
            config.set(assignment)?;
            if let Some((key, _)) = assignment.split_once('=') {
                explicit.insert(key.trim().to_string());
            }
        }
        config.derive(&explicit);
        config.validate().map_err(|e| match e {
            ConfigError::OutOfRange { ref key, .. }
                if !explicit.is_empty() && !explicit.iter().any(|set| covers(set, key)) =>
            {
                ConfigError::NotSetByYou {
                    key: key.clone(),
                    preset: config.preset.clone(),
                    set: explicit.iter().cloned().collect::<Vec<_>>().join(", "),
                    cause: Box::new(e),
                }
            }
            e => e,
        })?;
        Ok(config)
    }

    /// Makes the values the user did not set follow the ones they did, where a preset's value
    /// only suits the preset's swarm: `contract.penalised_ranks` is clamped to `quorum - 1` (a
    /// swarm of 2..5 robots has a quorum of 1 or 2, so the paper's 2 of 7 cannot apply) and
    /// `world.peer_refresh_s` is raised to `run.tick_s` (peers are refreshed at most once a
    /// tick). `explicit` holds the dotted keys set by a file or an override: those are never
    /// changed, so a contradiction among them is reported by [`Config::validate`] naming the
    /// user's own key. A configuration that already validates is left as it is, so every
    /// existing run keeps its records.
    pub fn derive(&mut self, explicit: &std::collections::BTreeSet<String>) {
        let set = |key: &str| explicit.contains(key);
        if !set("contract.penalised_ranks") {
            let max = self.quorum().saturating_sub(1);
            self.contract.penalised_ranks = self.contract.penalised_ranks.min(max);
        }
        if !set("world.peer_refresh_s") && self.world.peer_refresh_s < self.run.tick_s {
            self.world.peer_refresh_s = self.run.tick_s;
        }
    }

    /// Applies one `key.path=value` override. The value is TOML (`0.5`, `true`, `"faulty"`,
    /// `[1, 1, -1]`); a bare word is taken as a string. The key must exist and the value must
    /// have the field's type; an error names the key, the value, what is expected and, for a
    /// typo of a key, the nearest key.
    pub fn set(&mut self, assignment: &str) -> Result<(), ConfigError> {
        let (key, raw) = assignment
            .split_once('=')
            .ok_or_else(|| ConfigError::Override {
                assignment: assignment.to_string(),
                message: "expected key.path=value, e.g. --set world.robots=30".to_string(),
            })?;
        let key = key.trim();
        let raw = raw.trim();
        let mut root = full_tree(self);
        let keys = hints::dotted_keys(&root);
        let mut slot = &mut root;
        let mut walked = String::new();
        for part in key.split('.') {
            let table = slot.as_table_mut().ok_or_else(|| ConfigError::UnknownKey {
                key: key.to_string(),
                allowed: format!("`{walked}` is a value, not a table; set `{walked}` itself"),
            })?;
            if !table.contains_key(part) {
                return Err(unknown_key(key.to_string(), key, &walked, table, &keys));
            }
            if !walked.is_empty() {
                walked.push('.');
            }
            walked.push_str(part);
            slot = table.get_mut(part).expect("checked above");
        }
        let value = parse_value(assignment, key, raw, slot)?;
        let value = coerce(key, slot, value).map_err(|expected| ConfigError::WrongType {
            key: key.to_string(),
            value: raw.to_string(),
            expected,
        })?;
        *slot = value;
        let updated: Config = root
            .try_into()
            .map_err(|e: toml::de::Error| value_error(self, key, key, raw, e.message()))?;
        *self = updated;
        Ok(())
    }

    /// Checks that `next` differs from `self` only in keys that may change in the middle of a
    /// run ([`RECONFIGURABLE`]), and returns the changed keys.
    pub fn check_reconfiguration(&self, next: &Config) -> Result<Vec<String>, ConfigError> {
        let changed = self.changed_keys(next);
        if let Some(key) = changed.iter().find(|k| !is_reconfigurable(k)) {
            return Err(ConfigError::NotReconfigurable {
                key: key.clone(),
                allowed: RECONFIGURABLE.join(", "),
            });
        }
        Ok(changed)
    }
}

/// The configuration keys a fork may change in the middle of a run (a trailing `.*` stands for
/// every key of that table). Everything else shapes the world, the model or the ledger from
/// genesis on: change it with a new run instead.
///
/// - `run.duration_s`: the run ends at the new time (after the fork point).
/// - `learn.*` except `lstm_units`: the robots' next trainings use the new hyper-parameters.
/// - `contract.security`, `stake_tokens`, `quorum_fraction`, `outlier_threshold`,
///   `penalised_ranks`, `rule`, `assumed_f`, `reward_weights`, the variant options
///   (`median` .. `pool`), `defence` and `defence_refund_percent`: the contract's rules change
///   for the blocks sealed after the fork point
///   (activation by block timestamp, as Ethereum's time-based upgrades); the round open on a
///   chain when it crosses the activation is restarted and its stakes refunded.
/// - `byzantine.*`: which robots misbehave, and how, from the fork point on.
/// - `output.*`: presentation only.
pub const RECONFIGURABLE: &[&str] = &[
    "run.duration_s",
    "learn.dropout",
    "learn.learning_rate",
    "learn.batch_size",
    "learn.epochs",
    "learn.train_fraction",
    "learn.training_period_s",
    "learn.training_duration_s",
    "learn.min_train_samples",
    "learn.withheld",
    "contract.security",
    "contract.stake_tokens",
    "contract.quorum_fraction",
    "contract.outlier_threshold",
    "contract.penalised_ranks",
    "contract.rule",
    "contract.assumed_f",
    "contract.reward_weights",
    "contract.median",
    "contract.fedavg_rounding",
    "contract.int48_products",
    "contract.threshold",
    "contract.rank_key",
    "contract.rank_ties",
    "contract.rank_order",
    "contract.payout_rounding",
    "contract.pool",
    "contract.defence",
    "contract.defence_refund_percent",
    "byzantine.*",
    "output.*",
];

/// True when `key` may change in the middle of a run (see [`RECONFIGURABLE`]).
pub fn is_reconfigurable(key: &str) -> bool {
    RECONFIGURABLE
        .iter()
        .any(|pattern| match pattern.strip_suffix('*') {
            Some(table) => key.starts_with(table),
            None => key == *pattern,
        })
}

impl Config {
    /// The TOML text with every key, also those [`Config::to_toml`] leaves out at their
    /// default: what `swarmfl config` prints, so every key can be read and set.
    pub fn to_toml_full(&self) -> String {
        toml::to_string(&full_tree(self)).expect("a TOML tree serialises")
    }
}

/// The configuration as a TOML tree with every key, including those [`Config::to_toml`]
/// leaves out at their default (keys added after records existed, whose recording would move
/// every run's hash), so that files and `--set` find them.
pub(super) fn full_tree(config: &Config) -> toml::Value {
    super::skip::with_every_key(|| toml::Value::try_from(config).expect("Config serialises"))
}

/// [`full_tree`] for the tests of the configuration.
#[cfg(test)]
pub(super) fn full_tree_for_tests(config: &Config) -> toml::Value {
    full_tree(config)
}

/// Overlays `patch` on `base`, table by table; a key that `base` lacks is an error naming it
/// and the nearest of `keys` (every dotted key of the whole tree).
fn merge(
    base: &mut toml::Value,
    patch: toml::Value,
    prefix: &str,
    source_name: &str,
    keys: &[String],
) -> Result<(), ConfigError> {
    match (base, patch) {
        (toml::Value::Table(b), toml::Value::Table(p)) => {
            for (k, v) in p {
                let path = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                match b.get_mut(&k) {
                    Some(slot) => merge(slot, v, &path, source_name, keys)?,
                    None => {
                        return Err(unknown_key(
                            format!("{path} (in {source_name})"),
                            &path,
                            prefix,
                            b,
                            keys,
                        ));
                    }
                }
            }
            Ok(())
        }
        (slot, value) => {
            let shown = value.to_string();
            *slot = coerce(prefix, slot, value).map_err(|expected| ConfigError::WrongType {
                key: format!("{prefix} (in {source_name})"),
                value: shown,
                expected,
            })?;
            Ok(())
        }
    }
}

/// Converts `value` to the type of `slot` (the value of `key`) where that loses nothing (an
/// integer where a float is expected); otherwise says what type was expected.
fn coerce(key: &str, slot: &toml::Value, value: toml::Value) -> Result<toml::Value, String> {
    use toml::Value as V;
    match (slot, value) {
        (V::Float(_), V::Integer(i)) => Ok(V::Float(i as f64)),
        (V::Float(_), v @ V::Float(_)) => Ok(v),
        // `"inf"` as text, for keys whose value may be infinite (`world.home_range.alpha`);
        // every other float key's range check refuses it by name.
        (V::Float(_), V::String(s)) if s.trim().eq_ignore_ascii_case("inf") => {
            Ok(V::Float(f64::INFINITY))
        }
        (V::Integer(_), v @ V::Integer(_)) => Ok(v),
        (V::Boolean(_), v @ V::Boolean(_)) => Ok(v),
        (V::String(_), v @ V::String(_)) => Ok(v),
        (V::Array(_), v @ V::Array(_)) => Ok(v),
        (V::Table(_), v @ V::Table(_)) => Ok(v),
        (slot, _) => Err(match slot {
            V::Float(_) => hints::number_expected(key),
            V::Integer(_) => "an integer".to_string(),
            V::Boolean(_) => "true or false".to_string(),
            V::String(s) => format!("a string (currently {s:?})"),
            V::Array(_) => hints::list_expected(key),
            V::Table(_) => "a table (name a field inside it)".to_string(),
            V::Datetime(_) => "a datetime".to_string(),
        }),
    }
}

/// Every dotted key of a value in a (partial) TOML table (`world.robots`, not `world`).
fn collect_keys(prefix: &str, table: &toml::Table, out: &mut std::collections::BTreeSet<String>) {
    for (k, v) in table {
        let key = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            toml::Value::Table(t) => collect_keys(&key, t, out),
            _ => {
                out.insert(key);
            }
        }
    }
}

/// Whether setting `set` (a dotted key, maybe a whole table or list such as `faults.crashes`)
/// sets `key` too (`faults.crashes[0].robot`).
fn covers(set: &str, key: &str) -> bool {
    key == set
        || key
            .strip_prefix(set)
            .is_some_and(|rest| rest.starts_with('.') || rest.starts_with('['))
}

/// serde's "unknown variant `krumm`, expected one of `a`, `b`" as an [`ConfigError::UnknownValue`]
/// that lists the choices and names the nearest one ([`hints::nearest`]); `None` for any other
/// message.
fn unknown_choice(key: &str, raw: &str, message: &str) -> Option<ConfigError> {
    let rest = message.strip_prefix("unknown variant `")?;
    let (value, rest) = rest.split_once('`')?;
    let list = rest
        .strip_prefix(", expected one of ")
        .or_else(|| rest.strip_prefix(", expected "))?;
    let choices: Vec<&str> = list
        .split(", ")
        .map(|c| c.trim().trim_start_matches("or ").trim_matches('`'))
        .filter(|c| !c.is_empty())
        .collect();
    let nearest = hints::nearest(value, choices.iter().copied())
        .map(|c| format!("; did you mean `{c}`?"))
        .unwrap_or_default();
    let listed = choices
        .iter()
        .map(|c| format!("`{c}`"))
        .collect::<Vec<_>>()
        .join(", ");
    Some(ConfigError::UnknownValue {
        key: key.to_string(),
        value: if value.is_empty() { raw } else { value }.to_string(),
        help: format!("{nearest}; the choices are: {listed}"),
    })
}

/// An unknown key: `shown` is how the message names it (`world.robotz`, or with its file),
/// `key` the dotted key, `walked` the table that lacks it and `table` that table's keys; the
/// nearest of `keys` (every dotted key) is suggested.
fn unknown_key(
    shown: String,
    key: &str,
    walked: &str,
    table: &toml::Table,
    keys: &[String],
) -> ConfigError {
    let mut allowed: Vec<&str> = table.keys().map(String::as_str).collect();
    allowed.sort_unstable();
    let guess = hints::nearest_key(key, keys)
        .map(|k| format!("did you mean `{k}`? "))
        .unwrap_or_default();
    ConfigError::UnknownKey {
        key: shown,
        allowed: format!(
            "{guess}{}: {}",
            if walked.is_empty() {
                "top-level keys"
            } else {
                walked
            },
            allowed.join(", ")
        ),
    }
}

/// The value of an override: TOML, or a bare word taken as a string. A value that starts as
/// TOML does (`[`, `{`, a quote) but does not parse is an error naming the parser's complaint
/// and what `key` (whose current value is `slot`) takes, rather than a string of the wrong
/// type.
fn parse_value(
    assignment: &str,
    key: &str,
    raw: &str,
    slot: &toml::Value,
) -> Result<toml::Value, ConfigError> {
    const PREFIX: &str = "v = ";
    match toml::from_str::<toml::Table>(&format!("{PREFIX}{raw}")) {
        Ok(mut t) => Ok(t.remove("v").expect("parsed table has v")),
        Err(e) if raw.starts_with(['[', '{', '"', '\'']) => {
            let at = e
                .span()
                .map(|s| format!(" at character {}", s.start.saturating_sub(PREFIX.len()) + 1))
                .unwrap_or_default();
            let expected = match slot {
                toml::Value::Array(_) => hints::list_expected(key),
                toml::Value::String(_) => format!("a string, e.g. --set {key}=word"),
                _ => "a single value".to_string(),
            };
            let count = |c: char| raw.matches(c).count();
            let open = count('[') != count(']')
                || count('{') != count('}')
                || count('"') % 2 == 1
                || count('\'') % 2 == 1;
            Err(ConfigError::Override {
                assignment: assignment.to_string(),
                message: format!(
                    "the value `{raw}` is not valid TOML ({}{at}{}); `{key}` takes {expected}",
                    e.message().trim().trim_end_matches('.'),
                    if open {
                        ": a bracket, brace or quote is left open"
                    } else {
                        ""
                    },
                ),
            })
        }
        Err(_) => Ok(toml::Value::String(raw.to_string())),
    }
}

/// serde's complaint (`message`) about the value `raw` of `key` in the user's terms: a typo of
/// a choice, a number out of its range (the range [`Config::validate`] allows, read from
/// `current`), an entry of a list that lacks or misnames a field. `shown` is how the message
/// names the key.
fn value_error(current: &Config, key: &str, shown: &str, raw: &str, message: &str) -> ConfigError {
    if let Some(e) = unknown_choice(shown, raw, message) {
        return e;
    }
    let entries = hints::list_example(key).is_some_and(|e| e.starts_with("[{"));
    let example = || match hints::list_example(key) {
        Some(e) => format!("e.g. --set '{key}={e}'"),
        None => format!("see `swarmfl config` for `{key}`"),
    };
    let bad_entry = |problem: String, fix: String| ConfigError::BadEntry {
        key: shown.to_string(),
        problem,
        fix,
    };
    match hints::read_serde(message) {
        SerdeMessage::InvalidValue(value, expected) if !entries => ConfigError::OutOfRange {
            key: shown.to_string(),
            value: value.to_string(),
            allowed: super::validate::allowed(current, key)
                .unwrap_or_else(|| hints::type_in_words(expected)),
        },
        SerdeMessage::InvalidValue(value, expected)
        | SerdeMessage::InvalidType(value, expected) => bad_entry(
            format!(
                "an entry holds {value}, where {} is expected",
                hints::type_in_words(expected)
            ),
            example(),
        ),
        SerdeMessage::MissingField(field) => bad_entry(
            format!("an entry lacks the field `{field}`"),
            format!("every entry needs it, {}", example()),
        ),
        SerdeMessage::UnknownField(field, fields) => bad_entry(
            format!("an entry has the unknown field `{field}`"),
            format!(
                "{}the fields are: {}",
                hints::nearest(field, fields.iter().copied())
                    .map(|f| format!("did you mean `{f}`? "))
                    .unwrap_or_default(),
                fields.join(", ")
            ),
        ),
        SerdeMessage::Other(m) => ConfigError::WrongType {
            key: shown.to_string(),
            value: raw.to_string(),
            expected: m.to_string(),
        },
    }
}

/// Which key of a file's `table` the configuration tree cannot take (serde's own message names
/// no key): each key's value is laid alone on `config`'s tree, and the first that fails is
/// told as [`value_error`] tells an override. `None` when each key alone is fine.
fn locate(
    config: &Config,
    table: &toml::Table,
    source_name: &str,
    keys: &[String],
) -> Option<ConfigError> {
    let mut set = std::collections::BTreeSet::new();
    collect_keys("", table, &mut set);
    let whole = toml::Value::Table(table.clone());
    set.into_iter().find_map(|key| {
        let mut value = &whole;
        for part in key.split('.') {
            value = value.get(part)?;
        }
        let mut single = toml::Value::Table(toml::Table::new());
        let mut slot = &mut single;
        for part in key.split('.') {
            slot = slot
                .as_table_mut()?
                .entry(part)
                .or_insert(toml::Value::Table(toml::Table::new()));
        }
        *slot = value.clone();
        let mut base = full_tree(config);
        merge(&mut base, single, "", source_name, keys).ok()?;
        let e = base.try_into::<Config>().err()?;
        let shown = format!("{key} (in {source_name})");
        Some(value_error(
            config,
            &key,
            &shown,
            &value.to_string(),
            e.message(),
        ))
    })
}
