//! The checks of `contract.protocol = "buffered"` and its keys (issue 32): the buffer size
//! against the swarm, the staleness bound, the exponent and the server step, the relative
//! outlier rule's keys, and what the buffered protocol cannot run with. They read several
//! keys, so they sit apart from the single-key rows of `validate.rs`; every error names the
//! key, the value and the fix.

use super::contract::{ContractEngine, OutlierRule, RoundProtocol, Rule};
use super::error::ConfigError;
use super::ranges::out_of_range as refuse;
use super::tree::{Aggregation, Config};

/// The largest `contract.max_staleness`: every node keeps that many past versions of the
/// model to judge submissions against their base, so the bound caps what a node stores.
pub const MAX_STALENESS_LIMIT: u32 = 1000;

/// The largest `contract.server_step`: beyond 10 times the mean update the model
/// extrapolates far outside what any robot submitted.
pub const MAX_SERVER_STEP: f64 = 10.0;

/// The largest `contract.staleness_exponent`: `(1 + 1)^-10` already weighs an update one
/// version old at 1/1024.
pub const MAX_STALENESS_EXPONENT: f64 = 10.0;

/// The largest `contract.outlier_factor`: beyond 1000 times the median honest distance the
/// bound is the cap whatever the swarm does.
pub const MAX_OUTLIER_FACTOR: f64 = 1000.0;

/// The largest `contract.outlier_window`, in closed buffers: every node keeps `window x K`
/// distances and sorts a copy for every submission it judges.
pub const MAX_OUTLIER_WINDOW: u32 = 1024;

/// The largest `contract.outlier_cap`, as `contract.outlier_threshold`'s range.
pub const MAX_OUTLIER_CAP: f64 = 1.0e6;

/// The buffered protocol's keys are in range (checked whatever the protocol, so that a
/// typo is caught before it is switched on), and the buffered protocol runs only where a
/// contract implements it.
///
/// K above the swarm's size is refused under the buffered protocol: a robot counts at most
/// once per base version and the version does not move while the buffer fills, so a buffer
/// of more than `world.robots` updates could only fill from robots' stale second
/// submissions, and may never fill. Under the paper's rounds the buffer is unused, so a
/// small swarm keeps the default K.
pub(super) fn buffered_fits(config: &Config) -> Result<(), ConfigError> {
    let k = &config.contract;
    let robots = config.world.robots;
    let buffered = k.protocol == RoundProtocol::Buffered;
    let matched = config.learn.aggregation == Aggregation::Matched;
    if matched && k.buffer_size > robots {
        return refuse(
            "contract.buffer_size",
            k.buffer_size.to_string(),
            format!(
                "an integer in [1, world.robots = {robots}] with learn.aggregation = matched: \
                 the matched ideal aggregates every K updates of the swarm's trainings, as the \
                 buffered contract does; set contract.buffer_size to at most {robots}"
            ),
        );
    }
    if k.buffer_size == 0 || (buffered && k.buffer_size > robots) {
        return refuse(
            "contract.buffer_size",
            k.buffer_size.to_string(),
            format!(
                "an integer in [1, world.robots = {robots}]: K updates move the model, and a \
                 robot counts once per base version; set contract.buffer_size to at most \
                 {robots} (7 by default)"
            ),
        );
    }
    if k.max_staleness > MAX_STALENESS_LIMIT {
        return refuse(
            "contract.max_staleness",
            k.max_staleness.to_string(),
            format!(
                "an integer in [0, {MAX_STALENESS_LIMIT}] (versions behind the newest; every \
                 node keeps that many past models); set contract.max_staleness to at most \
                 {MAX_STALENESS_LIMIT} (64 by default)"
            ),
        );
    }
    let a = k.staleness_exponent;
    if !(a.is_finite() && (0.0..=MAX_STALENESS_EXPONENT).contains(&a)) {
        return refuse(
            "contract.staleness_exponent",
            a.to_string(),
            format!(
                "a number in [0, {MAX_STALENESS_EXPONENT}] (FedAsync's a in (1 + tau)^-a; 0.5 \
                 by default)"
            ),
        );
    }
    let eta = k.server_step;
    if !(eta.is_finite() && eta > 0.0 && eta <= MAX_SERVER_STEP) {
        return refuse(
            "contract.server_step",
            eta.to_string(),
            format!("a number in (0, {MAX_SERVER_STEP}] (1 by default: the plain mean update)"),
        );
    }
    let matched = config.learn.aggregation == Aggregation::Matched;
    if matched && k.protocol != RoundProtocol::Buffered {
        return refuse(
            "learn.aggregation",
            "matched".to_string(),
            format!(
                "chain, gossip or central with contract.protocol = {}: the matched ideal \
                 applies the buffered protocol's rule (every contract.buffer_size accepted \
                 updates); set contract.protocol = buffered, or learn.aggregation = central \
                 (the ideal of the paper's rounds)",
                k.protocol.name()
            ),
        );
    }
    if k.protocol != RoundProtocol::Buffered || matched {
        return Ok(());
    }
    if config.learn.aggregation != Aggregation::Chain {
        return refuse(
            "contract.protocol",
            "buffered".to_string(),
            format!(
                "rounds with learn.aggregation = {} (the buffered protocol is the contract's); \
                 set learn.aggregation = chain, or contract.protocol = rounds",
                config.learn.aggregation.name()
            ),
        );
    }
    if k.engine == ContractEngine::Evm {
        return refuse(
            "contract.protocol",
            "buffered".to_string(),
            "rounds with contract.engine = evm: contracts/SwarmFL.sol implements the paper's \
             rounds only; set contract.engine = native to run the buffered protocol"
                .to_string(),
        );
    }
    if k.int48_products {
        return refuse(
            "contract.int48_products",
            "true".to_string(),
            "false with contract.protocol = buffered: the authors' int48 accumulator sums \
             models, the buffered contract sums updates; set contract.int48_products = false"
                .to_string(),
        );
    }
    Ok(())
}

/// The relative outlier rule's keys are in range (checked whatever the rule, so that a typo is
/// caught before it is switched on), and the rule runs only where it means something: the
/// buffered protocol (the rounds judge against the newest model, and no window of closed
/// buffers exists there), the paper's rule (the only one that checks the bound on arrival),
/// the native engine (`contracts/SwarmFL.sol` has a fixed threshold only). Runs before
/// [`buffered_fits`], so that the engine's refusal names `contract.outlier_rule`.
pub(super) fn outlier_rule_fits(config: &Config) -> Result<(), ConfigError> {
    let k = &config.contract;
    let factor = k.outlier_factor;
    if !(factor.is_finite() && factor > 0.0 && factor <= MAX_OUTLIER_FACTOR) {
        return refuse(
            "contract.outlier_factor",
            factor.to_string(),
            format!(
                "a number in (0, {MAX_OUTLIER_FACTOR}] (k: the bound is k times the median \
                 accepted distance; 5 by default)"
            ),
        );
    }
    if !(1..=MAX_OUTLIER_WINDOW).contains(&k.outlier_window) {
        return refuse(
            "contract.outlier_window",
            k.outlier_window.to_string(),
            format!(
                "an integer in [1, {MAX_OUTLIER_WINDOW}] (closed buffers whose accepted \
                 distances the median is taken over; 8 by default)"
            ),
        );
    }
    let cap = k.outlier_cap;
    if !(cap.is_finite() && cap > 0.0 && cap <= MAX_OUTLIER_CAP) {
        return refuse(
            "contract.outlier_cap",
            cap.to_string(),
            format!(
                "a number in (0, {MAX_OUTLIER_CAP}] (the largest bound, a mean absolute \
                 distance; 0.2 by default)"
            ),
        );
    }
    if k.outlier_rule != OutlierRule::Relative {
        return Ok(());
    }
    if cap < k.outlier_threshold {
        return refuse(
            "contract.outlier_cap",
            cap.to_string(),
            format!(
                "at least contract.outlier_threshold = {} with contract.outlier_rule = \
                 relative (the bound lies between the two); raise contract.outlier_cap or \
                 lower contract.outlier_threshold",
                k.outlier_threshold
            ),
        );
    }
    let relative = || "relative".to_string();
    if k.engine == ContractEngine::Evm {
        return refuse(
            "contract.outlier_rule",
            relative(),
            "absolute with contract.engine = evm: contracts/SwarmFL.sol checks a fixed \
             threshold only; set contract.engine = native to run the relative rule"
                .to_string(),
        );
    }
    if k.protocol != RoundProtocol::Buffered {
        return refuse(
            "contract.outlier_rule",
            relative(),
            "absolute with contract.protocol = rounds: the relative bound is taken over the \
             closed buffers of the buffered protocol; set contract.protocol = buffered"
                .to_string(),
        );
    }
    if config.rule() != Rule::Paper {
        return refuse(
            "contract.outlier_rule",
            relative(),
            format!(
                "absolute with contract.rule = {} (security {}): only the paper's rule checks \
                 the outlier bound on arrival; set contract.rule = paper and \
                 contract.security = true",
                config.rule().name(),
                if k.security { "on" } else { "off" }
            ),
        );
    }
    Ok(())
}
