//! The round deadline (`contract.round_timeout_s`; beyond the paper, whose contract has none,
//! so every preset keeps it off).
//!
//! Without a deadline a round can stall for good: with 9 outliers in a swarm of 15 the quorum
//! of 7 accepted models is never reached, the accepted stakes stay locked, and every honest
//! resubmission is a duplicate. With one, the first block whose timestamp is at least
//! `round_timeout_ms` after the round opened (genesis, or the block of the last aggregation or
//! deadline) closes the round before its transactions run: no aggregation, the model and the
//! round number stay, every *accepted* submission gets its stake back, and the outliers'
//! stakes stay with the contract and roll into the next pool, as they would have at an
//! aggregation. Everyone may submit again. Tokens are conserved (asserted).

use super::{ContractParams, ContractState, Verdict};

impl ContractState {
    /// Enters a block with timestamp `timestamp_ms` under `params`: records the block time and
    /// closes the open round if its deadline has passed.
    pub fn enter_block(&mut self, params: &ContractParams, timestamp_ms: u64) {
        self.block_time_ms = timestamp_ms;
        if params.round_timeout_ms == 0
            || timestamp_ms < self.round_opened_ms.saturating_add(params.round_timeout_ms)
        {
            return;
        }
        if self.submissions.is_empty() {
            // Nothing to refund: the round simply opens again from here.
            self.round_opened_ms = timestamp_ms;
            return;
        }
        let before = self.total_units();
        for s in std::mem::take(&mut self.submissions) {
            if s.verdict != Verdict::Accepted {
                continue;
            }
            self.holdings_units = self
                .holdings_units
                .checked_sub(s.stake_units)
                .expect("the contract holds the open round's stakes");
            let balance = &mut self.balances[s.sender as usize];
            *balance = balance
                .checked_add(s.stake_units)
                .expect("conserved supply fits u64");
            self.timeout_refunded_units += s.stake_units;
        }
        self.rounds_timed_out += 1;
        self.round_opened_ms = timestamp_ms;
        assert_eq!(self.total_units(), before, "a deadline conserves tokens");
    }
}
