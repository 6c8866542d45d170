//! What `byzantine.ledger` names, and the withholding policy the network's gossip follows.
//! The misbehaviours themselves live in `byzantine/ledger/`, one file each.

use serde::{Deserialize, Serialize};

use crate::types::RobotId;

registry! {
    /// What the Byzantine robots do on the ledger.
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
    #[serde(rename_all = "kebab-case")]
    pub enum LedgerBehaviour, files ledger_attack_files {
        /// Seal, gossip and submit like everyone.
        #[default]
        Honest = "honest",
        /// Seal two different blocks on one parent, each sent to part of the peers.
        Equivocate = "equivocate" in equivocate,
        /// Seal but release the blocks late, except to some peers.
        Withhold = "withhold" in withhold,
        /// Spam valid-looking transactions (future nonces, same-nonce variants).
        Flood = "flood" in flood,
        /// Re-send old transactions and transactions signed for another chain.
        Replay = "replay" in replay,
        /// Send malformed, forged and oversize blocks and transactions.
        SpamInvalid = "spam-invalid" in spam_invalid,
        /// Send blocks stamped far in the future.
        FutureTimestamp = "future-timestamp" in future_timestamp,
    }
}

/// Which robots withhold, and for how long (the network's gossip asks it).
#[derive(Clone, Debug)]
pub struct WithholdPolicy {
    withholders: Vec<bool>,
    hold_ms: u64,
}

impl WithholdPolicy {
    /// `withholders[r]`: robot r withholds; blocks are held three periods of `period_ms`.
    pub fn new(withholders: Vec<bool>, period_ms: u64) -> WithholdPolicy {
        WithholdPolicy {
            withholders,
            hold_ms: 3 * period_ms,
        }
    }

    /// Whether robot `robot` withholds its blocks.
    pub fn withholds(&self, robot: RobotId) -> bool {
        self.withholders
            .get(robot as usize)
            .copied()
            .unwrap_or(false)
    }

    /// How long a withheld block is held after its timestamp, in milliseconds.
    pub fn hold_ms(&self) -> u64 {
        self.hold_ms
    }
}
