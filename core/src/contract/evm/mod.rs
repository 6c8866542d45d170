//! `contract.engine = "evm"`: every contract call runs the Solidity contract of
//! `contracts/SwarmFL.sol` (its committed bytecode, `contracts/build/SwarmFL.json`) in revm.
//!
//! The EVM's storage is the truth: after each call the [`ContractState`] fields the rest of
//! swarmfl reads (balances, holdings, round, shared weights, the round's submissions) are read
//! back from the contract through its view functions, and the outcome is decoded from the
//! call's return value and events. Only what the contract never stores is taken from the
//! transaction: the submitted weights themselves (the contract keeps their running FedAvg sum,
//! not the models) and the reason texts of malformed calls (the contract returns a code and
//! its numbers; [`malformed`] words them exactly as the native contract does).
//!
//! Each chain's state owns its own EVM database ([`EvmState`], shared copy-on-write between
//! blocks), so forks execute independently, as geth would. revm is deterministic: no clock, no
//! randomness, the block environment fixed; storage lookups only (never iterated into state).
//!
//! Rules changes (forks) are owner calls: `restartRound` when a chain enters a new epoch and
//! `configure` before the first call under different parameters. The owner is the chain itself
//! ([`OWNER`]), as a system call would be on a real chain. So is `enterBlock(timestamp)`, made
//! before every block's transactions: the contract keeps the round deadline's clock itself
//! and closes a round that is `round_timeout_ms` old ([`enter_block`]).

mod abi;
mod gas_limit;
pub mod geth;
#[cfg(test)]
mod tests;

use std::collections::BTreeMap;
use std::sync::{Arc, OnceLock};

use revm::context::result::{ExecutionResult, Output};
use revm::context::{Context, TxEnv};
use revm::database::{CacheDB, EmptyDB};
use revm::handler::MainnetContext;
use revm::primitives::hardfork::SpecId;
use revm::primitives::{Address, Bytes, Log, TxKind, U256};
use revm::{ExecuteCommitEvm, MainBuilder, MainContext};
use serde::{Deserialize, Serialize};

use super::{
    model_digest, Call, ContractParams, ContractState, Outcome, Payout, RoundSummary, Submission,
    Verdict,
};
use crate::config::ContractEngine;
use crate::types::RobotId;
use abi::{Decoder, Encoder};
pub use gas_limit::estimate;

/// The compiled contract: `{compiler, contract, abi, bytecode}` written by `contracts/build.sh`.
pub const ARTEFACT_JSON: &str = include_str!("../../../../contracts/build/SwarmFL.json");

/// The deployer and owner of the contract: the chain itself (rules activation).
pub const OWNER: Address = Address::new([0xc0; 20]);

/// The EVM fork the bytecode is compiled for (`evmVersion: prague` in `contracts/compile.js`).
const SPEC: SpecId = SpecId::PRAGUE;

/// Gas limit of the chain's own calls (deployment, rules changes, state reads): far above any
/// of them, so gas never decides their outcome. A robot's transaction gets the block gas
/// limit instead (`contract.block_gas_limit`).
const GAS_LIMIT: u64 = 1 << 40;

/// The account address of robot `robot`: `0x10` followed by zeros and the id, big endian.
pub fn robot_address(robot: RobotId) -> Address {
    let mut bytes = [0u8; 20];
    bytes[0] = 0x10;
    bytes[16..].copy_from_slice(&robot.to_be_bytes());
    Address::new(bytes)
}

/// Gas of the calls of one kind (one outcome name).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct GasStat {
    /// Number of calls.
    pub calls: u64,
    /// Sum of their gas (as a receipt reports it: intrinsic, calldata and execution, net of
    /// refunds).
    pub total_gas: u64,
    /// The smallest.
    pub min_gas: u64,
    /// The largest.
    pub max_gas: u64,
}

impl GasStat {
    fn add(&mut self, gas: u64) {
        self.min_gas = if self.calls == 0 {
            gas
        } else {
            self.min_gas.min(gas)
        };
        self.max_gas = self.max_gas.max(gas);
        self.calls += 1;
        self.total_gas += gas;
    }

    /// Mean gas per call (0 without calls).
    pub fn mean_gas(&self) -> u64 {
        self.total_gas.checked_div(self.calls).unwrap_or(0)
    }
}

/// The rules the deployed contract currently runs (to know when to call `configure`).
#[derive(Clone, Debug, PartialEq, Eq)]
struct Rules {
    stake_units: u64,
    security: bool,
    quorum: u32,
    max_distance_units: u128,
    reward_weights: Vec<i64>,
    flags: u64,
    max_samples: u64,
    round_timeout_ms: u64,
}

impl Rules {
    fn of(params: &ContractParams) -> Rules {
        assert!(
            params.robust.is_none(),
            "SwarmFL.sol has no robust rule (validation refuses them with evm)"
        );
        Rules {
            stake_units: params.stake_units,
            security: params.security,
            quorum: params.quorum,
            max_distance_units: params.max_distance_units(),
            reward_weights: params.reward_weights.clone(),
            flags: params.options.flags(),
            max_samples: params.claim_bound.max_samples,
            round_timeout_ms: params.round_timeout_ms,
        }
    }
}

/// One chain's EVM: the database holding the deployed contract, and the gas its calls used.
#[derive(Clone, Debug)]
pub struct EvmState {
    db: CacheDB<EmptyDB>,
    contract: Address,
    rules: Rules,
    /// Gas by call kind along this chain: outcome names (`accepted`, `aggregated`, `outlier`,
    /// ...) and `deploy`, `configure`, `restart_round`.
    pub gas: BTreeMap<String, GasStat>,
    /// The robots' calls of the block last entered ([`enter_block`] empties it), in block
    /// order: what their Ethereum receipts hold ([`geth`]). A measurement, like `gas`.
    pub block_calls: Vec<CallTrace>,
}

/// One robot call as an Ethereum receipt records it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CallTrace {
    /// Gas used, as the receipt reports it (0 for a call the EVM never ran).
    pub gas: u64,
    /// Whether a block could hold it: false for a call over the block gas limit (a real
    /// chain's pool refuses it, so no receipt would exist).
    pub included: bool,
    /// Whether it ran to the end: false for a call that ran out of its transaction's gas and
    /// reverted (receipt status 0).
    pub success: bool,
    /// The events it emitted, in order.
    pub logs: Vec<Log>,
}

impl PartialEq for EvmState {
    /// Equal contracts: same address, rules and storage (the gas tally is a measurement).
    fn eq(&self, other: &EvmState) -> bool {
        fn storage(s: &EvmState) -> Option<&revm::primitives::StorageKeyMap<U256>> {
            s.db.cache.accounts.get(&s.contract).map(|a| &a.storage)
        }
        self.contract == other.contract
            && self.rules == other.rules
            && storage(self) == storage(other)
    }
}

impl Eq for EvmState {}

/// What one call returned.
struct CallResult {
    output: Bytes,
    logs: Vec<Log>,
    gas: u64,
}

fn bytecode() -> &'static [u8] {
    static CODE: OnceLock<Vec<u8>> = OnceLock::new();
    CODE.get_or_init(|| {
        let artefact: serde_json::Value =
            serde_json::from_str(ARTEFACT_JSON).expect("contracts/build/SwarmFL.json is JSON");
        let hex = artefact["bytecode"]
            .as_str()
            .and_then(|s| s.strip_prefix("0x"))
            .expect("contracts/build/SwarmFL.json has a 0x bytecode");
        abi::from_hex(hex).expect("the committed bytecode is hex")
    })
}

impl EvmState {
    /// Deploys the contract with `params` (accounts `0..robots`, their initial units, the
    /// genesis model, the rules).
    pub fn deploy(params: &ContractParams) -> EvmState {
        assert_eq!(params.engine, ContractEngine::Evm);
        let accounts: Vec<Address> = (0..params.robots).map(robot_address).collect();
        let mut args = Encoder::default();
        args.address_array(&accounts);
        args.uint(u128::from(params.initial_units));
        args.int_array(&params.genesis_weights);
        push_rules(&mut args, &Rules::of(params));
        let mut data = bytecode().to_vec();
        data.extend_from_slice(&args.finish());
        let mut state = EvmState {
            db: CacheDB::default(),
            contract: Address::ZERO,
            rules: Rules::of(params),
            gas: BTreeMap::new(),
            block_calls: Vec::new(),
        };
        let result = state
            .transact(OWNER, TxKind::Create, data.into(), GAS_LIMIT)
            .expect("deploying runs within its gas limit");
        let (gas, created) = match result {
            ExecutionResult::Success {
                gas,
                output: Output::Create(_, Some(address)),
                ..
            } => (gas.tx_gas_used(), address),
            other => panic!("deploying SwarmFL failed: {other:?}"),
        };
        state.contract = created;
        state.gas.entry("deploy".into()).or_default().add(gas);
        state
    }

    /// Runs one transaction with `gas_limit` gas (also the block's limit) and commits it; an
    /// error when the EVM refuses it before execution (its intrinsic gas, calldata included,
    /// exceeds the limit).
    fn transact(
        &mut self,
        caller: Address,
        kind: TxKind,
        data: Bytes,
        gas_limit: u64,
    ) -> Result<ExecutionResult, String> {
        let db = std::mem::take(&mut self.db);
        let mut evm = context(db, gas_limit).build_mainnet();
        let tx = tx_env(caller, kind, data, gas_limit);
        let result = evm.transact_commit(tx);
        self.db = std::mem::take(&mut evm.ctx.journaled_state.database);
        // The database would keep every log forever; the result carries this call's.
        self.db.cache.logs.clear();
        match result {
            Ok(result) => Ok(result),
            // Only the transaction's own validity can fail on an in-memory database with a
            // zero gas price: its intrinsic gas against the limit.
            Err(revm::context::result::EVMError::Transaction(e)) => Err(e.to_string()),
            Err(e) => panic!("the EVM failed on an in-memory database: {e:?}"),
        }
    }

    /// Calls the contract as the chain (unlimited gas) and requires success (the contract
    /// never reverts on input; a revert is a bug of the contract or of this binding).
    fn call(&mut self, caller: Address, data: Vec<u8>) -> CallResult {
        self.call_within(caller, data, GAS_LIMIT)
            .unwrap_or_else(|| panic!("a call of the chain ran out of {GAS_LIMIT} gas"))
    }

    /// Calls the contract with at most `gas_limit` gas: None when the call needs more (refused
    /// before execution, or out of gas, its changes undone); otherwise as [`EvmState::call`].
    fn call_within(
        &mut self,
        caller: Address,
        data: Vec<u8>,
        gas_limit: u64,
    ) -> Option<CallResult> {
        let kind = TxKind::Call(self.contract);
        match self.transact(caller, kind, data.into(), gas_limit) {
            Ok(ExecutionResult::Success {
                gas, logs, output, ..
            }) => Some(CallResult {
                output: output.into_data(),
                logs,
                gas: gas.tx_gas_used(),
            }),
            Ok(ExecutionResult::Halt {
                reason: revm::context::result::HaltReason::OutOfGas(_),
                ..
            })
            | Err(_) => None,
            Ok(other) => panic!("SwarmFL call reverted: {other:?}"),
        }
    }

    fn configure(&mut self, params: &ContractParams) {
        let rules = Rules::of(params);
        let mut data =
            abi::selector("configure(uint64,bool,uint32,uint256,int64[],uint256,uint64,uint64)");
        let mut args = Encoder::default();
        push_rules(&mut args, &rules);
        data.extend_from_slice(&args.finish());
        let r = self.call(OWNER, data);
        self.gas.entry("configure".into()).or_default().add(r.gas);
        self.rules = rules;
    }

    /// `state()`: every balance, the holdings and the round.
    fn read_state(&mut self) -> (Vec<u64>, u64, u64) {
        let r = self.call(OWNER, abi::selector("state()"));
        let d = Decoder::new(&r.output);
        let balances = d.uint_array(0).into_iter().map(to_u64).collect();
        (balances, to_u64(d.word(1)), to_u64(d.word(2)))
    }

    /// `getModel()`: the shared weights and their version.
    fn read_model(&mut self) -> (Vec<i64>, u64) {
        let r = self.call(OWNER, abi::selector("getModel()"));
        let d = Decoder::new(&r.output);
        let weights = d.uint_array(0).into_iter().map(to_i64).collect();
        (weights, to_u64(d.word(1)))
    }

    /// `deadline()`: block time, round opened, rounds timed out, units they refunded.
    fn read_deadline(&mut self) -> [u64; 4] {
        let r = self.call(OWNER, abi::selector("deadline()"));
        let d = Decoder::new(&r.output);
        [0, 1, 2, 3].map(|i| to_u64(d.word(i)))
    }

    /// `getSubmissions()`: (sender, samples, distance, stake, outlier) of the open round.
    fn read_submissions(&mut self) -> Vec<[u128; 5]> {
        let r = self.call(OWNER, abi::selector("getSubmissions()"));
        let d = Decoder::new(&r.output);
        d.struct_array(0, 5)
            .into_iter()
            .map(|w| {
                let v: Vec<u128> = w.into_iter().map(|x| x.to::<u128>()).collect();
                [v[0], v[1], v[2], v[3], v[4]]
            })
            .collect()
    }
}

impl EvmState {
    /// The contract's address.
    pub fn contract(&self) -> Address {
        self.contract
    }

    /// The contract's non-zero storage slots, by slot (what an Ethereum state trie holds: a
    /// slot written to zero is deleted).
    pub fn storage(&self) -> BTreeMap<U256, U256> {
        self.db
            .cache
            .accounts
            .get(&self.contract)
            .map(|a| {
                a.storage
                    .iter()
                    .filter(|(_, v)| !v.is_zero())
                    .map(|(k, v)| (*k, *v))
                    .collect()
            })
            .unwrap_or_default()
    }

    /// The deployed (runtime) code's length in bytes.
    pub fn code_bytes(&self) -> u64 {
        self.db
            .cache
            .accounts
            .get(&self.contract)
            .and_then(|a| a.info.code.as_ref())
            .map_or(0, |c| c.original_byte_slice().len() as u64)
    }
}

/// The EVM's context over `db`: the fork, no nonce check, no initcode size limit, a block
/// whose gas limit is `gas_limit` and whose base fee is 0 (calls cost the callers nothing,
/// the gas is measured).
fn context(db: CacheDB<EmptyDB>, gas_limit: u64) -> MainnetContext<CacheDB<EmptyDB>> {
    Context::mainnet()
        .modify_cfg_chained(|cfg| {
            cfg.set_spec_and_mainnet_gas_params(SPEC);
            cfg.disable_nonce_check = true;
            cfg.limit_contract_initcode_size = Some(usize::MAX);
        })
        .modify_block_chained(|block| {
            block.basefee = 0;
            block.gas_limit = gas_limit;
        })
        .with_db(db)
}

/// A transaction from `caller` with `gas_limit` gas at gas price 0.
fn tx_env(caller: Address, kind: TxKind, data: Bytes, gas_limit: u64) -> TxEnv {
    TxEnv::builder()
        .caller(caller)
        .kind(kind)
        .data(data)
        .gas_limit(gas_limit)
        .gas_price(0)
        .build()
        .expect("a complete transaction")
}

fn push_rules(args: &mut Encoder, rules: &Rules) {
    args.uint(u128::from(rules.stake_units));
    args.uint(u128::from(rules.security));
    args.uint(u128::from(rules.quorum));
    args.uint(rules.max_distance_units);
    args.int_array(&rules.reward_weights);
    args.uint(u128::from(rules.flags));
    args.uint(u128::from(rules.max_samples));
    args.uint(u128::from(rules.round_timeout_ms));
}

fn to_u64(word: U256) -> u64 {
    u64::try_from(word).expect("a uint64 the contract returned")
}

/// The low 64 bits of a sign-extended ABI word, as the int64 the contract returned.
fn to_i64(word: U256) -> i64 {
    word.as_limbs()[0] as i64
}

/// Executes `call` on the EVM of `state` (the dispatch of [`ContractState::execute`] for the
/// evm engine) and reads the state back. `tx_gas` is the transaction's own gas limit
/// (`contract.gas_limit = "estimate"`); without one the call may use the block's.
pub fn execute(
    state: &mut ContractState,
    params: &ContractParams,
    sender: RobotId,
    value_units: u64,
    call: &Call,
    tx_gas: Option<u64>,
) -> Outcome {
    let evm = Arc::make_mut(
        state
            .evm
            .as_mut()
            .expect("a state made under contract.engine = evm holds its EVM"),
    );
    let Some(data) = calldata(call, value_units) else {
        // Validation refuses the buffered protocol with this engine; a foreign transaction
        // can still carry the call. It never reaches the EVM (on a chain it would revert: no
        // such function), so its receipt has no gas and no events.
        evm.block_calls.push(CallTrace {
            gas: 0,
            included: true,
            success: true,
            logs: Vec::new(),
        });
        return Outcome::Malformed(
            "submitUpdate is the buffered protocol's; contracts/SwarmFL.sol implements the \
             paper's rounds only"
                .to_string(),
        );
    };
    if evm.rules != Rules::of(params) {
        evm.configure(params);
    }
    let (weights, samples) = match call {
        Call::SubmitModel { weights, samples } => (Some(weights), *samples),
        _ => (None, 0),
    };
    let result = match gas_limit::run(evm, sender, data, params.block_gas_limit, tx_gas) {
        Ok(result) => result,
        Err(refused) => return refused,
    };
    let d = Decoder::new(&result.output);
    let code = to_u64(d.word(0));
    let round = to_u64(d.word(1));
    let distance_units = to_u64(d.word(2));
    let (a, b) = (d.word(3), d.word(4));
    let outcome = match code {
        0 => Outcome::Accepted {
            round,
            distance_units,
        },
        1 => Outcome::Aggregated {
            round,
            distance_units,
            payouts: decode_payouts(&result.logs),
        },
        2 => Outcome::Outlier {
            round,
            distance_units,
        },
        3 => Outcome::Duplicate,
        4 => Outcome::InsufficientStake,
        5 => Outcome::Transferred,
        6 => Outcome::InsufficientFunds,
        code => Outcome::Malformed(malformed(
            code,
            a,
            b,
            sender,
            value_units,
            call,
            params,
            state.balances.len(),
        )),
    };
    let evm = Arc::make_mut(state.evm.as_mut().expect("checked above"));
    evm.gas
        .entry(outcome.name().to_string())
        .or_default()
        .add(result.gas);
    evm.block_calls.push(CallTrace {
        gas: result.gas,
        included: true,
        success: true,
        logs: result.logs.clone(),
    });

    // Read the state back from the contract's storage.
    let (balances, holdings, new_round) = evm.read_state();
    state.balances = balances;
    state.holdings_units = holdings;
    match &outcome {
        Outcome::Accepted { .. } | Outcome::Outlier { .. } => {
            let weights = weights.expect("only submissions are counted");
            let stored = evm.read_submissions();
            assert_eq!(
                stored.len(),
                state.submissions.len() + 1,
                "one more counted submission"
            );
            let previous = std::mem::take(&mut state.submissions);
            state.submissions = stored
                .iter()
                .enumerate()
                .map(|(i, s)| {
                    let w = previous.get(i).map_or(weights, |p| &p.weights);
                    submission_from_storage(s, w)
                })
                .collect();
        }
        Outcome::Aggregated {
            payouts,
            round: closed,
            ..
        } => {
            let weights = weights.expect("only submissions aggregate");
            let mut submissions = std::mem::take(&mut state.submissions);
            submissions.push(Submission {
                sender,
                samples,
                distance_units,
                stake_units: if params.security {
                    params.stake_units
                } else {
                    0
                },
                verdict: Verdict::Accepted,
                weights: weights.clone(),
                weights_digest: model_digest(weights),
            });
            let (pool_units, carried_units) = decode_aggregated(&result.logs);
            assert_eq!(carried_units, holdings, "the event and the storage agree");
            let (model, version) = evm.read_model();
            assert_eq!(version, new_round);
            let model: Arc<[i64]> = model.into();
            state.previous_weights = Some(std::mem::replace(&mut state.weights, model));
            state.previous_digest = state.weights_digest;
            state.weights_digest = model_digest(&state.weights);
            // The round opened by this aggregation counts from this block, as the contract's
            // `_aggregate` records for its deadline.
            state.round_opened_ms = state.block_time_ms;
            state.last_round = Some(Arc::new(RoundSummary {
                round: *closed,
                submissions,
                payouts: payouts.clone(),
                pool_units,
                carried_units,
            }));
        }
        _ => {}
    }
    state.round = new_round;
    outcome
}

/// The calldata of a robot's `call` with `value_units` attached; None for `submitUpdate`,
/// which `contracts/SwarmFL.sol` does not have.
fn calldata(call: &Call, value_units: u64) -> Option<Vec<u8>> {
    let (signature, args) = match call {
        Call::SubmitModel { weights, samples } => {
            let mut args = Encoder::default();
            args.int_array(weights);
            args.uint(u128::from(*samples));
            args.uint(u128::from(value_units));
            ("submitModel(int64[],uint64,uint64)", args)
        }
        Call::SubmitUpdate { .. } => return None,
        Call::Transfer { to, amount_units } => {
            let mut args = Encoder::default();
            args.address(robot_address(*to));
            args.uint(u128::from(*amount_units));
            args.uint(u128::from(value_units));
            ("transfer(address,uint64,uint64)", args)
        }
    };
    let mut data = abi::selector(signature);
    data.extend_from_slice(&args.finish());
    Some(data)
}

fn submission_from_storage(s: &[u128; 5], weights: &Arc<[i64]>) -> Submission {
    let narrow = |x: u128| u64::try_from(x).expect("uint64 fields");
    Submission {
        sender: u32::try_from(s[0]).expect("uint32 sender"),
        samples: narrow(s[1]),
        distance_units: narrow(s[2]),
        stake_units: narrow(s[3]),
        verdict: if s[4] == 0 {
            Verdict::Accepted
        } else {
            Verdict::Outlier
        },
        weights: weights.clone(),
        weights_digest: model_digest(weights),
    }
}

/// `enterBlock(timestamp_ms)` on the EVM of `state` (before a block's transactions, under the
/// block's `params`), then the deadline's clock read back, and, when the deadline closed the
/// round, the balances too (the dispatch of [`ContractState::enter_block`] for the evm
/// engine).
pub fn enter_block(state: &mut ContractState, params: &ContractParams, timestamp_ms: u64) {
    let evm = Arc::make_mut(state.evm.as_mut().expect("an evm state"));
    if evm.rules != Rules::of(params) {
        evm.configure(params);
    }
    let mut data = abi::selector("enterBlock(uint64)");
    let mut args = Encoder::default();
    args.uint(u128::from(timestamp_ms));
    data.extend_from_slice(&args.finish());
    let r = evm.call(OWNER, data);
    evm.gas.entry("enter_block".into()).or_default().add(r.gas);
    evm.block_calls.clear();
    let [block_time, opened, timed_out, refunded] = evm.read_deadline();
    state.block_time_ms = block_time;
    state.round_opened_ms = opened;
    if timed_out != state.rounds_timed_out {
        let (balances, holdings, round) = evm.read_state();
        assert!(
            evm.read_submissions().is_empty(),
            "a deadline empties the round"
        );
        state.balances = balances;
        state.holdings_units = holdings;
        state.round = round;
        state.submissions.clear();
        state.rounds_timed_out = timed_out;
        state.timeout_refunded_units = refunded;
    }
}

/// `restartRound()` on the EVM of `state` (rules activation), then the state read back.
pub fn restart_round(state: &mut ContractState) {
    let evm = Arc::make_mut(state.evm.as_mut().expect("an evm state"));
    let r = evm.call(OWNER, abi::selector("restartRound()"));
    evm.gas
        .entry("restart_round".into())
        .or_default()
        .add(r.gas);
    let (balances, holdings, round) = evm.read_state();
    assert!(evm.read_submissions().is_empty());
    state.balances = balances;
    state.holdings_units = holdings;
    state.round = round;
    state.submissions.clear();
}

fn decode_payouts(logs: &[Log]) -> Vec<Payout> {
    let topic = abi::event_topic("Paid(uint32,uint32,int64,uint64)");
    logs.iter()
        .filter(|l| l.topics().first() == Some(&topic))
        .map(|l| {
            let d = Decoder::new(&l.data.data);
            Payout {
                robot: u32::try_from(d.word(0)).expect("uint32"),
                rank: u32::try_from(d.word(1)).expect("uint32"),
                reward_weight: to_i64(d.word(2)),
                units: to_u64(d.word(3)),
            }
        })
        .collect()
}

/// (pool, carried) of the `Aggregated` event.
fn decode_aggregated(logs: &[Log]) -> (u64, u64) {
    let topic = abi::event_topic("Aggregated(uint64,uint64,uint64)");
    let log = logs
        .iter()
        .find(|l| l.topics().first() == Some(&topic))
        .expect("an aggregation emits Aggregated");
    let d = Decoder::new(&log.data.data);
    (to_u64(d.word(1)), to_u64(d.word(2)))
}

/// The reason text of a malformed call from the contract's code and numbers, worded exactly as
/// the native contract words it (the differential tests compare them).
#[allow(clippy::too_many_arguments)]
fn malformed(
    code: u64,
    a: U256,
    b: U256,
    sender: RobotId,
    value_units: u64,
    call: &Call,
    params: &ContractParams,
    accounts: usize,
) -> String {
    match (code, call) {
        (10, _) => format!("submission from {sender}: accounts are 0..{accounts}"),
        (11, _) => "samples must be at least 1, got 0".to_string(),
        (12, _) => super::over_claim(to_u64(a), to_u64(b)),
        (13, _) => format!(
            "model has {} weights, the shared model has {}",
            a,
            params.model_len()
        ),
        (14, _) => format!("weight {} = {} is outside int48 (|w| < 2^47)", a, to_i64(b)),
        (15, _) => format!(
            "value {value_units} exceeds the stake of {} units; send exactly the stake",
            params.stake_units
        ),
        (16, Call::Transfer { to, .. }) => {
            format!("transfer from {sender} to {to}: accounts are 0..{accounts}")
        }
        (17, _) => {
            format!("transfer carries value {value_units}; send the amount in the call, value 0")
        }
        (18, Call::SubmitModel { weights, samples }) => {
            let i = usize::try_from(a).expect("an index");
            format!(
                "weight {i} = {} times {samples} samples leaves int48 (contract.int48_products)",
                weights[i]
            )
        }
        (code, _) => panic!("SwarmFL returned unknown outcome code {code}"),
    }
}
