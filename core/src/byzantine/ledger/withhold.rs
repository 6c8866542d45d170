//! `withhold`: the robot seals as usual but its gossip hides each block it signed from half of
//! its peers (those whose id parity differs from its own) until three block periods after the
//! block's timestamp, then releases it: the favoured half builds on it, the others on their
//! own branch, and the release reorganises them (a selfish-mining shape). Honest nodes need no
//! rule for it: fork choice takes the heavier branch; the cost is the reorgs and delays in the
//! summary, bounded by the withholding time.

use crate::config::WithholdPolicy;
use crate::ledger::network::GossipFilter;
use crate::ledger::{BlockHash, Ledger};
use crate::types::{RobotId, SimTime};

impl GossipFilter for WithholdPolicy {
    fn hides(
        &self,
        ledger: &Ledger,
        from: RobotId,
        to: RobotId,
        block: &BlockHash,
        now: SimTime,
    ) -> bool {
        if !self.withholds(from) || from % 2 == to % 2 {
            return false;
        }
        ledger.block(block).is_some_and(|e| {
            e.block.header.signer == from && e.block.header.timestamp_ms + self.hold_ms() > now.0
        })
    }
}
