//! The few pieces of the Solidity ABI the binding needs: selectors, event topics, head/tail
//! encoding of static words and dynamic arrays of static values, and decoding of the same.

use revm::primitives::{keccak256, Address, B256, U256};

/// The 4-byte selector of a function signature, as the start of a call's data.
pub fn selector(signature: &str) -> Vec<u8> {
    keccak256(signature.as_bytes())[..4].to_vec()
}

/// The first topic of an event.
pub fn event_topic(signature: &str) -> B256 {
    keccak256(signature.as_bytes())
}

/// Hex (no prefix) to bytes.
pub fn from_hex(hex: &str) -> Option<Vec<u8>> {
    if !hex.len().is_multiple_of(2) {
        return None;
    }
    (0..hex.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(hex.get(i..i + 2)?, 16).ok())
        .collect()
}

/// One argument: a static word or a dynamic array of static words.
enum Arg {
    Word([u8; 32]),
    Array(Vec<[u8; 32]>),
}

/// Encodes a call's arguments (head, then the tails of the dynamic ones).
#[derive(Default)]
pub struct Encoder {
    args: Vec<Arg>,
}

fn uint_word(x: u128) -> [u8; 32] {
    let mut w = [0u8; 32];
    w[16..].copy_from_slice(&x.to_be_bytes());
    w
}

fn int_word(x: i64) -> [u8; 32] {
    let mut w = if x < 0 { [0xff; 32] } else { [0u8; 32] };
    w[24..].copy_from_slice(&x.to_be_bytes());
    w
}

fn address_word(a: Address) -> [u8; 32] {
    let mut w = [0u8; 32];
    w[12..].copy_from_slice(a.as_slice());
    w
}

impl Encoder {
    /// An unsigned integer (or a bool as 0/1).
    pub fn uint(&mut self, x: u128) {
        self.args.push(Arg::Word(uint_word(x)));
    }

    /// An address.
    pub fn address(&mut self, a: Address) {
        self.args.push(Arg::Word(address_word(a)));
    }

    /// An `int64[]`.
    pub fn int_array(&mut self, xs: &[i64]) {
        self.args
            .push(Arg::Array(xs.iter().map(|&x| int_word(x)).collect()));
    }

    /// A fixed-size `int<N>[len]` (N <= 64): its words in place, no offset or length.
    pub fn int_words(&mut self, xs: &[i64]) {
        self.args.extend(xs.iter().map(|&x| Arg::Word(int_word(x))));
    }

    /// An `address[]`.
    pub fn address_array(&mut self, xs: &[Address]) {
        self.args
            .push(Arg::Array(xs.iter().map(|&a| address_word(a)).collect()));
    }

    /// The encoded arguments.
    pub fn finish(self) -> Vec<u8> {
        let head_len = 32 * self.args.len();
        let mut head = Vec::with_capacity(head_len);
        let mut tail = Vec::new();
        for arg in &self.args {
            match arg {
                Arg::Word(w) => head.extend_from_slice(w),
                Arg::Array(items) => {
                    head.extend_from_slice(&uint_word((head_len + tail.len()) as u128));
                    tail.extend_from_slice(&uint_word(items.len() as u128));
                    for w in items {
                        tail.extend_from_slice(w);
                    }
                }
            }
        }
        head.extend_from_slice(&tail);
        head
    }
}

/// Reads ABI-encoded return data. The data comes from our own contract, so a malformed
/// encoding is a bug and panics with what was expected.
pub struct Decoder<'a> {
    data: &'a [u8],
}

impl<'a> Decoder<'a> {
    /// Decodes `data`.
    pub fn new(data: &'a [u8]) -> Decoder<'a> {
        Decoder { data }
    }

    fn word_at(&self, offset: usize) -> U256 {
        let bytes = self
            .data
            .get(offset..offset + 32)
            .unwrap_or_else(|| panic!("return data too short for a word at byte {offset}"));
        U256::from_be_slice(bytes)
    }

    /// The `i`-th head word.
    pub fn word(&self, i: usize) -> U256 {
        self.word_at(32 * i)
    }

    fn offset(&self, head: usize) -> usize {
        usize::try_from(self.word(head)).expect("an ABI offset fits usize")
    }

    /// The dynamic array of static words whose offset is head word `head`.
    pub fn uint_array(&self, head: usize) -> Vec<U256> {
        let at = self.offset(head);
        let len = usize::try_from(self.word_at(at)).expect("an ABI length fits usize");
        (0..len).map(|i| self.word_at(at + 32 * (i + 1))).collect()
    }

    /// The dynamic array of static structs of `fields` words whose offset is head word `head`.
    pub fn struct_array(&self, head: usize, fields: usize) -> Vec<Vec<U256>> {
        let at = self.offset(head);
        let len = usize::try_from(self.word_at(at)).expect("an ABI length fits usize");
        (0..len)
            .map(|i| {
                (0..fields)
                    .map(|f| self.word_at(at + 32 * (1 + i * fields + f)))
                    .collect()
            })
            .collect()
    }
}
