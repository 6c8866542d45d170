//! The bytes a geth node would hold for the chain of an `evm` run (`summary.json`'s
//! `ledger.geth_equivalent`, issue 36): each node's canonical chain re-encoded as Ethereum
//! blocks, receipts, indexes and state, with the sizes of `contract::evm::geth`. The model, what
//! it leaves out and its sources are in docs/CONTRACT.md, "What a geth node would store".
//!
//! A measurement read off the final state: nothing here enters a record, a checkpoint or a
//! digest. Under the native engine (and in a build without the `evm` feature) there is no EVM
//! whose storage and receipts could be encoded, and the field is absent.

use serde::{Deserialize, Serialize};

use super::Ledger;
use crate::types::{RobotId, SimTime};

/// Bytes by component, as geth files them (each database entry's key and value).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct GethBytes {
    /// Block bodies: the RLP transactions carrying the authors' calldata, under their keys.
    pub transactions: u64,
    /// Block headers (Clique: 97 bytes of extra data), under their keys.
    pub headers: u64,
    /// Receipt lists in geth's storage encoding (status, cumulative gas, logs).
    pub receipts: u64,
    /// The state: trie nodes (genesis and head), the snapshot's flat entries, the code.
    pub storage: u64,
    /// Total difficulty, canonical hash, hash-to-number and transaction lookup entries.
    pub indexes: u64,
    /// Their sum.
    pub total: u64,
}

/// The state's bytes, part by part (their sum is [`GethBytes::storage`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct GethStateBytes {
    /// Trie nodes of the genesis state and of the head's (account trie and the contract's
    /// storage trie), each stored once by hash.
    pub trie: u64,
    /// The snapshot's flat entries: one per account and per non-zero storage slot.
    pub snapshot: u64,
    /// The contract's code.
    pub code: u64,
    /// Non-zero storage slots of the contract at the head.
    pub slots: u64,
}

/// One point of the series: the final canonical chain up to a time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct GethPoint {
    /// Simulated time, s (a multiple of [`SERIES_STEP_S`]).
    pub time_s: u64,
    /// Height of the chain's last block sealed by then.
    pub height: u64,
    /// Its bytes.
    pub bytes: GethBytes,
    /// What the state would take under `gcmode = archive` by then.
    pub storage_archive: u64,
}

/// The step of [`GethEquivalent::series`], simulated s.
pub const SERIES_STEP_S: u64 = 500;

/// What a geth node would store for the run's chain.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct GethEquivalent {
    /// The model in a line (details in docs/CONTRACT.md).
    pub model: String,
    /// Bytes per node at the end: each node's own canonical chain and head state, mean over
    /// nodes (floor).
    pub bytes_per_node_mean: u64,
    /// The smallest node's.
    pub bytes_per_node_min: u64,
    /// The largest node's.
    pub bytes_per_node_max: u64,
    /// What the blocks a node holds off its canonical chain add (geth writes every valid
    /// block it imports: header, body, total difficulty, hash-to-number; no receipts for a
    /// side block it never executed), mean over nodes (floor): not in the figures above.
    pub side_blocks_per_node_mean: u64,
    /// The final canonical chain's (the heaviest head's), by component.
    pub components: GethBytes,
    /// Its state, part by part.
    pub state: GethStateBytes,
    /// Transactions on it that carry a model.
    pub submissions: u64,
    /// Their mean RLP size (floor), bytes.
    pub tx_bytes_per_submission: u64,
    /// Its receipts in consensus form (with the 256-byte bloom, as the receipt root hashes
    /// them and peers exchange them; geth stores them without): not in the total.
    pub receipts_consensus: u64,
    /// Its state under `gcmode = archive`, every block's new trie nodes kept: not in the
    /// total (the authors ran geth's default, `full`).
    pub storage_archive: u64,
    /// The final canonical chain every [`SERIES_STEP_S`] s.
    pub series: Vec<GethPoint>,
}

/// The geth-equivalent bytes of the ledger's chains, the components and the series those of
/// `best`'s chain (the final canonical one, `metrics::best_node`): `None` unless the contract
/// runs on the EVM (`contract.engine = "evm"`).
/// `end` is the run's end, the last point of the series.
pub fn geth_equivalent(ledger: &Ledger, best: RobotId, end: SimTime) -> Option<GethEquivalent> {
    imp::geth_equivalent(ledger, best, end)
}

#[cfg(not(feature = "evm"))]
mod imp {
    use super::{GethEquivalent, Ledger, RobotId, SimTime};

    /// No EVM in this build, so no run has one.
    pub fn geth_equivalent(_: &Ledger, _: RobotId, _: SimTime) -> Option<GethEquivalent> {
        None
    }
}

#[cfg(feature = "evm")]
mod imp {
    use std::collections::{BTreeMap, BTreeSet};

    use revm::primitives::{Address, B256, U256};

    use super::{
        GethBytes, GethEquivalent, GethPoint, GethStateBytes, Ledger, RobotId, SimTime,
        SERIES_STEP_S,
    };
    use crate::contract::evm::geth::{self as g, Account, Header, TrieNodes};
    use crate::contract::evm::{robot_address, EvmState};
    use crate::contract::Call;
    use crate::ledger::BlockHash;

    /// A robot's ether at genesis: the authors' genesis funds each with 21 ether
    /// (`TrajectoryPrediction/reset-geth`, `0x1236efcbcbb340000`). Fees and stakes are not
    /// followed (the tokens live in the contract's storage here); the balance's size is.
    const ROBOT_WEI: u128 = 21_000_000_000_000_000_000;

    /// Accounts puppeth funds with 1 wei when asked to "pre-fund the pre-compile addresses"
    /// (`geth/files/reset-genesis` of argos-blockchain answers yes): 0x00 to 0xff.
    const PRECOMPILES: u16 = 256;

    /// One block's entries, and what the next block's header needs.
    #[derive(Clone, Debug, Default)]
    struct BlockBytes {
        bytes: GethBytes,
        /// Its entries as a side block: header, body, total difficulty, hash-to-number.
        side: u64,
        receipts_consensus: u64,
        submissions: u64,
        submission_tx_bytes: u64,
        gas_limit: u64,
        gas_used: u64,
        time_ms: u64,
    }

    pub fn geth_equivalent(ledger: &Ledger, best: RobotId, end: SimTime) -> Option<GethEquivalent> {
        let genesis_state = ledger.block(&ledger.genesis())?.state.evm.clone()?;
        let mut blocks: BTreeMap<BlockHash, BlockBytes> = BTreeMap::new();
        let mut states = States {
            ledger,
            genesis: tries(ledger, &ledger.genesis(), &genesis_state),
            cache: BTreeMap::new(),
        };
        let mut per_node = Vec::with_capacity(ledger.robots() as usize);
        let mut side = 0;
        for robot in 0..ledger.robots() {
            let chain = ledger.canonical_chain(robot);
            let mut bytes = GethBytes::default();
            for hash in chain {
                bytes.add(&block_bytes(ledger, &mut blocks, hash).bytes);
            }
            bytes.storage += states
                .at(chain.last().expect("a chain holds genesis"))
                .total();
            per_node.push(bytes.with_total().total);
            let canonical: BTreeSet<&BlockHash> = chain.iter().collect();
            for hash in &ledger.node(robot).known_blocks {
                if !canonical.contains(hash) {
                    side += block_bytes(ledger, &mut blocks, hash).side;
                }
            }
        }
        let best = ledger.canonical_chain(best);
        let mut components = GethBytes::default();
        let (mut receipts_consensus, mut submissions, mut submission_bytes) = (0, 0, 0);
        let mut archive = Archive::default();
        let mut series = Vec::new();
        let mut next_s = SERIES_STEP_S;
        // The point of time t is the chain's prefix sealed by then, with the state of its last
        // block; after the last block, the whole chain until the run's end.
        let mut point = |time_s: u64, last: usize, so_far: GethBytes, archive: &Archive| {
            let mut bytes = so_far;
            bytes.storage += states.at(&best[last]).total();
            GethPoint {
                time_s,
                height: last as u64,
                bytes: bytes.with_total(),
                storage_archive: archive.bytes,
            }
        };
        for (i, hash) in best.iter().enumerate() {
            let b = block_bytes(ledger, &mut blocks, hash).clone();
            while b.time_ms > next_s * 1000 {
                series.push(point(next_s, i.max(1) - 1, components, &archive));
                next_s += SERIES_STEP_S;
            }
            components.add(&b.bytes);
            receipts_consensus += b.receipts_consensus;
            submissions += b.submissions;
            submission_bytes += b.submission_tx_bytes;
            archive.add(ledger, hash);
        }
        while next_s <= end.0 / 1000 {
            series.push(point(next_s, best.len() - 1, components, &archive));
            next_s += SERIES_STEP_S;
        }
        let state = states.at(best.last().expect("a chain holds genesis"));
        components.storage += state.total();
        let n = per_node.len() as u64;
        Some(GethEquivalent {
            model: "geth 1.10.2, gcmode full, snapshot on, LevelDB entries (key + value), \
                    uncompressed; docs/CONTRACT.md"
                .to_string(),
            bytes_per_node_mean: per_node.iter().sum::<u64>() / n.max(1),
            bytes_per_node_min: per_node.iter().copied().min().unwrap_or(0),
            bytes_per_node_max: per_node.iter().copied().max().unwrap_or(0),
            side_blocks_per_node_mean: side / n.max(1),
            components: components.with_total(),
            state,
            submissions,
            tx_bytes_per_submission: submission_bytes.checked_div(submissions).unwrap_or(0),
            receipts_consensus,
            storage_archive: archive.bytes,
            series,
        })
    }

    impl GethStateBytes {
        fn total(&self) -> u64 {
            self.trie + self.snapshot + self.code
        }
    }

    impl GethBytes {
        fn add(&mut self, other: &GethBytes) {
            self.transactions += other.transactions;
            self.headers += other.headers;
            self.receipts += other.receipts;
            self.storage += other.storage;
            self.indexes += other.indexes;
            self.total += other.total;
        }

        fn with_total(mut self) -> GethBytes {
            self.total =
                self.transactions + self.headers + self.receipts + self.storage + self.indexes;
            self
        }
    }

    /// The state after each block asked for, computed once.
    struct States<'l> {
        ledger: &'l Ledger,
        /// The genesis state's nodes: on disk since `geth init`.
        genesis: TrieNodes,
        cache: BTreeMap<BlockHash, GethStateBytes>,
    }

    impl States<'_> {
        /// The state a node whose head is `hash` holds: the genesis trie and the head's (once
        /// committed), nodes they share stored once; the snapshot's flat entries; the code.
        fn at(&mut self, hash: &BlockHash) -> GethStateBytes {
            let (ledger, genesis) = (self.ledger, &self.genesis);
            *self.cache.entry(*hash).or_insert_with(|| {
                let evm = ledger
                    .block(hash)
                    .and_then(|e| e.state.evm.as_ref())
                    .expect("an evm state");
                let mut seen = BTreeSet::new();
                let trie =
                    genesis.new_bytes(&mut seen) + tries(ledger, hash, evm).new_bytes(&mut seen);
                let slots = evm.storage();
                // The contract's storage root does not change an account's size.
                let accounts = accounts(ledger, hash, evm, B256::ZERO);
                let snapshot = slots
                    .values()
                    .map(|v| 1 + 32 + 32 + g::slot_value(*v).len() as u64)
                    .sum::<u64>()
                    + accounts
                        .iter()
                        .map(|(_, a)| 1 + 32 + a.slim_bytes())
                        .sum::<u64>();
                GethStateBytes {
                    trie,
                    snapshot,
                    code: 1 + 32 + evm.code_bytes(),
                    slots: slots.len() as u64,
                }
            })
        }
    }

    /// The stored nodes of the account trie and of the contract's storage trie after `hash`.
    fn tries(ledger: &Ledger, hash: &BlockHash, evm: &EvmState) -> TrieNodes {
        let entries: Vec<(Vec<u8>, Vec<u8>)> = evm
            .storage()
            .into_iter()
            .map(|(slot, value)| (slot.to_be_bytes::<32>().to_vec(), g::slot_value(value)))
            .collect();
        let storage = g::secure_trie(&entries);
        let accounts: Vec<(Vec<u8>, Vec<u8>)> = accounts(ledger, hash, evm, storage.root)
            .into_iter()
            .map(|(address, account)| (address.to_vec(), account.rlp()))
            .collect();
        let mut all = g::secure_trie(&accounts);
        all.nodes.extend(storage.nodes);
        all
    }

    /// The accounts after `hash`: the robots (nonce = transactions sent), the contract (whose
    /// storage root is `storage_root`) and the pre-funded precompile addresses.
    fn accounts(
        ledger: &Ledger,
        hash: &BlockHash,
        evm: &EvmState,
        storage_root: B256,
    ) -> Vec<(Address, Account)> {
        let entry = ledger.block(hash).expect("a stored block");
        let mut out: Vec<(Address, Account)> = (0..ledger.robots())
            .map(|r| {
                let account = Account {
                    nonce: entry.next_nonce[r as usize],
                    balance: U256::from(ROBOT_WEI),
                    storage_root: g::empty_root(),
                    code_hash: g::empty_code_hash(),
                };
                (robot_address(r), account)
            })
            .collect();
        out.push((
            evm.contract(),
            Account {
                nonce: 1,
                balance: U256::ZERO,
                storage_root,
                // The value does not change the size; the code is the deployed one.
                code_hash: B256::repeat_byte(0xc0),
            },
        ));
        out.extend((0..PRECOMPILES).map(|i| {
            let mut address = [0u8; 20];
            address[18..].copy_from_slice(&i.to_be_bytes());
            let account = Account {
                nonce: 0,
                balance: U256::from(1),
                storage_root: g::empty_root(),
                code_hash: g::empty_code_hash(),
            };
            (Address::new(address), account)
        }));
        out
    }

    /// `gcmode = archive`: every block's trie nodes are written, each new node once.
    #[derive(Default)]
    struct Archive {
        seen: BTreeSet<B256>,
        bytes: u64,
    }

    impl Archive {
        fn add(&mut self, ledger: &Ledger, hash: &BlockHash) {
            let evm = ledger
                .block(hash)
                .and_then(|e| e.state.evm.as_ref())
                .expect("an evm state");
            self.bytes += tries(ledger, hash, evm).new_bytes(&mut self.seen);
        }
    }

    /// The entries of one block, computed once per block (the parent's first: the header's
    /// gas limit follows the parent's).
    fn block_bytes<'a>(
        ledger: &Ledger,
        blocks: &'a mut BTreeMap<BlockHash, BlockBytes>,
        hash: &BlockHash,
    ) -> &'a BlockBytes {
        if !blocks.contains_key(hash) {
            let entry = ledger.block(hash).expect("a stored block");
            let header = &entry.block.header;
            let parent = if header.height == 0 {
                None
            } else {
                Some(block_bytes(ledger, blocks, &header.parent).clone())
            };
            let made = encode_block(ledger, hash, parent.as_ref());
            blocks.insert(*hash, made);
        }
        &blocks[hash]
    }

    fn encode_block(ledger: &Ledger, hash: &BlockHash, parent: Option<&BlockBytes>) -> BlockBytes {
        let entry = ledger.block(hash).expect("a stored block");
        let header = &entry.block.header;
        let evm = entry.state.evm.as_ref().expect("an evm state");
        let calls = if parent.is_some() {
            &evm.block_calls[..]
        } else {
            &[]
        };
        assert_eq!(
            calls.len(),
            entry.block.txs.len(),
            "one call per transaction"
        );
        let (mut tx_bytes, mut stored, mut consensus) = (Vec::new(), Vec::new(), Vec::new());
        let (mut gas_used, mut submissions, mut submission_tx_bytes) = (0u64, 0u64, 0u64);
        for (tx_hash, call) in entry.block.txs.iter().zip(calls) {
            if !call.included {
                continue; // Over the block gas limit: no block would hold it.
            }
            let tx = &ledger
                .tx(tx_hash)
                .expect("a block's transactions are stored")
                .tx;
            let (data, submission) = match &tx.call {
                Call::SubmitModel { weights, samples }
                | Call::SubmitUpdate {
                    weights, samples, ..
                } => (g::authors_submission_calldata(*samples, weights), true),
                Call::Transfer { to, amount_units } => (
                    g::transfer_calldata(robot_address(*to), *amount_units, tx.value_units),
                    false,
                ),
            };
            let value_wei = u128::from(tx.value_units) * u128::from(g::WEI_PER_UNIT);
            // The gas field is web3.py's estimate, the gas the call uses.
            let bytes = g::legacy_tx_bytes(tx.nonce, call.gas, value_wei, &data);
            if submission {
                submissions += 1;
                submission_tx_bytes += bytes;
            }
            tx_bytes.push(bytes);
            gas_used += call.gas;
            stored.push(g::stored_receipt_bytes(call.success, gas_used, &call.logs));
            consensus.push(g::consensus_receipt_bytes(
                call.success,
                gas_used,
                &call.logs,
            ));
        }
        let time = g::GENESIS_UNIX_S + header.timestamp_ms / 1000;
        let (header_rlp, gas_limit) = match parent {
            None => (
                Header::genesis(ledger.robots(), time).rlp_bytes(),
                g::GENESIS_GAS_LIMIT,
            ),
            Some(p) => {
                let limit = g::next_gas_limit(p.gas_limit, p.gas_used);
                let h = Header::sealed(header.height, header.difficulty, limit, gas_used, time);
                (h.rlp_bytes(), limit)
            }
        };
        let key = g::BLOCK_KEY_BYTES;
        // geth's genesis has difficulty 1 where ours has 0: one more all along.
        let td = u128::from(entry.total_difficulty) + 1;
        let number_bytes = u64::from(8 - header.height.leading_zeros() / 8);
        let td_entry = key + 1 + g::int_bytes(td); // `headerTDKey` -> RLP(td)
        let number_entry = 1 + 32 + 8; // `headerNumberKey` -> number
        let indexes = td_entry
            + number_entry
            + (1 + 8 + 1 + 32) // `headerHashKey` -> hash (canonical)
            + tx_bytes.len() as u64 * (1 + 32 + number_bytes); // `txLookupKey` -> number
        let (body, header_entry) = (key + g::body_bytes(&tx_bytes), key + header_rlp);
        BlockBytes {
            side: header_entry + body + td_entry + number_entry,
            bytes: GethBytes {
                transactions: body,
                headers: header_entry,
                receipts: key + g::receipts_bytes(&stored),
                storage: 0,
                indexes,
                total: 0,
            }
            .with_total(),
            receipts_consensus: g::receipts_bytes(&consensus),
            submissions,
            submission_tx_bytes,
            gas_limit,
            gas_used,
            time_ms: header.timestamp_ms,
        }
    }
}
