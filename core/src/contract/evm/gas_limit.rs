//! A robot call's gas: the limit it runs with (the block's, or its transaction's own under
//! `contract.gas_limit = "estimate"`) and the estimate its sender's node makes
//! (`contract::gas_limit`).

use std::sync::Arc;

use revm::bytecode::opcode::SSTORE;
use revm::context::result::ExecutionResult;
use revm::interpreter::interpreter_types::Jumps;
use revm::interpreter::Interpreter;
use revm::primitives::TxKind;

/// EIP-2200's sentry: an `SSTORE` needs more gas left than a call's stipend.
const CALL_STIPEND: u64 = 2300;
use revm::{InspectEvm, Inspector, MainBuilder};

use super::{calldata, context, robot_address, tx_env, CallResult, CallTrace, EvmState, Rules};
use crate::contract::{Call, ContractParams, ContractState, Outcome};
use crate::types::RobotId;

/// Runs a robot's call (`data`) on `evm` with its gas: the transaction's own limit `tx_gas`
/// when it carries one, else the block's. `Err` with the outcome when it cannot run to the
/// end, counted and traced: a limit above the block's can never be included
/// ([`Outcome::OverGasLimit`], no receipt); a call that needs more than its transaction's
/// limit is included, spends the whole limit and reverts ([`Outcome::OutOfGas`]). Either
/// way the contract's storage is unchanged.
pub(super) fn run(
    evm: &mut EvmState,
    sender: RobotId,
    data: Vec<u8>,
    block_gas_limit: u64,
    tx_gas: Option<u64>,
) -> Result<CallResult, Outcome> {
    // A transaction asking for more than a block holds: a pool refuses it unrun.
    let over = tx_gas.is_some_and(|limit| limit > block_gas_limit);
    let limit = tx_gas.unwrap_or(block_gas_limit).min(block_gas_limit);
    if !over {
        if let Some(result) = evm.call_within(robot_address(sender), data, limit) {
            return Ok(result);
        }
    }
    let refused = match tx_gas {
        Some(gas_limit) if !over => Outcome::OutOfGas { gas_limit },
        _ => Outcome::OverGasLimit {
            gas_limit: block_gas_limit,
        },
    };
    // Out of gas (or, for a limit below the calldata's own cost, refused before execution,
    // which `estimate`'s limits never are): the call changed nothing.
    let included = matches!(refused, Outcome::OutOfGas { .. });
    evm.gas
        .entry(refused.name().to_string())
        .or_default()
        .add(limit);
    evm.block_calls.push(CallTrace {
        gas: limit,
        included,
        success: false,
        logs: Vec::new(),
    });
    Err(refused)
}

/// The least gas left at any `SSTORE` of a call: EIP-2200 makes an `SSTORE` with 2300 gas
/// left or less run out of gas (the reentrancy sentry), so a call's minimal limit can exceed
/// the gas it spends. `contracts/SwarmFL.sol` calls no other contract, so every step is the
/// transaction's own frame.
#[derive(Default)]
struct SstoreSentry {
    least_left: Option<u64>,
}

impl<CTX> Inspector<CTX> for SstoreSentry {
    fn step(&mut self, interp: &mut Interpreter, _context: &mut CTX) {
        if interp.bytecode.opcode() == SSTORE {
            let left = interp.gas.remaining();
            self.least_left = Some(self.least_left.map_or(left, |l| l.min(left)));
        }
    }
}

/// The contract's outcome codes that refuse a call and change nothing (`contracts/SwarmFL.sol`:
/// `DUPLICATE`, `INSUFFICIENT_STAKE`, `INSUFFICIENT_FUNDS`, and from `BAD_SENDER` on the
/// malformed ones): each a `require` of the authors' contract or a check its ABI decoder or
/// checked arithmetic makes, so there the call reverts and `eth_estimateGas` fails.
fn refused(code: u64) -> Option<&'static str> {
    match code {
        3 => Some("duplicate"),
        4 => Some("insufficient_stake"),
        6 => Some("insufficient_funds"),
        10.. => Some("malformed"),
        _ => None,
    }
}

/// The gas `sender`'s call needs on `head` under `params`, as `eth_estimateGas` answers it:
/// the least gas limit with which it runs to the end. That is the gas it spends before
/// refunds (the refund comes after execution), at least the calldata floor (EIP-7623), and at
/// least what leaves 2301 gas at each of its `SSTORE`s (EIP-2200's sentry), found in one
/// execution where geth searches by bisection. Runs on a copy of `head`'s EVM, committing
/// nothing. `Err` names the outcome when the estimate fails, as geth's does on the authors'
/// contract (web3.py then raises and sends nothing): the call cannot complete within the
/// block gas limit (`over_gas_limit`), or the contract refuses it ([`refused`]).
pub fn estimate(
    head: &ContractState,
    params: &ContractParams,
    sender: RobotId,
    value_units: u64,
    call: &Call,
) -> Result<u64, &'static str> {
    let Some(data) = calldata(call, value_units) else {
        // submitUpdate never reaches the EVM.
        return Err("malformed");
    };
    let mut evm: EvmState = Arc::unwrap_or_clone(
        head.evm
            .clone()
            .expect("a state made under contract.engine = evm holds its EVM"),
    );
    if evm.rules != Rules::of(params) {
        evm.configure(params);
    }
    let limit = params.block_gas_limit;
    let tx = tx_env(
        robot_address(sender),
        TxKind::Call(evm.contract),
        data.into(),
        limit,
    );
    let mut machine = context(evm.db, limit).build_mainnet_with_inspector(SstoreSentry::default());
    let result = machine.inspect_tx(tx).map(|r| r.result);
    match result {
        Ok(ExecutionResult::Success { gas, output, .. }) => {
            let code = super::to_u64(super::abi::Decoder::new(output.data()).word(0));
            if let Some(outcome) = refused(code) {
                return Err(outcome);
            }
            let sentry = machine.inspector.least_left.map_or(0, |left| {
                // With limit L the SSTORE would have `left - (limit - L)` left: L must make
                // that more than the stipend.
                (limit - left).saturating_add(CALL_STIPEND + 1)
            });
            Ok(gas.total_gas_spent().max(gas.floor_gas()).max(sentry))
        }
        Ok(_) | Err(_) => Err("over_gas_limit"),
    }
}
