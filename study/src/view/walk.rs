//! The frame grid of a view and the walk that samples the world on it while a log is folded.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use swarmfl_core::config::Config;
use swarmfl_core::event::{CheckpointCause, Event, Record};
use swarmfl_core::state::State;
use swarmfl_core::Digest;

use super::frames::Frames;

/// Most uniform frames of a view (block frames come on top).
const MAX_FRAMES: u64 = 2000;

/// Where the uniform frames fall: every `frame_ms`, a whole number of ticks (every tick of a
/// short run), at most [`MAX_FRAMES`] over the run's duration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Grid {
    pub(super) tick_ms: u64,
    pub(super) total_ticks: u64,
    pub(super) frame_ms: u64,
    pub(super) robots: u32,
}

impl Grid {
    /// The grid of a run with `config`.
    pub(super) fn of(config: &Config) -> Grid {
        let tick_ms = (config.run.tick_s * 1000.0).round().max(1.0) as u64;
        let total_ticks = config.ticks().max(1);
        let every_ticks = total_ticks.div_ceil(MAX_FRAMES).max(1);
        Grid {
            tick_ms,
            total_ticks,
            frame_ms: every_ticks * tick_ms,
            robots: config.world.robots,
        }
    }
}

/// The second fold of the log: frames, every node's blocks and the reorgs, read from the
/// index's state after each record.
pub(super) struct Walk {
    /// Where the uniform frames fall.
    pub(super) grid: Grid,
    /// The time of the next uniform frame.
    pub(super) next_frame_ms: u64,
    /// Every block seen (any node's), numbered in sealing order; genesis is 0.
    pub(super) ids: BTreeMap<Digest, u32>,
    /// JSON without its closing bracket: `[id, parent id, height, node, time ms]` per block.
    pub(super) blocks: String,
    /// JSON without its closing bracket: `[time ms, node, depth]` per reorg.
    pub(super) reorgs: String,
    /// Reorgs written into `reorgs`.
    pub(super) reorg_count: usize,
    /// Block checkpoints folded: every sealing of any node.
    pub(super) sealings: u64,
    /// Every node's head after the last ledger event.
    pub(super) heads: Vec<Digest>,
    /// The sampled frames: every uniform one, and one at every sealing (shown when its block
    /// is on the final canonical chain of the records folded).
    pub(super) frames: Frames,
}

impl Walk {
    /// A walk at genesis (`state`) on `grid`, with the frame at time 0.
    pub(super) fn start(state: &State, grid: Grid) -> Walk {
        let genesis = state.ledger.head(0).0;
        let mut walk = Walk {
            grid,
            next_frame_ms: grid.frame_ms,
            ids: BTreeMap::from([(genesis, 0)]),
            blocks: String::from("[[0,-1,0,-1,0]"),
            reorgs: String::from("["),
            reorg_count: 0,
            sealings: 0,
            heads: vec![genesis; grid.robots as usize],
            frames: Frames::default(),
        };
        walk.frames.push(state, &walk.ids, 0, None);
        walk
    }

    /// Notes `record`, which the index has just folded into `state`: a ledger event's reorgs,
    /// a block checkpoint's block and frame, a tick's uniform frame when one falls due.
    pub(super) fn note(&mut self, state: &State, record: &Record) {
        match record {
            Record::Event {
                event: Event::Ledger(_),
                time,
            } => self.note_reorgs(state, time.0),
            Record::Checkpoint(cp) => {
                if let CheckpointCause::Block { node, height } = cp.cause {
                    self.sealings += 1;
                    self.note_block(state, node, height, cp.time.0);
                }
            }
            Record::Event {
                time,
                event: Event::Tick(_),
            } => {
                let now = time.0 + self.grid.tick_ms;
                if now >= self.next_frame_ms {
                    self.frames.push(state, &self.ids, now, None);
                    let frame_ms = self.grid.frame_ms;
                    self.next_frame_ms = (now / frame_ms + 1) * frame_ms;
                }
            }
            Record::Event { .. } => {}
        }
    }

    /// After a ledger event at `time_ms`: every node whose new head does not descend from its
    /// old one had a reorg; records it with its depth (blocks of the old branch abandoned).
    fn note_reorgs(&mut self, state: &State, time_ms: u64) {
        let ledger = &state.ledger;
        for (node, old) in self.heads.iter_mut().enumerate() {
            let (new, height) = ledger.head(node as u32);
            if new == *old {
                continue;
            }
            let old_height = ledger.block(old).map_or(0, |e| e.block.header.height);
            // The new head's ancestor at the old head's height.
            let mut cursor = new;
            let mut h = height;
            while h > old_height {
                match ledger.block(&cursor) {
                    Some(e) => cursor = e.block.header.parent,
                    None => break,
                }
                h -= 1;
            }
            if cursor != *old {
                let mut a = *old;
                let mut b = cursor;
                let mut depth = 0u64;
                while a != b {
                    let (Some(ea), Some(eb)) = (ledger.block(&a), ledger.block(&b)) else {
                        break;
                    };
                    a = ea.block.header.parent;
                    b = eb.block.header.parent;
                    depth += 1;
                }
                let _ = write!(
                    self.reorgs,
                    "{}[{time_ms},{node},{depth}]",
                    if self.reorg_count == 0 { "" } else { "," },
                );
                self.reorg_count += 1;
            }
            *old = new;
        }
    }

    /// At the checkpoint of `node` sealing a block at `height`: numbers the block if new, and
    /// takes its frame (shown if the block is on the final canonical chain).
    fn note_block(&mut self, state: &State, node: u32, height: u64, time_ms: u64) {
        let (hash, _) = state.ledger.head(node);
        if !self.ids.contains_key(&hash) {
            let id = self.ids.len() as u32;
            self.ids.insert(hash, id);
            let parent = state
                .ledger
                .block(&hash)
                .and_then(|e| self.ids.get(&e.block.header.parent).copied())
                .map_or(-1, i64::from);
            let _ = write!(self.blocks, ",[{id},{parent},{height},{node},{time_ms}]");
        }
        self.frames
            .push(state, &self.ids, time_ms, Some((hash, height)));
    }
}
