//! Fork choice's moves of a node's head: to a heavier block, or (liveness under Clique's
//! recent-signer rule) to an equally heavy one on which the node may seal; the canonical chain
//! and mempool follow the head.

use super::intake::Leaves;
use super::{BlockHash, Ledger};
use crate::types::{RobotId, SimTime};

impl Ledger {
    /// Liveness under Clique's recent-signer rule. A node that may not seal on its head moves
    /// to an equally heavy known block on which it may (the lowest id if several). Without
    /// this, equally heavy branches whose every node signed recently on its own branch
    /// deadlock forever under "ties keep the head" (geth's Clique has the same hole: it breaks
    /// ties by lower height, then by a coin flip); the property test found such a deadlock
    /// with 4 robots. With it, some node can always seal, so connected nodes converge. The
    /// rule changes nothing while a node may seal on its head. Returns whether the head moved.
    pub(super) fn unstick(&mut self, node: RobotId, at: SimTime) -> bool {
        let n = &self.nodes[node as usize];
        if !self.signed_recently(&n.head, node) {
            return false;
        }
        let td = self.blocks[&n.head].total_difficulty;
        let better = n.by_td.get(&td).and_then(|same| {
            same.iter()
                .filter(|h| **h != n.head && !self.signed_recently(h, node))
                .min()
                .copied()
        });
        match better {
            Some(b) => {
                self.set_head(node, b, at);
                true
            }
            None => false,
        }
    }

    /// Moves the node's head to `new_head`: canonical chain, reorg figures, mempool.
    pub(super) fn set_head(&mut self, node: RobotId, new_head: BlockHash, at: SimTime) {
        // The branch from the new head down to the first block of the old canonical chain.
        let mut branch = Vec::new();
        let mut cursor = new_head;
        loop {
            let h = self.blocks[&cursor].block.header.height as usize;
            let canonical = &self.nodes[node as usize].canonical;
            if h < canonical.len() && canonical[h] == cursor {
                break;
            }
            branch.push(cursor);
            cursor = self.blocks[&cursor].block.header.parent;
        }
        let ancestor_height = self.blocks[&cursor].block.header.height as usize;
        let n = &mut self.nodes[node as usize];
        let abandoned: Vec<BlockHash> = n.canonical.split_off(ancestor_height + 1);
        let depth = abandoned.len() as u64;
        if depth > 0 {
            n.reorgs += 1;
            n.deepest_reorg = n.deepest_reorg.max(depth);
            self.metrics.on_reorg(depth);
        }
        n.canonical.extend(branch.iter().rev());
        n.head = new_head;
        n.head_td = self.blocks[&new_head].total_difficulty;
        n.head_since = at;
        n.version += 1;
        self.head_journal.push(node);
        let version = self.blocks[&new_head].state.round;
        self.metrics.on_head(node, version, at);
        self.return_abandoned(node, &abandoned, new_head, at);
        for b in branch.iter().rev() {
            for tx in &self.blocks[b].block.txs {
                if self.txs[tx].tx.sender == node {
                    self.metrics.on_included_own(tx, at);
                }
            }
        }
    }

    /// After a reorg, the transactions of the abandoned blocks (in chain and block order)
    /// return to the mempool through the same caps as new ones ([`Ledger::make_room`]): a
    /// reorg must not let a flooder's abandoned transactions past them. First the mempool
    /// keeps only what is still pending on the new chain; then each returning transaction
    /// still pending there is admitted if it fits. One that does not fit stays known to the
    /// node (it holds the abandoned block) without being pending, like one a full mempool
    /// evicts. Each returning transaction takes an arrival number, pending or not, as every
    /// one did before the caps applied here: arrival numbers enter the node's digest, so runs
    /// that never reach the caps keep their records.
    fn return_abandoned(
        &mut self,
        node: RobotId,
        abandoned: &[BlockHash],
        new_head: BlockHash,
        at: SimTime,
    ) {
        let n = &mut self.nodes[node as usize];
        let mut returning = Vec::new();
        for b in abandoned {
            for tx in &self.blocks[b].block.txs {
                if !n.mempool.contains(tx) {
                    returning.push((*tx, n.arrivals));
                    n.arrivals += 1;
                }
            }
        }
        let next = self.blocks[&new_head].next_nonce.clone();
        n.mempool.retain_from_nonces(&next);
        for (tx, arrival) in returning {
            let body = &self.txs[&tx].tx;
            let (sender, nonce) = (body.sender, body.nonce);
            if nonce < next[sender as usize] {
                continue;
            }
            let Ok(victim) = self.make_room(node, sender) else {
                continue;
            };
            if let Some(victim) = victim {
                self.leave_mempool(node, victim, Leaves::Evicted);
            }
            self.nodes[node as usize]
                .mempool
                .insert(tx, sender, nonce, arrival, at);
        }
    }
}
