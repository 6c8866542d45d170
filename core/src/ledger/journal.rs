//! The journal of head changes: which nodes' heads moved, in order, so that the driver's
//! sealing schedule looks only at those.

use std::collections::VecDeque;

use crate::types::RobotId;

/// The nodes whose head or head time changed, in order, for the driver's sealing schedule
/// ([`super::Network`] reads it instead of looking at every node at every step). Bounded: a reader
/// that fell behind what it keeps looks at every node. Not part of the reduced state's
/// digest: it records when the state changed, not what it is.
#[derive(Clone, Debug, Default)]
pub(super) struct HeadJournal {
    /// The position of `nodes[0]`.
    start: u64,
    nodes: VecDeque<RobotId>,
}

impl HeadJournal {
    /// Records that `node`'s head or head time changed.
    pub(super) fn push(&mut self, node: RobotId) {
        self.nodes.push_back(node);
        if self.nodes.len() > HEAD_JOURNAL_KEPT {
            self.nodes.pop_front();
            self.start += 1;
        }
    }

    /// The position after the last recorded change.
    pub(super) fn end(&self) -> u64 {
        self.start + self.nodes.len() as u64
    }

    /// The changes from position `since` on, or None when the journal no longer holds it.
    pub(super) fn since(&self, since: u64) -> Option<impl Iterator<Item = RobotId> + '_> {
        let skip = since.checked_sub(self.start)?;
        (since <= self.end()).then(|| self.nodes.iter().skip(skip as usize).copied())
    }
}

/// Head changes the ledger's journal keeps (see `HeadJournal`).
const HEAD_JOURNAL_KEPT: usize = 1 << 16;
