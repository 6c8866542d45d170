//! What a geth node stores, in bytes, for the chain the `evm` engine runs: the Ethereum
//! encodings (RLP) of headers, transactions, receipts and state, and the keys geth files them
//! under. The model, its sources (go-ethereum v1.10.2, the authors' version) and what it leaves
//! out are in docs/CONTRACT.md, "What a geth node would store"; `ledger/geth.rs` walks the chain
//! and adds these up.
//!
//! Every function here returns a byte count from plain inputs; nothing reads the ledger.

use std::collections::BTreeSet;

use alloy_rlp::{Encodable, RlpEncodable};
use revm::primitives::{keccak256, Address, Bytes, Log, B256, U256};

/// geth's database key of a header, body or receipt list: a one-byte prefix, the number (8
/// bytes, big endian) and the hash (`core/rawdb/schema.go`: `headerKey`, `blockBodyKey`,
/// `blockReceiptsKey`).
pub const BLOCK_KEY_BYTES: u64 = 1 + 8 + 32;

/// Clique's extra data of a sealed block: 32 bytes of vanity and the 65-byte seal
/// (`consensus/clique/clique.go`: `extraVanity`, `extraSeal`).
pub const SEALED_EXTRA_BYTES: usize = 32 + 65;

/// The gas price of the authors' transactions, wei: web3.py leaves it to geth, whose
/// suggestion starts at the miner's minimum, 1 gwei (`eth/ethconfig/config.go`:
/// `Miner.GasPrice`; `eth/backend.go`: `gpoParams.Default = config.Miner.GasPrice`).
pub const GAS_PRICE_WEI: u64 = 1_000_000_000;

/// The chain id of the authors' genesis (`reset-genesis` answers puppeth's network id with
/// 1515); EIP-155 signatures carry `v = 2 * id + 35 + parity`.
pub const CHAIN_ID: u64 = 1515;

/// Wei per contract unit: 1 token = 10^9 units = 1 ether = 10^18 wei (docs/CONTRACT.md, row 11).
pub const WEI_PER_UNIT: u64 = 1_000_000_000;

/// The block gas limit of the authors' genesis (`TrajectoryPrediction/reset-geth`).
pub const GENESIS_GAS_LIMIT: u64 = 0x9000000000000;

/// The miner's gas target (`eth/ethconfig/config.go`: `Miner.GasFloor`, `GasCeil`).
pub const MINER_GAS_TARGET: u64 = 8_000_000;

/// Seconds since 1970 of the model's genesis (May 2021, when geth 1.10.2 was current): block
/// times are this plus the simulated time, so they take the 4 bytes a 2021 timestamp takes.
pub const GENESIS_UNIX_S: u64 = 1_620_000_000;

/// The length of an RLP string of `n` bytes, `first` its first byte (a single byte below
/// 0x80 is its own encoding).
fn string_len(n: usize, first: Option<u8>) -> usize {
    match (n, first) {
        (1, Some(b)) if b < 0x80 => 1,
        _ => alloy_rlp::Header {
            list: false,
            payload_length: n,
        }
        .length_with_payload(),
    }
}

/// The length of an RLP list whose items take `payload` bytes.
pub fn list_len(payload: usize) -> usize {
    alloy_rlp::Header {
        list: true,
        payload_length: payload,
    }
    .length_with_payload()
}

/// A block header before London (`core/types/block.go`: `Header`, 15 fields).
#[derive(RlpEncodable)]
pub struct Header {
    /// Parent hash.
    pub parent: B256,
    /// Hash of the (empty) uncle list.
    pub uncles: B256,
    /// Clique leaves the coinbase zero.
    pub coinbase: Address,
    /// State root.
    pub state_root: B256,
    /// Transaction trie root.
    pub tx_root: B256,
    /// Receipt trie root.
    pub receipt_root: B256,
    /// The logs' bloom filter.
    pub bloom: [u8; 256],
    /// Clique: 2 in turn, 1 out of turn.
    pub difficulty: u64,
    /// Height.
    pub number: u64,
    /// Gas limit.
    pub gas_limit: u64,
    /// Gas used by the block's transactions.
    pub gas_used: u64,
    /// Unix seconds.
    pub time: u64,
    /// Clique's vanity and seal (and, at genesis, the signer list).
    pub extra: Bytes,
    /// Zero under Clique.
    pub mix_digest: B256,
    /// Zero under Clique (no vote).
    pub nonce: [u8; 8],
}

impl Header {
    /// A sealed Clique header with the figures that set its size (hashes and bloom are
    /// fixed-size, so their values do not matter).
    pub fn sealed(
        number: u64,
        difficulty: u64,
        gas_limit: u64,
        gas_used: u64,
        time: u64,
    ) -> Header {
        Header::with_extra(
            number,
            difficulty,
            gas_limit,
            gas_used,
            time,
            SEALED_EXTRA_BYTES,
        )
    }

    /// The genesis header: its extra data lists the `signers` (20 bytes each) between the
    /// vanity and an empty seal (`consensus/clique/clique.go`, checkpoint blocks).
    pub fn genesis(signers: u32, time: u64) -> Header {
        let extra = SEALED_EXTRA_BYTES + 20 * signers as usize;
        Header::with_extra(0, 1, GENESIS_GAS_LIMIT, 0, time, extra)
    }

    fn with_extra(
        number: u64,
        difficulty: u64,
        gas_limit: u64,
        gas_used: u64,
        time: u64,
        extra: usize,
    ) -> Header {
        Header {
            parent: B256::ZERO,
            uncles: B256::ZERO,
            coinbase: Address::ZERO,
            state_root: B256::ZERO,
            tx_root: B256::ZERO,
            receipt_root: B256::ZERO,
            bloom: [0; 256],
            difficulty,
            number,
            gas_limit,
            gas_used,
            time,
            extra: Bytes::from(vec![0u8; extra]),
            mix_digest: B256::ZERO,
            nonce: [0; 8],
        }
    }

    /// Its RLP length in bytes.
    pub fn rlp_bytes(&self) -> u64 {
        self.length() as u64
    }
}

/// The gas limit of a block after one with `parent_limit` and `parent_used`, as geth's miner
/// sets it (`core/block_validator.go`: `CalcGasLimit`, floor and ceiling both
/// [`MINER_GAS_TARGET`], `params.GasLimitBoundDivisor` 1024, `params.MinGasLimit` 5000).
pub fn next_gas_limit(parent_limit: u64, parent_used: u64) -> u64 {
    let contrib = (parent_used + parent_used / 2) / 1024;
    let decay = parent_limit / 1024 - 1;
    let limit = (parent_limit - decay + contrib).max(5000);
    if limit < MINER_GAS_TARGET {
        (parent_limit + decay).min(MINER_GAS_TARGET)
    } else if limit > MINER_GAS_TARGET {
        (parent_limit - decay).max(MINER_GAS_TARGET)
    } else {
        limit
    }
}

/// The RLP length of a legacy (pre-EIP-2718) signed transaction (`core/types/legacy_tx.go`:
/// nonce, gas price, gas, to, value, data, v, r, s) with `data_bytes` of calldata, EIP-155
/// `v` for [`CHAIN_ID`] and full 32-byte `r` and `s` (one signature in 256 has a shorter one).
pub fn legacy_tx_bytes(nonce: u64, gas: u64, value_wei: u128, data: &[u8]) -> u64 {
    let v = 2 * CHAIN_ID + 35;
    let word = U256::MAX;
    let payload = nonce.length()
        + GAS_PRICE_WEI.length()
        + gas.length()
        + Address::ZERO.length()
        + value_wei.length()
        + string_len(data.len(), data.first().copied())
        + v.length()
        + 2 * word.length();
    list_len(payload) as u64
}

/// The authors' calldata of a submission: `submitWeights(int nbSamples, int48[2848] weights)`
/// of `federatedsc3V2.sol`, the selector then one 32-byte word per argument and per weight
/// (a fixed-size array is encoded in place), as web3.py's `sc.functions.submitWeights(nb_sample,
/// weights).transact(...)` sends it (`controllers/docker/fedlerv2.py`).
pub fn authors_submission_calldata(samples: u64, weights: &[i64]) -> Vec<u8> {
    let signature = format!("submitWeights(int256,int48[{}])", weights.len());
    let mut data = super::abi::selector(&signature);
    let mut args = super::abi::Encoder::default();
    args.uint(u128::from(samples));
    args.int_words(weights);
    data.extend_from_slice(&args.finish());
    data
}

/// SwarmFL.sol's calldata of `transfer(to, amount, offered)` (the authors have no transfer):
/// the selector and three words.
pub fn transfer_calldata(to: Address, amount_units: u64, value_units: u64) -> Vec<u8> {
    let mut data = super::abi::selector("transfer(address,uint64,uint64)");
    let mut args = super::abi::Encoder::default();
    args.address(to);
    args.uint(u128::from(amount_units));
    args.uint(u128::from(value_units));
    data.extend_from_slice(&args.finish());
    data
}

/// The storage encoding of one receipt (`core/types/receipt.go`: `storedReceiptRLP`: status,
/// cumulative gas, logs; no bloom since database version 5).
#[derive(RlpEncodable)]
struct StoredReceipt {
    status: Bytes,
    cumulative_gas: u64,
    logs: Vec<Log>,
}

/// The consensus encoding of one receipt (`core/types/receipt.go`: `receiptRLP`: status,
/// cumulative gas, bloom, logs), the one the receipt root hashes and peers exchange.
#[derive(RlpEncodable)]
struct ConsensusReceipt {
    status: Bytes,
    cumulative_gas: u64,
    bloom: [u8; 256],
    logs: Vec<Log>,
}

fn status(success: bool) -> Bytes {
    // `receiptStatusSuccessfulRLP` is [0x01], `receiptStatusFailedRLP` empty.
    if success {
        Bytes::from_static(&[1])
    } else {
        Bytes::new()
    }
}

/// A receipt's RLP length as geth stores it (without bloom).
pub fn stored_receipt_bytes(success: bool, cumulative_gas: u64, logs: &[Log]) -> u64 {
    StoredReceipt {
        status: status(success),
        cumulative_gas,
        logs: logs.to_vec(),
    }
    .length() as u64
}

/// A receipt's RLP length in its consensus form (with the 256-byte bloom).
pub fn consensus_receipt_bytes(success: bool, cumulative_gas: u64, logs: &[Log]) -> u64 {
    ConsensusReceipt {
        status: status(success),
        cumulative_gas,
        bloom: [0; 256],
        logs: logs.to_vec(),
    }
    .length() as u64
}

/// The RLP length of a block body, `[transactions, uncles]`, with transactions of
/// `tx_bytes` each (legacy transactions are list items as they are) and no uncle.
pub fn body_bytes(tx_bytes: &[u64]) -> u64 {
    let txs = tx_bytes.iter().sum::<u64>() as usize;
    list_len(list_len(txs) + list_len(0)) as u64
}

/// The RLP length of a list of stored receipts of `receipt_bytes` each.
pub fn receipts_bytes(receipt_bytes: &[u64]) -> u64 {
    list_len(receipt_bytes.iter().sum::<u64>() as usize) as u64
}

/// The RLP length of an integer as geth's `big.Int` or `uint64` encodes it.
pub fn int_bytes(x: u128) -> u64 {
    x.length() as u64
}

/// An account as the state trie holds it: `[nonce, balance, storage root, code hash]`
/// (`core/state/state_object.go`: `Account`).
#[derive(RlpEncodable)]
pub struct Account {
    /// Nonce.
    pub nonce: u64,
    /// Balance, wei.
    pub balance: U256,
    /// Root of its storage trie.
    pub storage_root: B256,
    /// keccak of its code.
    pub code_hash: B256,
}

/// The root of an empty trie, keccak(RLP("")) (`core/types`: `EmptyRootHash`).
pub fn empty_root() -> B256 {
    keccak256([0x80u8])
}

/// keccak of empty code.
pub fn empty_code_hash() -> B256 {
    keccak256([])
}

impl Account {
    /// The account's RLP.
    pub fn rlp(&self) -> Vec<u8> {
        alloy_rlp::encode(self)
    }

    /// Its snapshot ("slim") encoding's length: the empty root and empty code hash become
    /// empty strings (`core/state/snapshot/account.go`: `SlimAccountRLP`).
    pub fn slim_bytes(&self) -> u64 {
        let root = if self.storage_root == empty_root() {
            1
        } else {
            33
        };
        let code = if self.code_hash == empty_code_hash() {
            1
        } else {
            33
        };
        list_len(self.nonce.length() + self.balance.length() + root + code) as u64
    }
}

/// A storage slot's value as the storage trie and the snapshot hold it: the RLP string of the
/// value's big-endian bytes without leading zeros (`core/state/state_object.go`,
/// `updateTrie`: `rlp.EncodeToBytes(common.TrimLeftZeroes(value[:]))`).
pub fn slot_value(value: U256) -> Vec<u8> {
    let bytes: [u8; 32] = value.to_be_bytes();
    let trimmed: &[u8] = {
        let start = bytes.iter().position(|&b| b != 0).unwrap_or(32);
        &bytes[start..]
    };
    alloy_rlp::encode(trimmed)
}

/// The nodes of a Merkle Patricia trie that geth writes to its database: every node whose RLP
/// is 32 bytes or more, and the root, each under its 32-byte hash (`trie/hasher.go`, nodes
/// under 32 bytes are embedded in their parent; `core/rawdb/accessors_state.go`:
/// `WriteTrieNode(db, hash, node)`).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct TrieNodes {
    /// The stored nodes, by hash, with their RLP length.
    pub nodes: Vec<(B256, u64)>,
    /// The root hash.
    pub root: B256,
}

impl TrieNodes {
    /// The bytes they take as database entries: a 32-byte key and the node per entry.
    pub fn entry_bytes(&self) -> u64 {
        self.nodes.iter().map(|(_, len)| 32 + len).sum()
    }

    /// The bytes of the nodes not in `seen`, which then holds them too: what a trie adds to
    /// a database that already holds those (geth writes a node by hash, so a node present
    /// in an older trie costs nothing again).
    pub fn new_bytes(&self, seen: &mut BTreeSet<B256>) -> u64 {
        self.nodes
            .iter()
            .filter(|(hash, _)| seen.insert(*hash))
            .map(|(_, len)| 32 + len)
            .sum()
    }
}

/// The stored nodes of the trie mapping `keccak(key)` to `value` for each entry (a "secure"
/// trie, as geth's account and storage tries are). Empty: no node and the empty root.
pub fn secure_trie(entries: &[(Vec<u8>, Vec<u8>)]) -> TrieNodes {
    let leaves: Vec<(Vec<u8>, &[u8])> = entries
        .iter()
        .map(|(key, value)| (nibbles(keccak256(key).as_slice()), value.as_slice()))
        .collect();
    trie(leaves)
}

/// The stored nodes of the trie mapping each key, all of one length, to its value.
fn trie(mut leaves: Vec<(Vec<u8>, &[u8])>) -> TrieNodes {
    leaves.sort_unstable_by(|a, b| a.0.cmp(&b.0));
    let mut out = TrieNodes::default();
    if leaves.is_empty() {
        out.root = empty_root();
        return out;
    }
    assert!(
        leaves
            .windows(2)
            .all(|w| w[0].0 < w[1].0 && w[0].0.len() == w[1].0.len()),
        "distinct keys of one length (no value sits at a branch)"
    );
    let root = node(&leaves, 0, &mut out);
    let hash = keccak256(&root);
    out.nodes.push((hash, root.len() as u64));
    out.root = hash;
    out
}

fn nibbles(bytes: &[u8]) -> Vec<u8> {
    bytes.iter().flat_map(|b| [b >> 4, b & 0x0f]).collect()
}

/// The hex-prefix encoding of a path (Ethereum yellow paper, appendix C).
fn hex_prefix(path: &[u8], leaf: bool) -> Vec<u8> {
    let flag = if leaf { 2 } else { 0 } + (path.len() % 2) as u8;
    let mut out = Vec::with_capacity(path.len() / 2 + 1);
    let rest = if path.len() % 2 == 1 {
        out.push((flag << 4) | path[0]);
        &path[1..]
    } else {
        out.push(flag << 4);
        path
    };
    out.extend(rest.chunks(2).map(|p| (p[0] << 4) | p[1]));
    out
}

fn push_string(out: &mut Vec<u8>, bytes: &[u8]) {
    bytes.encode(out);
}

fn wrap_list(payload: Vec<u8>) -> Vec<u8> {
    let mut out = Vec::with_capacity(payload.len() + 3);
    alloy_rlp::Header {
        list: true,
        payload_length: payload.len(),
    }
    .encode(&mut out);
    out.extend_from_slice(&payload);
    out
}

/// How a parent refers to a child node: embedded under 32 bytes, else by hash (the child is
/// then stored).
fn child_ref(child: Vec<u8>, payload: &mut Vec<u8>, out: &mut TrieNodes) {
    if child.len() < 32 {
        payload.extend_from_slice(&child);
    } else {
        let hash = keccak256(&child);
        out.nodes.push((hash, child.len() as u64));
        push_string(payload, hash.as_slice());
    }
}

/// The RLP of the node holding `leaves` (sorted, distinct, sharing their first `depth`
/// nibbles); its stored descendants go to `out`.
fn node(leaves: &[(Vec<u8>, &[u8])], depth: usize, out: &mut TrieNodes) -> Vec<u8> {
    let (first, last) = (&leaves[0].0, &leaves[leaves.len() - 1].0);
    if leaves.len() == 1 {
        let mut payload = Vec::new();
        push_string(&mut payload, &hex_prefix(&first[depth..], true));
        push_string(&mut payload, leaves[0].1);
        return wrap_list(payload);
    }
    // Sorted keys: the common prefix of all is that of the first and the last.
    let shared = (depth..first.len())
        .take_while(|&i| first[i] == last[i])
        .count();
    if shared > 0 {
        let mut payload = Vec::new();
        push_string(
            &mut payload,
            &hex_prefix(&first[depth..depth + shared], false),
        );
        let child = branch(leaves, depth + shared, out);
        child_ref(child, &mut payload, out);
        return wrap_list(payload);
    }
    branch(leaves, depth, out)
}

fn branch(leaves: &[(Vec<u8>, &[u8])], depth: usize, out: &mut TrieNodes) -> Vec<u8> {
    let mut payload = Vec::new();
    let mut start = 0;
    for nibble in 0..16u8 {
        let end = start + leaves[start..].partition_point(|(k, _)| k[depth] == nibble);
        if end == start {
            payload.push(0x80);
        } else {
            let child = node(&leaves[start..end], depth + 1, out);
            child_ref(child, &mut payload, out);
        }
        start = end;
    }
    assert_eq!(start, leaves.len(), "every leaf under one of 16 nibbles");
    payload.push(0x80); // No value at a branch: the keys have one length.
    wrap_list(payload)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(name: &str, got: u64, want: u64) {
        assert_eq!(got, want, "{name}");
    }

    #[test]
    fn a_sealed_header_has_the_hand_computed_length() {
        // Six 32-byte hashes (parent, uncles, state, transactions, receipts, mix digest) at
        // 33 bytes each: 198; the coinbase 21; the bloom 3 + 256; difficulty 2: 1; number 5:
        // 1; the gas limit 0x9000000000000 (7 bytes): 8; gas used 0: 1 (0x80); time
        // 1,620,000,010 (4 bytes): 5; extra 97 bytes: 2 + 97; nonce 9. Payload 602, and a
        // 3-byte list header (0xf9 and two length bytes).
        let h = Header::sealed(5, 2, GENESIS_GAS_LIMIT, 0, GENESIS_UNIX_S + 10);
        check("sealed header", h.rlp_bytes(), 605);
        // Gas used 15,532,716 (3 bytes) takes 4 instead of 1; height 300 (2 bytes) takes 3.
        let h = Header::sealed(300, 1, GENESIS_GAS_LIMIT, 15_532_716, GENESIS_UNIX_S);
        check("busy header", h.rlp_bytes(), 605 + 3 + 2);
        // Genesis: 15 signers make the extra data 397 bytes, 3 + 397 instead of 2 + 97.
        check(
            "genesis header",
            Header::genesis(15, GENESIS_UNIX_S).rlp_bytes(),
            605 + 301,
        );
    }

    #[test]
    fn a_submission_transaction_has_the_hand_computed_length() {
        let weights = vec![-5i64; 2848];
        let data = authors_submission_calldata(200, &weights);
        // 4-byte selector, nbSamples, 2848 weights: 4 + 32 * 2849.
        check("calldata", data.len() as u64, 91_172);
        // The first weight's word: -5 sign-extended, 31 bytes of 0xff then 0xfb.
        assert_eq!(&data[36..67], &[0xff; 31][..], "sign extension");
        assert_eq!(data[67], 0xfb, "-5");
        // nonce 3: 1; gas price 10^9 (4 bytes): 5; gas 15,532,716 (3 bytes): 4; to: 21;
        // value 5 ether = 5 * 10^18 (8 bytes): 9; data: 91,172 + 4 (0xba, 3 length bytes);
        // v = 3065 (2 bytes): 3; r, s: 33 each. Payload 91,285, list header 4 bytes.
        let value = 5 * u128::from(WEI_PER_UNIT) * 1_000_000_000;
        check(
            "submission",
            legacy_tx_bytes(3, 15_532_716, value, &data),
            91_289,
        );
        // Nonce 0 and gas 0 encode as one byte each (0x80): the gas 3 bytes less.
        check("zeros", legacy_tx_bytes(0, 0, value, &data), 91_289 - 3);
    }

    #[test]
    fn receipts_have_the_hand_computed_length() {
        // Status 0x01: 1; cumulative gas 15,532,716: 4; no log: 1 (0xc0). Payload 6.
        check("stored", stored_receipt_bytes(true, 15_532_716, &[]), 7);
        // The consensus form adds the bloom (3 + 256): payload 265, header 3.
        check(
            "consensus",
            consensus_receipt_bytes(true, 15_532_716, &[]),
            268,
        );
        // One log of one topic and 128 bytes of data (Paid: four words): address 21, topics
        // [33] 34, data 2 + 128: payload 185, header 2: 187; the log list 2 + 187. The
        // receipt's payload 1 + 4 + 189 = 194, its header 2.
        let log = Log::new_unchecked(Address::ZERO, vec![B256::ZERO], Bytes::from(vec![7; 128]));
        check(
            "with a log",
            stored_receipt_bytes(true, 15_532_716, std::slice::from_ref(&log)),
            2 + 194,
        );
        // A failed status is the empty string (one byte).
        check("failed", stored_receipt_bytes(false, 0, &[]), 4);
    }

    #[test]
    fn a_body_and_a_receipt_list_wrap_their_items() {
        check("empty body", body_bytes(&[]), 3); // [[], []]: c2 c0 c0.
        check("one tx", body_bytes(&[91_290]), 1 + 3 + 4 + 91_290 + 1);
        check("receipts", receipts_bytes(&[7, 7]), 15);
    }

    #[test]
    fn gas_limit_moves_a_1024th_toward_the_target() {
        let l = GENESIS_GAS_LIMIT;
        check("decay", next_gas_limit(l, 0), l - (l / 1024 - 1));
        check("floor", next_gas_limit(8_000_000, 0), 8_000_000);
        check(
            "raise",
            next_gas_limit(5_000_000, 0),
            5_000_000 + 5_000_000 / 1024 - 1,
        );
    }

    #[test]
    fn a_one_entry_trie_is_one_leaf() {
        // One slot, value 1: the leaf [hp(64 nibbles) = 0x20 + 32 bytes, rlp(0x01)]: the path
        // 33 bytes + 1 header, the value string 0x01 as a one-byte string: 34 + 1 = 35,
        // header 1: 36 bytes, stored (the root always is) under 32 bytes of key.
        let trie = secure_trie(&[(vec![0; 32], slot_value(U256::from(1)))]);
        check("nodes", trie.nodes.len() as u64, 1);
        check("leaf", trie.nodes[0].1, 36);
        check("entries", trie.entry_bytes(), 68);
        assert_eq!(
            trie.root,
            keccak256(hex_leaf_for_test()),
            "root is the leaf's hash"
        );
    }

    fn hex_leaf_for_test() -> Vec<u8> {
        let key = nibbles(keccak256([0u8; 32]).as_slice());
        let mut payload = Vec::new();
        push_string(&mut payload, &hex_prefix(&key, true));
        push_string(&mut payload, &[0x01]);
        wrap_list(payload)
    }

    /// go-ethereum's own vectors (`trie/stacktrie_test.go`, `TestStackTrieInsertAndHash`):
    /// keys of one length, the root after each insertion.
    #[test]
    fn trie_roots_match_go_ethereum() {
        assert_eq!(
            secure_trie(&[]).root,
            revm::primitives::b256!(
                "56e81f171bcc55a6ff8345e692c0f86e5b48e01b996cadc001622fb5e363b421"
            ),
            "the empty root"
        );
        let groups: [&[(&str, &str, &str)]; 3] = [
            &[
                (
                    "00",
                    "v_______________________0___0",
                    "5cb26357b95bb9af08475be00243ceb68ade0b66b5cd816b0c18a18c612d2d21",
                ),
                (
                    "70",
                    "v_______________________0___1",
                    "8ff64309574f7a437a7ad1628e690eb7663cfde10676f8a904a8c8291dbc1603",
                ),
                (
                    "f0",
                    "v_______________________0___2",
                    "9e3a01bd8d43efb8e9d4b5506648150b8e3ed1caea596f84ee28e01a72635470",
                ),
            ],
            &[
                (
                    "10cc",
                    "v_______________________1___0",
                    "233e9b257843f3dfdb1cce6676cdaf9e595ac96ee1b55031434d852bc7ac9185",
                ),
                (
                    "e1fc",
                    "v_______________________1___1",
                    "39c5e908ae83d0c78520c7c7bda0b3782daf594700e44546e93def8f049cca95",
                ),
                (
                    "eefc",
                    "v_______________________1___2",
                    "d789567559fd76fe5b7d9cc42f3750f942502ac1c7f2a466e2f690ec4b6c2a7c",
                ),
            ],
            &[
                (
                    "88001f",
                    "v_______________________5___0",
                    "e817db50d84f341d443c6f6593cafda093fc85e773a762421d47daa6ac993bd5",
                ),
                (
                    "88002e",
                    "v_______________________5___1",
                    "d6e3e6047bdc110edd296a4d63c030aec451bee9d8075bc5a198eee8cda34f68",
                ),
                (
                    "88003d",
                    "v_______________________5___2",
                    "b6bdf8298c703342188e5f7f84921a402042d0e5fb059969dd53a6b6b1fb989e",
                ),
            ],
        ];
        for group in groups {
            let mut leaves = Vec::new();
            for &(key, value, root) in group {
                let key = super::super::abi::from_hex(key).expect("hex");
                leaves.push((nibbles(&key), value.as_bytes()));
                let want: B256 = root.parse().expect("a hash");
                assert_eq!(trie(leaves.clone()).root, want, "after {key:?}");
            }
        }
    }

    #[test]
    fn a_two_entry_trie_has_a_branch_and_embeds_nothing() {
        let entries: Vec<(Vec<u8>, Vec<u8>)> = (0..2u8)
            .map(|i| (vec![i; 32], slot_value(U256::from(1000))))
            .collect();
        let trie = secure_trie(&entries);
        // Two leaves of 63 nibbles (hp 32 bytes + 1, value rlp(0x03e8) = 82 03 e8 as a
        // string: 4) each 37 + 1 = 38 bytes, >= 32 so stored by hash; the root a branch
        // (unless the two hashes share a first nibble, then an extension over it).
        let leaves: Vec<u64> = trie
            .nodes
            .iter()
            .map(|n| n.1)
            .filter(|&l| l == 38)
            .collect();
        check("leaves", leaves.len() as u64, 2);
        // The branch: 2 hashes of 33, 14 empty slots and the value, 15 bytes: 81, header 2.
        check("branch", trie.nodes.last().expect("a root").1, 83);
    }

    #[test]
    fn a_known_node_is_not_written_twice() {
        let a = secure_trie(&[(vec![1], vec![0x01])]);
        let mut seen = BTreeSet::new();
        let first = a.new_bytes(&mut seen);
        check("first", first, a.entry_bytes());
        check("again", a.new_bytes(&mut seen), 0);
    }

    #[test]
    fn slot_values_drop_leading_zeros() {
        assert_eq!(slot_value(U256::from(1)), vec![0x01]);
        assert_eq!(slot_value(U256::from(0x1234)), vec![0x82, 0x12, 0x34]);
        check("max", slot_value(U256::MAX).len() as u64, 33);
    }

    #[test]
    fn slim_accounts_drop_the_empty_root_and_code() {
        let eoa = Account {
            nonce: 0,
            balance: U256::from(1),
            storage_root: empty_root(),
            code_hash: empty_code_hash(),
        };
        // [0x80, 0x01, 0x80, 0x80]: 4 bytes and a 1-byte header.
        check("slim eoa", eoa.slim_bytes(), 5);
        // Full: 0x80, 0x01, 33, 33 = 68, header 2.
        check("full eoa", eoa.rlp().len() as u64, 70);
    }
}
