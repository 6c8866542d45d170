//! The viewer's sampled frames ([`Frames`]): poses, radio links, heads, foragers and items.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use swarmfl_core::config::{Aggregation, Behaviour, MixedAssign};
use swarmfl_core::inspect;
use swarmfl_core::state::State;
use swarmfl_core::world::{Behaviours, Forager, World};
use swarmfl_core::Digest;

/// The sampled frames, each field already JSON text.
#[derive(Default)]
pub(super) struct Frames {
    /// The block (and its height) of a frame taken at its sealing; `None` for a uniform one.
    pub(super) block: Vec<Option<(Digest, u64)>>,
    pub(super) t: Vec<u64>,
    pub(super) pose: Vec<String>,
    pub(super) links: Vec<String>,
    pub(super) heads: Vec<String>,
    /// Each robot's forager state as one letter (see [`forager_letter`]); empty text when
    /// nobody forages.
    pub(super) forager: Vec<String>,
    /// Flow-FL's items on the floor (`world.foraging.rule = "flowfl"`), `[x, y, ...]` in
    /// millimetres in item order (carried ones left out); `null` under any other rule. The
    /// page's data lists each change once ([`items_json`](super::data::items_json)).
    pub(super) items: Vec<String>,
    /// Each robot's behaviour at the frame as one letter (`a` avoidance, `f` flocking, `o`
    /// foraging) when behaviours follow places (`world.mixed.assign = "place"`); empty text
    /// when each robot keeps one behaviour (the page's `behaviour` then holds it).
    pub(super) of: Vec<String>,
    /// A baseline's model version of each robot (`gossip`: the merges it made; `central`: the
    /// server's round it holds); `null` for a chain run.
    pub(super) versions: Vec<String>,
}

impl Frames {
    /// The frames the page shows, in the order taken: every uniform one, and those taken at
    /// the sealing of a block of the final canonical chain of `index`.
    pub(super) fn shown(&self, index: &inspect::RunIndex) -> Vec<usize> {
        let canonical: BTreeMap<Digest, u64> =
            index.chain.iter().map(|r| (r.hash, r.height)).collect();
        (0..self.t.len())
            .filter(|&k| match &self.block[k] {
                None => true,
                Some((hash, height)) => canonical.get(hash) == Some(height),
            })
            .collect()
    }

    /// Adds the frame of `state` at `time_ms`: poses, links and every node's head block;
    /// `block` is the block (and height) whose sealing it shows, if any.
    pub(super) fn push(
        &mut self,
        state: &State,
        ids: &BTreeMap<Digest, u32>,
        time_ms: u64,
        block: Option<(Digest, u64)>,
    ) {
        let n = state.world.poses().len();
        let heads: Vec<String> = (0..n as u32)
            .map(|r| {
                let h = state.ledger.head(r).0;
                ids.get(&h).map_or("0".to_string(), |id| id.to_string())
            })
            .collect();
        let versions = if state.aggregation.kind() == Aggregation::Chain {
            "null".to_string()
        } else {
            let v: Vec<String> = (0..n as u32)
                .map(|r| state.aggregation.current(r).round.to_string())
                .collect();
            format!("[{}]", v.join(","))
        };
        self.push_world(
            &state.world,
            time_ms,
            block,
            format!("[{}]", heads.join(",")),
            versions,
        );
    }

    /// Adds the frame of `world` at `time_ms` with every node's head block (`heads`, JSON) and
    /// a baseline's model versions (`versions`, JSON); `block` as in [`Frames::push`].
    pub(super) fn push_world(
        &mut self,
        world: &World,
        time_ms: u64,
        block: Option<(Digest, u64)>,
        heads: String,
        versions: String,
    ) {
        let n = world.poses().len();
        self.block.push(block);
        self.t.push(time_ms);
        let mut pose = String::from("[");
        for (i, p) in world.poses().iter().enumerate() {
            let deg = p.theta.to_degrees().rem_euclid(360.0).round() as i64 % 360;
            let _ = write!(
                pose,
                "{}{},{},{deg}",
                if i == 0 { "" } else { "," },
                (p.x * 1000.0).round() as i64,
                (p.y * 1000.0).round() as i64
            );
        }
        pose.push(']');
        self.pose.push(pose);
        // Links as a bit set over the pairs (i < j) in row order, in hex.
        let pairs = n * n.saturating_sub(1) / 2;
        let mut bits = vec![0u8; pairs.div_ceil(4)];
        for (i, j) in world.links() {
            let (i, j) = (i.min(j) as usize, i.max(j) as usize);
            if i == j || j >= n {
                continue;
            }
            let k = i * (2 * n - i - 1) / 2 + (j - i - 1);
            bits[k / 4] |= 1 << (k % 4);
        }
        let hex: String = bits
            .iter()
            .map(|&b| char::from_digit(u32::from(b), 16).expect("a nibble"))
            .collect();
        self.links.push(format!("\"{hex}\""));
        self.heads.push(heads);
        let behaviours = world
            .behaviours()
            .filter(|b| b.nest.is_some() || b.flowfl.is_some());
        let forager: String = match behaviours {
            Some(b) => (0..n).map(|i| forager_letter(b, i)).collect(),
            None => String::new(),
        };
        self.forager.push(format!("\"{forager}\""));
        // Flow-FL's items move (taken, carried, re-placed on delivery): each frame has its own.
        let items = match behaviours.and_then(|b| b.flowfl.as_ref()) {
            Some(f) => {
                let mut items = String::from("[");
                for (k, &(x, y)) in f.items.iter().flatten().enumerate() {
                    let _ = write!(
                        items,
                        "{}{},{}",
                        if k == 0 { "" } else { "," },
                        (x * 1000.0).round() as i64,
                        (y * 1000.0).round() as i64
                    );
                }
                items.push(']');
                items
            }
            None => "null".to_string(),
        };
        self.items.push(items);
        let of: String = match world
            .behaviours()
            .filter(|b| b.assign == MixedAssign::Place)
        {
            Some(b) => {
                b.of.iter()
                    .map(|&x| match x {
                        Behaviour::Avoidance | Behaviour::Mixed => 'a',
                        Behaviour::Flocking => 'f',
                        Behaviour::Foraging => 'o',
                    })
                    .collect()
            }
            None => String::new(),
        };
        self.of.push(format!("\"{of}\""));
        self.versions.push(versions);
    }
}

/// Robot `i`'s forager state as one letter: `e` explore, `r` return, `s` rest, `-` not a
/// forager. Under the `simple` rule a returning forager carries food and no other does; under
/// Flow-FL's a forager also returns from a fruitless trip, so there the letter of one that
/// carries an item is upper case (`E`, `R`, `S`) and a lower-case `r` returns empty-handed.
pub(super) fn forager_letter(b: &Behaviours, i: usize) -> char {
    let letter = match (b.of[i], b.foragers[i]) {
        (Behaviour::Foraging, Forager::Explore) => 'e',
        (Behaviour::Foraging, Forager::Return) => 'r',
        (Behaviour::Foraging, Forager::Rest { .. }) => 's',
        _ => return '-',
    };
    match &b.flowfl {
        Some(f) if f.robots[i].item.is_some() => letter.to_ascii_uppercase(),
        _ => letter,
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn link_bits_number_the_pairs_in_row_order() {
        // The page decodes pair k of robots i < j with the same formula.
        let n = 5usize;
        let mut k_expected = 0;
        for i in 0..n {
            for j in i + 1..n {
                assert_eq!(i * (2 * n - i - 1) / 2 + (j - i - 1), k_expected);
                k_expected += 1;
            }
        }
        assert_eq!(k_expected, n * (n - 1) / 2);
        let html = super::super::TEMPLATE;
        assert!(html.contains("__DATA__") && html.contains("id=\"status\""));
        assert!(
            !html.contains("http://") && !html.contains("https://"),
            "no network"
        );
    }
}
