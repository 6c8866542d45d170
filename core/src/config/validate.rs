//! [`Config::validate`]: every range is one line of a table walked by one loop; the checks that
//! relate several keys are named functions in the table, in the order they run (the first
//! violation is the one reported). The checks that concern a domain's support of the
//! configuration (the robust rules and the variant options, the baseline aggregations, the EVM
//! engine) read only configuration fields, so they live here too. The rows that check the
//! behaviours' keys are in `behaviour_fit.rs`, as the protocol's are in `protocol_fit.rs`.

use super::byzantine::ByzantineKind;
use super::contract::{
    ContractEngine, ContractOptions, Defence, GasEstimateState, GasLimitRule, Rule,
};
use super::error::ConfigError;
use super::ledger::LedgerBehaviour;
use super::preset::Preset;
use super::ranges::{
    integer, integer_range, number, number_range, out_of_range, positive, positive_range,
};
use super::timing::Timing;
use super::tree::{Aggregation, Config, DEFAULT_ROUND_TIMEOUT_S};
use crate::faults::PartitionKind;
use crate::types::show_f64;

/// A check that relates several keys: the first violation, if any.
type Check = fn(&Config) -> Result<(), ConfigError>;

/// One line of the validation table.
enum Step {
    /// `key`'s value is a finite number in `[lo, hi]`: (key, value, lo, hi).
    Number(&'static str, f64, f64, f64),
    /// `key`'s value is a finite number in `(0, hi]`: (key, value, hi). One message for both
    /// ends, so -100 and 1e12 are told the same range.
    Positive(&'static str, f64, f64),
    /// `key`'s value is an integer in `[lo, hi]`: (key, value, lo, hi).
    Integer(&'static str, u64, u64, u64),
    /// A check across keys.
    Across(Check),
}

impl Config {
    /// Checks every value against its allowed range; the first violation is returned, naming
    /// the key, the value and what is allowed.
    pub fn validate(&self) -> Result<(), ConfigError> {
        for step in table(self) {
            match step {
                Step::Number(key, value, lo, hi) => number(key, value, lo, hi)?,
                Step::Positive(key, value, hi) => positive(key, value, hi)?,
                Step::Integer(key, value, lo, hi) => integer(key, value, lo, hi)?,
                Step::Across(check) => check(self)?,
            }
        }
        Ok(())
    }
}

/// Every check of `c`, in the order they run. One row per key (kept by `rustfmt::skip`: a
/// table reads best one line a row).
#[rustfmt::skip]
fn table(c: &Config) -> Vec<Step> {
    use Step::{Across, Integer, Number, Positive};
    let (run, w, d, l) = (&c.run, &c.world, &c.data, &c.learn);
    let (g, k, b) = (&c.ledger, &c.contract, &c.byzantine);
    // Saturating: the table is built before any check runs, so an absurd initial_tokens must
    // reach its own check (tokens_fit_in_62_bits) rather than overflow here.
    let max_stake = k.initial_tokens.max(1).saturating_mul(1000);
    vec![
        Across(preset_is_known),
        Positive("run.duration_s", run.duration_s, 1.0e7),
        Number("run.tick_s", run.tick_s, 0.001, 10.0),
        Integer("world.robots", w.robots.into(), 1, 10_000),
        Number("world.arena_side_m", w.arena_side_m, 0.1, 10_000.0),
        Integer("world.cylinders", w.cylinders.into(), 0, 100_000),
        Number("world.cylinder_radius_m", w.cylinder_radius_m, 0.001, 1000.0),
        Integer("world.boxes", w.boxes.into(), 0, 100_000),
        Number("world.box_side_m", w.box_side_m, 0.001, 1000.0),
        Number("world.obstacle_spread_half_m", w.obstacle_spread_half_m, 0.0, 5_000.0),
        Number("world.robot_radius_m", w.robot_radius_m, 0.001, 10.0),
        Number("world.wheel_base_m", w.wheel_base_m, 0.001, 20.0),
        Number("world.cruise_speed_mps", w.cruise_speed_mps, 0.0, 10.0),
        Integer("world.proximity_sensors", w.proximity_sensors.into(), 1, 64),
        Number("world.proximity_range_m", w.proximity_range_m, 0.001, 10.0),
        Number("world.proximity_threshold", w.proximity_threshold, 0.0, 1.0),
        Across(super::behaviour_fit::ring_rules_have_eight_sensors),
        Number("world.random_turn_rate_per_s", w.random_turn_rate_per_s, 0.0, 100.0),
        Number("world.random_turn_max_s", w.random_turn_max_s, 0.0, 1000.0),
        Number("world.rab_range_m", w.rab_range_m, 0.0, 10_000.0),
        Number("world.rab_noise_std_m", w.rab_noise_std_m, 0.0, 100.0),
        Number("world.rab_packet_drop", w.rab_packet_drop, 0.0, 1.0),
        Number("world.peer_refresh_s", w.peer_refresh_s, run.tick_s, 1.0e6),
        Across(super::behaviour_fit::mixed_swarm_is_complete),
        Across(super::behaviour_fit::flocking_fits_the_arena),
        Across(super::behaviour_fit::foraging_fits_the_arena),
        Across(super::behaviour_fit::home_range_fits),
        Integer("data.trajectory_ticks", d.trajectory_ticks.into(), 2, 100_000),
        Integer("data.input_waypoints", d.input_waypoints.into(), 1, 10_000),
        Integer("data.target_waypoints", d.target_waypoints.into(), 1, 10_000),
        Across(waypoints_fit_the_trajectory),
        Number("data.expiration_s", d.expiration_s, 0.0, 1.0e7),
        Integer("data.heldout_samples", d.heldout_samples.into(), 0, 1_000_000),
        Integer("data.heldout_windows", d.heldout_windows.into(), 0, 100_000),
        Integer("learn.lstm_units", l.lstm_units.into(), 1, 1024),
        Number("learn.dropout", l.dropout, 0.0, 0.99),
        Number("learn.learning_rate", l.learning_rate, 0.0, 10.0),
        Integer("learn.batch_size", l.batch_size.into(), 1, 100_000),
        Integer("learn.epochs", l.epochs.into(), 0, 100_000),
        Number("learn.train_fraction", l.train_fraction, 0.01, 1.0),
        Positive("learn.training_period_s", l.training_period_s, 1.0e6),
        Number("learn.training_duration_s", l.training_duration_s, 0.0, 1.0e6),
        // At most a period: a robot's timer then never fires before its previous cycle's.
        Number("learn.authors_timing.byzantine_jitter_s", l.authors_timing.byzantine_jitter_s, 0.0, l.training_period_s),
        Number("learn.authors_timing.service_time_s", l.authors_timing.service_time_s, 0.0, 1.0e6),
        Across(authors_timing_fits),
        Positive("ledger.block_period_s", g.block_period_s, 1.0e6),
        Number("ledger.wiggle_unit_s", g.wiggle_unit_s, 0.0, 1.0e6),
        Number("ledger.packet_loss", g.packet_loss, 0.0, 1.0),
        Integer("contract.stake_tokens", k.stake_tokens, 0, max_stake),
        Integer("contract.token_units", k.token_units, 1, 1_000_000_000_000),
        Integer("contract.weight_scale", k.weight_scale, 1, 1_000_000_000_000),
        Across(tokens_fit_in_62_bits),
        Number("contract.quorum_fraction", k.quorum_fraction, 0.0, 1.0),
        Number("contract.outlier_threshold", k.outlier_threshold, 0.0, 1.0e6),
        // Before the rows that read the quorum, which is the buffer size under `buffered`.
        Across(super::protocol_fit::outlier_rule_fits),
        Across(super::protocol_fit::buffered_fits),
        Integer("contract.penalised_ranks", k.penalised_ranks.into(), 0, (c.quorum() - 1).into()),
        Across(robust_rules_need_security),
        Across(threshold_gate_needs_a_robust_rule),
        Across(assumed_f_fits_the_rule),
        Across(mda_search_fits),
        Across(reward_weights_fit_the_quorum),
        Across(variant_options_fit_the_rule),
        Integer("byzantine.count", b.count.into(), 0, w.robots.into()),
        Across(count_matches_the_misbehaviour),
        Across(plugin_is_named),
        Across(rule_plugin_is_named),
        Number("contract.round_timeout_s", k.round_timeout_s, 0.0, 1.0e9),
        // At least a plain transaction's intrinsic gas; at most what revm's gas counter holds
        // with room to spare.
        Integer("contract.block_gas_limit", k.block_gas_limit, 21_000, 1 << 62),
        Integer("contract.gas_margin", k.gas_margin, 0, 1 << 62),
        Across(gas_limit_needs_the_evm),
        Number("contract.gas_recommit_s", k.gas_recommit_s, 0.0, 1.0e6),
        Across(gas_estimate_needs_the_option),
        Integer("contract.max_claimed_samples", k.max_claimed_samples, 0, u32::MAX.into()),
        Across(faults_fit_the_run),
        Across(baseline_supports),
        // After the baseline: a baseline refuses the engine naming learn.aggregation, in
        // builds with or without the evm feature.
        Across(engine_supports),
        Integer("byzantine.claimed_samples", b.claimed_samples.into(), 1, 1_000_000_000),
        Number("byzantine.faulty_range", b.faulty_range, 0.0, 1000.0),
        Integer("byzantine.wait_for_honest", b.wait_for_honest.into(), 1, 10_000),
        Number("byzantine.scale", b.scale, 0.0, 1.0e6),
        Number("byzantine.sigma", b.sigma, 0.0, 1000.0),
        Number("byzantine.alie_z", b.alie_z, -1000.0, 1000.0),
        Number("byzantine.threshold_fraction", b.threshold_fraction, 0.0, 1000.0),
        Integer("byzantine.inflated_samples", b.inflated_samples.into(), 1, u32::MAX.into()),
        Across(switch_token_share_is_a_share),
        Integer("byzantine.search_evals", b.search_evals.into(), 1, 1000),
        Integer("contract.defence_refund_percent", k.defence_refund_percent.into(), 0, 100),
        Across(defences_need_stakes),
        Across(super::preagg_fit::chain_fits),
        Across(withheld_are_robots),
    ]
}

/// `learn.timing = "authors"` (`sim/timing/authors.rs`) schedules submissions to a chain's
/// contract: the baselines have none, and the honest robots' training time is the server's
/// (`learn.authors_timing.service_time_s`), not `learn.training_duration_s`.
fn authors_timing_fits(c: &Config) -> Result<(), ConfigError> {
    if c.learn.timing != Timing::Authors {
        return Ok(());
    }
    if c.learn.aggregation != Aggregation::Chain {
        return out_of_range(
            "learn.timing",
            "authors".to_string(),
            format!(
                "independent with learn.aggregation = {} (the authors' timing schedules \
                 submissions to the chain's contract); set learn.timing = independent or \
                 learn.aggregation = chain",
                c.learn.aggregation.name()
            ),
        );
    }
    if c.learn.training_duration_s != 0.0 {
        return out_of_range(
            "learn.training_duration_s",
            show_f64(c.learn.training_duration_s),
            "0 under learn.timing = authors (an honest training takes the server's \
             learn.authors_timing.service_time_s; a Byzantine robot submits when its timer \
             fires); set learn.training_duration_s = 0"
                .to_string(),
        );
    }
    Ok(())
}

/// What `key` allows when the table has a row for it (`an integer in [1, 10000]`), as
/// [`Config::validate`] says it; the bounds that depend on other keys are `c`'s.
pub(super) fn allowed(c: &Config, key: &str) -> Option<String> {
    table(c).into_iter().find_map(|step| match step {
        Step::Number(k, _, lo, hi) if k == key => Some(number_range(lo, hi)),
        Step::Positive(k, _, hi) if k == key => Some(positive_range(hi)),
        Step::Integer(k, _, lo, hi) if k == key => Some(integer_range(lo, hi)),
        _ => None,
    })
}

/// The preset names output folders (`runs/<preset>-seed<seed>`), so it must be one of the
/// known names, never a path.
fn preset_is_known(c: &Config) -> Result<(), ConfigError> {
    if Preset::from_name(&c.preset).is_ok() {
        return Ok(());
    }
    out_of_range(
        "preset",
        format!("{:?}", c.preset),
        format!("one of {}", Preset::ALL.map(Preset::name).join(", ")),
    )
}

fn waypoints_fit_the_trajectory(c: &Config) -> Result<(), ConfigError> {
    let d = &c.data;
    if d.input_waypoints + d.target_waypoints <= d.trajectory_ticks {
        return Ok(());
    }
    out_of_range(
        "data.target_waypoints",
        d.target_waypoints.to_string(),
        format!(
            "input_waypoints + target_waypoints <= trajectory_ticks ({})",
            d.trajectory_ticks
        ),
    )
}

fn tokens_fit_in_62_bits(c: &Config) -> Result<(), ConfigError> {
    let total = u128::from(c.world.robots)
        * u128::from(c.contract.initial_tokens)
        * u128::from(c.contract.token_units);
    if total <= u128::from(u64::MAX / 4) {
        return Ok(());
    }
    out_of_range(
        "contract.initial_tokens",
        c.contract.initial_tokens.to_string(),
        "robots * initial_tokens * token_units must fit in 2^62 units".to_string(),
    )
}

fn robust_rules_need_security(c: &Config) -> Result<(), ConfigError> {
    if c.contract.security || matches!(c.contract.rule, Rule::Paper | Rule::Fedavg) {
        return Ok(());
    }
    out_of_range(
        "contract.rule",
        c.contract.rule.name().to_string(),
        "fedavg or paper while contract.security = false (security off is the fedavg rule); \
         set contract.security = true to use another rule"
            .to_string(),
    )
}

/// `contract.threshold_gate` puts the paper's threshold in front of a robust rule: `paper`
/// has it already and `fedavg` (security off) stakes nothing to keep.
fn threshold_gate_needs_a_robust_rule(c: &Config) -> Result<(), ConfigError> {
    if !c.contract.threshold_gate || !matches!(c.rule(), Rule::Paper | Rule::Fedavg) {
        return Ok(());
    }
    out_of_range(
        "contract.threshold_gate",
        "true".to_string(),
        format!(
            "false with contract.rule = {}: the gate puts the paper's outlier threshold in \
             front of a robust rule (paper has it already, fedavg stakes nothing); set \
             contract.rule to a robust rule, or contract.threshold_gate = false",
            c.rule().name()
        ),
    )
}

/// `contract.assumed_f` is at most the largest `f` for which the rule is defined with the
/// quorum; a rule defined for no `f` at all names the rule instead.
fn assumed_f_fits_the_rule(c: &Config) -> Result<(), ConfigError> {
    let (rule, quorum, f) = (c.rule(), c.quorum(), c.contract.assumed_f);
    let max_f = (0..=quorum)
        .take_while(|&f| rule.min_quorum(f) <= quorum)
        .last();
    let Some(max_f) = max_f else {
        return out_of_range(
            "contract.rule",
            rule.name().to_string(),
            format!(
                "a rule defined for quorum {quorum} (it needs quorum >= {} even with f = 0); \
                 raise contract.quorum_fraction",
                rule.min_quorum(0)
            ),
        );
    };
    if u64::from(f) <= u64::from(max_f) {
        return Ok(());
    }
    out_of_range(
        "contract.assumed_f",
        f.to_string(),
        format!(
            "an integer in [0, {max_f}] for rule {} with quorum {quorum} (it needs quorum >= {} \
             with f = {f})",
            rule.name(),
            rule.min_quorum(f)
        ),
    )
}

/// `mda` visits `C(q, f)` subsets per round: at most [`super::MDA_MAX_SUBSETS`].
fn mda_search_fits(c: &Config) -> Result<(), ConfigError> {
    let (q, f) = (u64::from(c.quorum()), u64::from(c.contract.assumed_f));
    if c.rule() != Rule::Mda || super::mda_subsets(q, f).is_some() {
        return Ok(());
    }
    out_of_range(
        "contract.assumed_f",
        f.to_string(),
        format!(
            "an f with C(quorum, f) <= {} for rule mda (quorum {q}: it searches every subset \
             of quorum - f models); lower contract.assumed_f or contract.quorum_fraction, or \
             choose another rule",
            super::MDA_MAX_SUBSETS
        ),
    )
}

fn reward_weights_fit_the_quorum(c: &Config) -> Result<(), ConfigError> {
    let k = &c.contract.reward_weights;
    if k.is_empty()
        || (k.len() == c.quorum() as usize
            && k.iter().any(|&w| w > 0)
            && k.iter().all(|w| w.abs() <= 1000))
    {
        return Ok(());
    }
    out_of_range(
        "contract.reward_weights",
        format!("{k:?}"),
        format!(
            "empty (derived from penalised_ranks) or one weight per rank of the quorum ({}), at \
             least one positive, each in -1000..=1000",
            c.quorum()
        ),
    )
}

/// The variant options (and `contract.reward_weights`) set away from swarmfl's defaults, as
/// (key, value) pairs in key order.
fn changed_options(config: &Config) -> Vec<(String, String)> {
    let table = |o: &ContractOptions| toml::Table::try_from(o).expect("options encode as TOML");
    let (mine, default) = (
        table(&config.contract.options()),
        table(&ContractOptions::default()),
    );
    let mut changed: Vec<(String, String)> = mine
        .iter()
        .filter(|&(k, v)| default.get(k) != Some(v))
        .map(|(k, v)| (format!("contract.{k}"), v.to_string()))
        .collect();
    if !config.contract.reward_weights.is_empty() {
        changed.push((
            "contract.reward_weights".to_string(),
            format!("{:?}", config.contract.reward_weights),
        ));
    }
    changed.sort();
    changed
}

/// The variant options describe the paper's contract (`fedavg` and `paper`); the robust rules
/// would ignore them, so a configuration that sets one with a robust rule is refused rather
/// than silently run under other rules than it says.
fn variant_options_fit_the_rule(config: &Config) -> Result<(), ConfigError> {
    let rule = config.rule();
    if matches!(rule, Rule::Fedavg | Rule::Paper) {
        return Ok(());
    }
    match changed_options(config).into_iter().next() {
        None => Ok(()),
        Some((key, value)) => Err(ConfigError::OutOfRange {
            allowed: format!(
                "its default with contract.rule = {} (the authors' variant options apply to \
                 the paper's contract only: rules paper and fedavg); remove `{key}`, or set \
                 contract.rule = paper",
                rule.name()
            ),
            key,
            value,
        }),
    }
}

/// How a plug-in attack is given its robots from Python (quoted by
/// [`count_matches_the_misbehaviour`]; kept on one line, whole, so that its braces are text).
const PLUGIN_COUNT_EXAMPLE: &str =
    "swarmfl.run(..., attack=MyAttack(), set={\"byzantine.count\": 3})";

/// `byzantine.count` is positive exactly when some robot misbehaves (`byzantine.kind` or
/// `byzantine.ledger` set), with a hint for Python's plug-in attacks, which set the kind alone.
fn count_matches_the_misbehaviour(c: &Config) -> Result<(), ConfigError> {
    let b = &c.byzantine;
    let misbehaves = b.kind != ByzantineKind::None || b.ledger != LedgerBehaviour::Honest;
    if misbehaves == (b.count > 0) {
        return Ok(());
    }
    if b.kind == ByzantineKind::Plugin && b.count == 0 {
        // A plug-in attack comes from Python, where the CLI's `--set` hint does not apply.
        return out_of_range(
            "byzantine.count",
            b.count.to_string(),
            format!(
                "at least 1 with byzantine.kind = \"plugin\": the plug-in attack `{}` \
                 (byzantine.plugin) runs on byzantine.count robots and none is given; give the \
                 count with the attack, e.g. {PLUGIN_COUNT_EXAMPLE} in Python",
                b.plugin
            ),
        );
    }
    out_of_range(
        "byzantine.count",
        b.count.to_string(),
        format!(
            "0 when byzantine.kind = \"none\" and byzantine.ledger = \"honest\", at least 1 \
             otherwise (byzantine.kind is \"{}\", byzantine.ledger is \"{}\"); set both, e.g. \
             --set byzantine.kind=faulty --set byzantine.count=3",
            b.kind.name(),
            b.ledger.name()
        ),
    )
}

/// `byzantine.kind = "plugin"` needs the plug-in's name in `byzantine.plugin` (a plain name:
/// it is recorded in the log header and matched against the plug-ins a replay is given), and a
/// name is only read under that kind.
fn plugin_is_named(c: &Config) -> Result<(), ConfigError> {
    let b = &c.byzantine;
    let plain = |n: &str| {
        !n.is_empty()
            && n.len() <= 100
            && n.chars()
                .all(|ch| ch.is_ascii_alphanumeric() || matches!(ch, '_' | '-' | '.'))
    };
    match (b.kind == ByzantineKind::Plugin, b.plugin.is_empty()) {
        (true, _) if !plain(&b.plugin) => out_of_range(
            "byzantine.plugin",
            format!("{:?}", b.plugin),
            "the plug-in attack's name (1 to 100 of A-Z a-z 0-9 _ - .) with byzantine.kind = \
             \"plugin\"; the Python package sets it from the attack's class: \
             swarmfl.run(..., attack=MyAttack())"
                .to_string(),
        ),
        (false, false) => out_of_range(
            "byzantine.plugin",
            format!("{:?}", b.plugin),
            format!(
                "empty unless byzantine.kind = \"plugin\" (byzantine.kind is \"{}\")",
                b.kind.name()
            ),
        ),
        _ => Ok(()),
    }
}

/// `contract.rule = "plugin"` needs the plug-in rule's name in `contract.rule_plugin` (a plain
/// name, like `byzantine.plugin`'s), takes no pre-aggregators (the chain is built for the
/// built-in rules), and a name is only read under that rule.
fn rule_plugin_is_named(c: &Config) -> Result<(), ConfigError> {
    let k = &c.contract;
    let plain = |n: &str| {
        !n.is_empty()
            && n.len() <= 100
            && n.chars()
                .all(|ch| ch.is_ascii_alphanumeric() || matches!(ch, '_' | '-' | '.'))
    };
    let plugin = k.rule == Rule::Plugin;
    if plugin && !plain(&k.rule_plugin) {
        return out_of_range(
            "contract.rule_plugin",
            format!("{:?}", k.rule_plugin),
            "the plug-in rule's name (1 to 100 of A-Z a-z 0-9 _ - .) with contract.rule = \
             \"plugin\"; the Python package sets it from the rule: swarmfl.run(..., \
             rule=my_rule)"
                .to_string(),
        );
    }
    if !plugin && !k.rule_plugin.is_empty() {
        return out_of_range(
            "contract.rule_plugin",
            format!("{:?}", k.rule_plugin),
            format!(
                "empty unless contract.rule = \"plugin\" (contract.rule is \"{}\")",
                k.rule.name()
            ),
        );
    }
    if plugin && c.rule() == Rule::Plugin && !k.preaggregators.is_empty() {
        return out_of_range(
            "contract.preaggregators",
            format!("{:?}", k.preaggregators),
            "[] with contract.rule = \"plugin\" (a plug-in rule does its own filtering)"
                .to_string(),
        );
    }
    Ok(())
}

fn faults_fit_the_run(c: &Config) -> Result<(), ConfigError> {
    c.faults
        .check(c.world.robots, c.run.duration_s)
        .or_else(|(key, value, allowed)| out_of_range(&key, value, allowed))
}

/// Checks that a baseline aggregation can run the configuration. Without a chain there is no
/// contract, no token, no block and no sealer, so what acts only on those is refused, naming
/// the key and the fix, rather than silently ignored:
/// - `contract.rule`: `gossip` and `central` average by FedAvg; `paper` (the default, whose
///   threshold and rewards then do not apply) and `fedavg` are accepted, the robust rules are
///   not (a robust server or merge would be a new baseline);
/// - `contract.engine = "evm"`, `contract.round_timeout_s` (but for 0 and the presets'
///   default) and `contract.max_claimed_samples` (but for 0, derived): contract machinery;
/// - `byzantine.ledger`: misbehaviour on a chain (Byzantine robots' model attacks,
///   `byzantine.kind`, all work: see `AggregationState::attacker_view` in `aggregation`);
/// - `faults.crashes` (a node's restart and resync), `faults.clock_skews` (block timestamps),
///   partitions of kind `sealer` (Clique's in-turn sealer).
///
/// Partitions `split` and `isolate`, loss bursts and delays act on the stigmergy's gossip as on
/// the ledger's. The `central` server is not on the radio, so they leave it untouched (accepted,
/// so that one fault schedule compares the three aggregations).
fn baseline_supports(config: &Config) -> Result<(), ConfigError> {
    let kind = config.learn.aggregation;
    if kind == Aggregation::Chain {
        return Ok(());
    }
    let refuse = |key: &str, value: String, allowed: String| {
        Err(ConfigError::OutOfRange {
            key: key.to_string(),
            value,
            allowed: format!(
                "{allowed} with learn.aggregation = {} (no chain, no contract); set \
                 learn.aggregation = chain to use it",
                kind.name()
            ),
        })
    };
    let rule = config.rule();
    if !matches!(rule, Rule::Paper | Rule::Fedavg) {
        return refuse(
            "contract.rule",
            rule.name().to_string(),
            "paper or fedavg (both mean plain FedAvg here)".to_string(),
        );
    }
    if config.contract.engine == ContractEngine::Evm {
        return refuse("contract.engine", "evm".to_string(), "native".to_string());
    }
    // The presets' deadline and derived claim bound are accepted, as the paper's rule is:
    // they are the contract's defaults, and without a contract they have nothing to act on.
    let timeout = config.contract.round_timeout_s;
    if timeout != 0.0 && timeout != DEFAULT_ROUND_TIMEOUT_S {
        return refuse(
            "contract.round_timeout_s",
            show_f64(timeout),
            format!("0 or the presets' {DEFAULT_ROUND_TIMEOUT_S} (no round deadline applies)"),
        );
    }
    if config.contract.max_claimed_samples != 0 {
        return refuse(
            "contract.max_claimed_samples",
            config.contract.max_claimed_samples.to_string(),
            "0 (derived; no contract refuses claims)".to_string(),
        );
    }
    if config.byzantine.ledger != LedgerBehaviour::Honest {
        return refuse(
            "byzantine.ledger",
            config.byzantine.ledger.name().to_string(),
            "honest (byzantine.kind attacks all apply)".to_string(),
        );
    }
    let f = &config.faults;
    if !f.crashes.is_empty() {
        return refuse(
            "faults.crashes",
            format!("{} crash(es)", f.crashes.len()),
            "none (partitions, loss bursts and delays are supported)".to_string(),
        );
    }
    if !f.clock_skews.is_empty() {
        return refuse(
            "faults.clock_skews",
            format!("{} skew(s)", f.clock_skews.len()),
            "none (clocks matter only to block timestamps)".to_string(),
        );
    }
    if let Some(i) = f
        .partitions
        .iter()
        .position(|p| p.kind == PartitionKind::Sealer)
    {
        return refuse(
            &format!("faults.partitions[{i}].kind"),
            "sealer".to_string(),
            "split or isolate (there is no sealer)".to_string(),
        );
    }
    Ok(())
}

/// `contract.gas_limit = "estimate"` only under `contract.engine = "evm"` (the native engine
/// has no gas).
fn gas_limit_needs_the_evm(config: &Config) -> Result<(), ConfigError> {
    let c = &config.contract;
    if c.gas_limit == GasLimitRule::Estimate && c.engine != ContractEngine::Evm {
        return Err(ConfigError::OutOfRange {
            key: "contract.gas_limit".to_string(),
            value: c.gas_limit.name().to_string(),
            allowed: "block with contract.engine = native, which has no gas; set \
                      contract.engine = evm to give transactions the authors' estimated gas \
                      limit, or contract.gas_limit = block"
                .to_string(),
        });
    }
    Ok(())
}

/// `contract.gas_estimate_state` and `contract.gas_recommit_s` only under
/// `contract.gas_limit = "estimate"` (the recommit only under the pending state): without
/// the option no transaction is estimated.
#[allow(clippy::float_cmp)]
fn gas_estimate_needs_the_option(config: &Config) -> Result<(), ConfigError> {
    let c = &config.contract;
    let estimated = c.gas_limit == GasLimitRule::Estimate;
    if c.gas_estimate_state != GasEstimateState::Pending && !estimated {
        return out_of_range(
            "contract.gas_estimate_state",
            c.gas_estimate_state.name().to_string(),
            "pending (the default) without contract.gas_limit = estimate, which no transaction \
             is estimated under; set contract.gas_limit = estimate (with contract.engine = \
             evm) or leave contract.gas_estimate_state out"
                .to_string(),
        );
    }
    let pending = estimated && c.gas_estimate_state == GasEstimateState::Pending;
    if c.gas_recommit_s != super::tree::GETH_RECOMMIT_S && !pending {
        return out_of_range(
            "contract.gas_recommit_s",
            c.gas_recommit_s.to_string(),
            "3 (the default) unless contract.gas_limit = estimate with \
             contract.gas_estimate_state = pending, the only estimate that reads the pending \
             block; set those or leave contract.gas_recommit_s out"
                .to_string(),
        );
    }
    Ok(())
}

/// `contract.engine = "evm"` only where the build and the Solidity contract support it.
fn engine_supports(config: &Config) -> Result<(), ConfigError> {
    if config.contract.engine == ContractEngine::Evm {
        evm_supports(config)
    } else {
        Ok(())
    }
}

/// Checks that the EVM contract implements the configured rules. `contracts/SwarmFL.sol` is
/// the paper's contract, with security on (`contract.rule = paper`) or off (`fedavg`), every
/// variant option included, with the round deadline and the claim bound. It has no robust
/// aggregation rule, no defence and no ranking order but the median's: such a configuration is refused, naming the key, rather than run on a contract
/// that would not do what it says.
#[cfg(feature = "evm")]
fn evm_supports(config: &Config) -> Result<(), ConfigError> {
    let c = &config.contract;
    let rule = config.rule();
    if !matches!(rule, Rule::Paper | Rule::Fedavg) {
        return Err(ConfigError::OutOfRange {
            key: "contract.rule".to_string(),
            value: rule.name().to_string(),
            allowed: format!(
                "paper (or fedavg, i.e. contract.security = false) with contract.engine = evm: \
                 contracts/SwarmFL.sol implements the paper's rule only; set \
                 contract.engine = native to run {}, or contract.rule = paper",
                rule.name()
            ),
        });
    }
    if !c.rank_order.is_median() {
        return Err(ConfigError::OutOfRange {
            key: "contract.rank_order".to_string(),
            value: c.rank_order.name().to_string(),
            allowed: "median with contract.engine = evm: contracts/SwarmFL.sol ranks around \
                      the median distance only; set contract.engine = native to rank by \
                      another order"
                .to_string(),
        });
    }
    if c.defence != Defence::None {
        return Err(ConfigError::OutOfRange {
            key: "contract.defence".to_string(),
            value: c.defence.name().to_string(),
            allowed: "none with contract.engine = evm: contracts/SwarmFL.sol pays by the \
                      paper's ranking only; set contract.engine = native to run a defence"
                .to_string(),
        });
    }
    Ok(())
}

/// Refuses `contract.engine = "evm"` in a build without the `evm` cargo feature, naming the
/// feature and the command that builds it.
#[cfg(not(feature = "evm"))]
fn evm_supports(_config: &Config) -> Result<(), ConfigError> {
    Err(ConfigError::OutOfRange {
        key: "contract.engine".to_string(),
        value: "evm".to_string(),
        allowed: "native in this build of swarmfl, which was built without the EVM engine \
                  (cargo feature `evm`, off by default); rebuild with \
                  `cargo build --release -p replay-cli --features evm` to run \
                  contracts/SwarmFL.sol, or set contract.engine = native"
            .to_string(),
    })
}

fn switch_token_share_is_a_share(c: &Config) -> Result<(), ConfigError> {
    let share = c.byzantine.switch_token_share;
    if share > 0.0 && share < 1.0 {
        return Ok(());
    }
    out_of_range(
        "byzantine.switch_token_share",
        share.to_string(),
        "a share strictly between 0 and 1 (0.5: more tokens than the honest robots together)"
            .to_string(),
    )
}

fn defences_need_stakes(c: &Config) -> Result<(), ConfigError> {
    if c.contract.defence == Defence::None || c.rule().stakes() {
        return Ok(());
    }
    out_of_range(
        "contract.defence",
        c.contract.defence.name().to_string(),
        "\"none\" with contract.security = false or contract.rule = fedavg (no stakes, no \
         rewards to defend); set contract.security = true and a staking rule, or \
         contract.defence = none"
            .to_string(),
    )
}

/// `learn.withheld` and `byzantine.as_honest` name robots of the swarm, each once.
fn withheld_are_robots(c: &Config) -> Result<(), ConfigError> {
    for (key, list) in [
        ("learn.withheld", &c.learn.withheld),
        ("byzantine.as_honest", &c.byzantine.as_honest),
    ] {
        let robots = c.world.robots;
        if let Some(bad) = list.iter().find(|&&r| r >= robots) {
            return out_of_range(
                key,
                format!("{list:?} (robot {bad})"),
                format!(
                    "a list of robot ids from 0 to {}, each at most once",
                    robots.saturating_sub(1)
                ),
            );
        }
        let mut sorted = list.clone();
        sorted.sort_unstable();
        if sorted.windows(2).any(|w| w[0] == w[1]) {
            return out_of_range(
                key,
                format!("{list:?}"),
                "a list of robot ids, each at most once".to_string(),
            );
        }
    }
    Ok(())
}
