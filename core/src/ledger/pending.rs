//! A node's pending state: the contract state of the block its miner would seal next, which
//! geth answers `eth_estimateGas` on when the caller names no block (web3.py names none).
//!
//! geth v1.10.2 (the authors' node, `FROM ethereum/client-go:v1.10.2`): `EstimateGas`
//! (`internal/ethapi/api.go`, line 1060) defaults to `rpc.PendingBlockNumber`; on a node whose
//! miner runs (every robot calls `w3.geth.miner.start()`, geth-argos
//! `TrajectoryPrediction/controllers/main.py`, line 227) the pending block is the miner
//! worker's snapshot (`miner/worker.go`, `pending`): the head plus the pool's executable
//! transactions, rebuilt on each new head and, when transactions arrived since, every
//! `--miner.recommit` (3 s by default, `newWorkLoop`'s timer, reset at each rebuild), not on
//! each arrival (`mainLoop`'s `txsCh` case applies new transactions at once only when the
//! miner is stopped). docs/CONTRACT.md, "The authors' gas limits".

use super::Ledger;
use crate::contract::ContractState;
use crate::types::{RobotId, SimTime};

impl Ledger {
    /// The state of the block `node` would seal next, as its miner last built it before or at
    /// `at`: its head state, entered as a block stamped `max(head + period, the node's clock at
    /// the rebuild)` (Clique's `Prepare`), then the transactions [`Ledger::sealable_txs`]
    /// picks, in that order, each with its own gas limit, from the mempool as it was at the
    /// last rebuild. The miner rebuilds when the head changes and every `recommit_ms` after
    /// (0: on every arrival, the block always current).
    pub fn pending_state(&self, node: RobotId, at: SimTime, recommit_ms: u64) -> ContractState {
        let n = self.node(node);
        let since = n.head_since.0.min(at.0);
        let rebuilt = (at.0 - since)
            .checked_div(recommit_ms)
            .map_or(at, |rebuilds| SimTime(since + rebuilds * recommit_ms));
        let txs = self.sealable_txs_until(node, Some(rebuilt));
        let head = &self.blocks[&n.head];
        let parent_ms = head.block.header.timestamp_ms;
        let timestamp_ms = self.clock_ms(node, rebuilt).max(parent_ms + self.period_ms);
        let mut state = head.state.clone();
        let epoch = self.enter_block(&mut state, parent_ms, timestamp_ms);
        let params = &self.epochs[epoch].params;
        for hash in &txs {
            let tx = &self.txs[hash].tx;
            tx.execute_on(&mut state, params);
        }
        state
    }
}
