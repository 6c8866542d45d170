//! Runs the same random rounds through the authors' contract (geth-argos,
//! `TrajectoryPrediction/scs/federatedsc3V2.sol`, compiled by the caller: it is not part of
//! this repository) and through swarmfl's contract, with swarmfl's rules and with every
//! authors' option on, and counts where they differ (docs/CONTRACT.md has the table).
//!
//! ```text
//! cargo run --release -p swarmfl-core --features evm --example compare_authors -- AUTHORS.json [ROUNDS]
//! ```
//!
//! `AUTHORS.json` holds `{"bytecode": "<hex>"}` (solc's `evm.bytecode.object`, with or without
//! `0x`; `contracts/compile.js` on the authors' source writes it, docs/CONTRACT.md says how).
//! The authors' contract fixes 15 robots, a quorum of 7 and 2848 weights; their robots send 5
//! ether (1 ether = 10^18 wei) where swarmfl stakes 5 tokens (10^9 units each), so a payout
//! compares as `floor(wei / 10^9)` units, exactly (their base share is the only amount that is
//! not a multiple of 10^9 wei).

use std::collections::BTreeMap;
use std::sync::Arc;

use rand_core::{RngCore, SeedableRng};
use rand_pcg::Pcg64;
use revm::context::result::{ExecutionResult, Output};
use revm::context::{Context, TxEnv};
use revm::database::{CacheDB, EmptyDB};
use revm::primitives::hardfork::SpecId;
use revm::primitives::{keccak256, Address, TxKind, U256};
use revm::state::AccountInfo;
use revm::{ExecuteCommitEvm, MainBuilder, MainContext};
use swarmfl_core::config::{ContractEngine, ContractOptions};
use swarmfl_core::contract::evm::robot_address;
use swarmfl_core::contract::{Call, ContractParams, ContractState, Outcome};

const ROBOTS: u32 = 15;
const QUORUM: usize = 7;
const N: usize = 2848;
const TOKEN_UNITS: u64 = 1_000_000_000;
const WEI_PER_UNIT: u128 = 1_000_000_000;
const STAKE_WEI: u128 = 5_000_000_000_000_000_000;

struct Authors {
    db: CacheDB<EmptyDB>,
    contract: Address,
    owner: Address,
}

fn word_i(x: i128) -> [u8; 32] {
    let mut w = if x < 0 { [0xff; 32] } else { [0u8; 32] };
    w[16..].copy_from_slice(&x.to_be_bytes());
    w
}

fn selector(sig: &str) -> Vec<u8> {
    keccak256(sig.as_bytes())[..4].to_vec()
}

impl Authors {
    fn transact(
        &mut self,
        caller: Address,
        kind: TxKind,
        data: Vec<u8>,
        value: u128,
    ) -> ExecutionResult {
        let db = std::mem::take(&mut self.db);
        let mut evm = Context::mainnet()
            .modify_cfg_chained(|cfg| {
                cfg.set_spec_and_mainnet_gas_params(SpecId::PRAGUE);
                cfg.disable_nonce_check = true;
                cfg.limit_contract_initcode_size = Some(usize::MAX);
            })
            .modify_block_chained(|b| {
                b.basefee = 0;
                b.gas_limit = u64::MAX;
            })
            .with_db(db)
            .build_mainnet();
        let tx = TxEnv::builder()
            .caller(caller)
            .kind(kind)
            .data(data.into())
            .value(U256::from(value))
            .gas_limit(1 << 40)
            .gas_price(0)
            .build()
            .expect("a transaction");
        let r = evm.transact_commit(tx).expect("in-memory EVM");
        self.db = std::mem::take(&mut evm.ctx.journaled_state.database);
        self.db.cache.logs.clear();
        r
    }

    fn deploy(bytecode: Vec<u8>, genesis: &[i64], rank_weights: &[i64]) -> Authors {
        let mut a = Authors {
            db: CacheDB::default(),
            contract: Address::ZERO,
            owner: Address::new([0xc0; 20]),
        };
        for r in 0..ROBOTS {
            let info = AccountInfo {
                balance: U256::from(21 * 1_000_000_000_000_000_000u128),
                ..AccountInfo::default()
            };
            a.db.insert_account_info(robot_address(r), info);
        }
        let owner = a.owner;
        match a.transact(owner, TxKind::Create, bytecode, 0) {
            ExecutionResult::Success {
                output: Output::Create(_, Some(addr)),
                ..
            } => a.contract = addr,
            other => panic!("deploy failed: {other:?}"),
        }
        let mut data = selector("setInitWeights(int48[2848],int256[7])");
        for &w in genesis {
            data.extend_from_slice(&word_i(i128::from(w)));
        }
        for &k in rank_weights {
            data.extend_from_slice(&word_i(i128::from(k)));
        }
        let to = TxKind::Call(a.contract);
        assert!(a.transact(owner, to, data, 0).is_success());
        a
    }

    fn balance(&self, robot: u32) -> u128 {
        self.db
            .cache
            .accounts
            .get(&robot_address(robot))
            .map_or(0, |acc| acc.info.balance.to::<u128>())
    }

    fn view(&mut self, sig: &str) -> Vec<u8> {
        let (owner, to) = (self.owner, TxKind::Call(self.contract));
        match self.transact(owner, to, selector(sig), 0) {
            ExecutionResult::Success { output, .. } => output.into_data().to_vec(),
            other => panic!("{sig} failed: {other:?}"),
        }
    }

    fn version(&mut self) -> u64 {
        let out = self.view("version()");
        u64::from(out[31])
    }

    fn weights(&mut self) -> Vec<i64> {
        let out = self.view("getWeights()");
        out.chunks(32)
            .map(|w| i64::from_be_bytes(w[24..32].try_into().expect("8 bytes")))
            .collect()
    }

    fn accepted(&mut self) -> usize {
        let out = self.view("getAcceptedList()");
        U256::from_be_slice(&out[32..64]).to::<usize>()
    }

    /// Submits; returns (outcome name, gas).
    fn submit(&mut self, robot: u32, weights: &[i64], samples: u64) -> (&'static str, u64) {
        let (version, accepted) = (self.version(), self.accepted());
        let mut data = selector("submitWeights(int256,int48[2848])");
        data.extend_from_slice(&word_i(i128::from(samples)));
        for &w in weights {
            data.extend_from_slice(&word_i(i128::from(w)));
        }
        let to = TxKind::Call(self.contract);
        match self.transact(robot_address(robot), to, data, STAKE_WEI) {
            ExecutionResult::Success { gas, .. } => {
                let kind = if self.version() != version {
                    "aggregated"
                } else if self.accepted() > accepted {
                    "accepted"
                } else {
                    "outlier"
                };
                (kind, gas.tx_gas_used())
            }
            ExecutionResult::Revert { gas, .. } | ExecutionResult::Halt { gas, .. } => {
                ("reverted", gas.tx_gas_used())
            }
        }
    }
}

fn params(
    genesis: &Arc<[i64]>,
    options: ContractOptions,
    k: &[i64],
    engine: ContractEngine,
) -> ContractParams {
    ContractParams {
        robots: ROBOTS,
        initial_units: 21 * TOKEN_UNITS,
        stake_units: 5 * TOKEN_UNITS,
        security: true,
        quorum: QUORUM as u32,
        outlier_threshold_units: 50_000_000,
        reward_weights: k.to_vec(),
        genesis_weights: genesis.clone(),
        round_timeout_ms: 0,
        claim_bound: Default::default(),
        robust: None,
        options,
        engine,
        defence: None,
        block_gas_limit: swarmfl_core::config::AUTHORS_BLOCK_GAS_LIMIT,
        preagg: None,
        buffered: None,
        rule_plugin: None,
        outlier: None,
    }
}

fn kind(outcome: &Outcome) -> &'static str {
    match outcome {
        // The authors' contract reverts every refusal (duplicate, stake, malformed).
        Outcome::Malformed(_) | Outcome::Duplicate | Outcome::InsufficientStake => "reverted",
        o => o.name(),
    }
}

/// Prints `message` and exits with status 2 (bad arguments or input).
fn fail(message: String) -> ! {
    eprintln!("compare_authors: {message}");
    std::process::exit(2)
}

fn main() {
    let mut args = std::env::args().skip(1);
    let Some(path) = args.next() else {
        fail("usage: compare_authors AUTHORS.json [ROUNDS]".into())
    };
    let rounds: u64 = match args.next() {
        None => 200,
        Some(r) => r
            .parse()
            .unwrap_or_else(|_| fail(format!("ROUNDS {r:?} is not a whole number"))),
    };
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| fail(format!("{path}: cannot read it ({e})")));
    let json: serde_json::Value =
        serde_json::from_str(&text).unwrap_or_else(|e| fail(format!("{path}: not JSON ({e})")));
    let Some(hex) = json["bytecode"].as_str() else {
        fail(format!(
            "{path}: no string field `bytecode`: write solc's evm.bytecode.object there"
        ))
    };
    // solc's standard JSON gives the bytecode bare, contracts/compile.js with a 0x prefix.
    let bytecode: Vec<u8> = revm::primitives::hex::decode(hex).unwrap_or_else(|e| {
        fail(format!(
            "{path}: `bytecode` is not hex ({e}): write solc's evm.bytecode.object, with or \
             without 0x"
        ))
    });

    for k in [vec![1, 1, 1, 1, 1, -1, -1], vec![5, 4, 3, 2, 1, -1, -2]] {
        let mut rng = Pcg64::seed_from_u64(2025);
        let genesis: Arc<[i64]> = (0..N)
            .map(|_| (rng.next_u64() % 400_000_001) as i64 - 200_000_000)
            .collect::<Vec<_>>()
            .into();
        let mut theirs = Authors::deploy(bytecode.clone(), &genesis, &k);
        let ours_p = params(
            &genesis,
            ContractOptions::default(),
            &k,
            ContractEngine::Native,
        );
        let auth_p = params(
            &genesis,
            ContractOptions::authors(),
            &k,
            ContractEngine::Evm,
        );
        let mut auth = ContractState::genesis(&auth_p);
        let mut diff: BTreeMap<&str, u64> = BTreeMap::new();
        let mut gas: BTreeMap<&str, (u64, u64)> = BTreeMap::new();
        let mut calls = 0u64;
        let mut closed = 0u64;
        let mut idle_passes = 0;
        // Drained robots (below the stake) stop submitting; stop when no round closes any more.
        while closed < rounds && idle_passes < 3 {
            idle_passes += 1;
            // One round's worth of submissions from robots in a random order.
            let mut order: Vec<u32> = (0..ROBOTS).collect();
            for i in (1..order.len()).rev() {
                order.swap(i, (rng.next_u64() % (i as u64 + 1)) as usize);
            }
            for robot in order {
                if theirs.balance(robot) < STAKE_WEI
                    || auth.balances[robot as usize] < 5 * TOKEN_UNITS
                {
                    continue;
                }
                let shared = auth.weights.clone();
                let spread = [
                    20_000_000u64,
                    49_000_000,
                    50_000_000,
                    51_000_000,
                    200_000_000,
                ][(rng.next_u64() % 5) as usize];
                let w: Vec<i64> = if rng.next_u64() % 10 == 0 {
                    shared.to_vec()
                } else {
                    shared
                        .iter()
                        .map(|&x| x + ((rng.next_u64() % (2 * spread + 1)) as i64 - spread as i64))
                        .collect()
                };
                let samples = if rng.next_u64() % 20 == 0 {
                    100_000 + rng.next_u64() % 200_000
                } else {
                    1 + rng.next_u64() % 400
                };
                let before: Vec<u128> = (0..ROBOTS).map(|r| theirs.balance(r)).collect();
                let (t_kind, t_gas) = theirs.submit(robot, &w, samples);
                let call = Call::SubmitModel {
                    weights: w.into(),
                    samples,
                };
                // swarmfl's rules start every call from the same state as the others, so each
                // call measures one decision, not the drift of earlier ones.
                let mut ours = auth.clone();
                ours.evm = None;
                let a = auth.execute(&auth_p, robot, 5 * TOKEN_UNITS, &call);
                let o = ours.execute(&ours_p, robot, 5 * TOKEN_UNITS, &call);
                calls += 1;
                let e = gas.entry(t_kind).or_default();
                e.0 += 1;
                e.1 += t_gas;
                if kind(&a) != t_kind {
                    *diff.entry("authors options: outcome").or_default() += 1;
                }
                if kind(&o) != t_kind {
                    *diff.entry("swarmfl rules: outcome").or_default() += 1;
                }
                if let Outcome::Aggregated { payouts, .. } = &a {
                    closed += 1;
                    idle_passes = 0;
                    if theirs.weights()[..] != auth.weights[..] {
                        *diff.entry("authors options: weights").or_default() += 1;
                    }
                    for p in payouts {
                        let mut delta =
                            theirs.balance(p.robot) as i128 - before[p.robot as usize] as i128;
                        if p.robot == robot {
                            delta += STAKE_WEI as i128;
                        }
                        if (delta / WEI_PER_UNIT as i128) as u64 != p.units {
                            *diff.entry("authors options: payout").or_default() += 1;
                        }
                    }
                }
                if matches!(o, Outcome::Aggregated { .. })
                    && ours.weights[..] != theirs.weights()[..]
                {
                    *diff.entry("swarmfl rules: weights").or_default() += 1;
                }
                if let (
                    Outcome::Aggregated { payouts: po, .. },
                    Outcome::Aggregated { payouts: pa, .. },
                ) = (&o, &a)
                {
                    if po != pa {
                        *diff.entry("swarmfl rules: payouts of a round").or_default() += 1;
                    }
                }
            }
        }
        let ours_gas = &auth.evm.as_ref().expect("evm").gas;
        println!("reward weights {k:?}: {closed} rounds, {calls} submissions");
        println!("  differences: {diff:?}");
        for (kind, (n, total)) in &gas {
            println!(
                "  authors' gas {kind}: {} calls, mean {}",
                n,
                total / n.max(&1)
            );
        }
        for (kind, g) in ours_gas {
            println!(
                "  SwarmFL.sol (authors options) gas {kind}: {} calls, mean {}",
                g.calls,
                g.mean_gas()
            );
        }
    }
}
