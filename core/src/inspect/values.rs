//! The values a predicate reads at each block of the final canonical chain (an
//! [`expr::Env`](super::expr::Env)).

use std::cell::RefCell;
use std::collections::BTreeMap;

use super::expr::{self, EvalError};
use super::index::RunIndex;
use crate::contract::Verdict;
use crate::learn::{self, ModelShape, TrainData};

impl RunIndex {
    /// The values of every block of the final canonical chain, for predicates.
    pub fn values(&self) -> ChainValues<'_> {
        let rounds = self.rounds();
        let mut loss_at = Vec::with_capacity(self.chain.len());
        let mut next = 0;
        let mut loss = f64::NAN;
        for row in &self.chain {
            while next < rounds.len() && rounds[next].block <= row.height {
                loss = rounds[next].loss;
                next += 1;
            }
            loss_at.push(loss);
        }
        ChainValues {
            index: self,
            loss_at,
            shape: ModelShape::from_config(&self.config),
            heldout: TrainData::new(
                &ModelShape::from_config(&self.config),
                self.final_state.world.heldout(),
            )
            .ok()
            .filter(|d| !d.is_empty()),
            heldout_cache: RefCell::new(BTreeMap::new()),
        }
    }
}

/// Per-block values of the final canonical chain (see [`expr::IDENTS`]).
pub struct ChainValues<'a> {
    pub(super) index: &'a RunIndex,
    loss_at: Vec<f64>,
    shape: ModelShape,
    heldout: Option<TrainData>,
    heldout_cache: RefCell<BTreeMap<u64, f64>>,
}

impl ChainValues<'_> {
    /// The values at block `height` (an [`expr::Env`]).
    pub fn at(&self, height: u64) -> BlockValues<'_> {
        assert!(height <= self.index.last_height(), "height on the chain");
        BlockValues {
            values: self,
            height,
        }
    }

    /// Number of blocks (genesis included).
    pub fn len(&self) -> usize {
        self.index.chain.len()
    }

    /// Never true: a chain has its genesis.
    pub fn is_empty(&self) -> bool {
        self.index.chain.is_empty()
    }
}

/// The values at one block: an [`expr::Env`].
pub struct BlockValues<'a> {
    values: &'a ChainValues<'a>,
    height: u64,
}

impl expr::Env for BlockValues<'_> {
    fn ident(&self, name: &str) -> Result<f64, EvalError> {
        let index = self.values.index;
        let row = &index.chain[self.height as usize];
        let state = index.contract_at(self.height);
        let group = |byz: bool| -> (f64, usize) {
            let units: Vec<u64> = state
                .balances
                .iter()
                .zip(&index.byzantine)
                .filter(|(_, &b)| b == byz)
                .map(|(&u, _)| u)
                .collect();
            (index.tokens(units.iter().sum()), units.len())
        };
        let mean = |(sum, n): (f64, usize)| if n == 0 { f64::NAN } else { sum / n as f64 };
        // Balance plus the stakes the group has in the current round (still in the pool).
        let wealth = |byz: bool| -> f64 {
            let staked: u64 = state
                .submissions
                .iter()
                .filter(|s| index.byzantine.get(s.sender as usize) == Some(&byz))
                .map(|s| s.stake_units)
                .sum();
            let (sum, n) = group(byz);
            if n == 0 {
                f64::NAN
            } else {
                (sum + index.tokens(staked)) / n as f64
            }
        };
        Ok(match name {
            "height" => row.height as f64,
            "time" => row.time.secs(),
            "round" => state.round as f64,
            "loss" => self.values.loss_at[self.height as usize],
            "heldout_loss" => {
                let mut cache = self.values.heldout_cache.borrow_mut();
                *cache
                    .entry(state.round)
                    .or_insert_with(|| match &self.values.heldout {
                        Some(data) => learn::loss(
                            &self.values.shape,
                            &learn::from_fixed(&state.weights, index.config.contract.weight_scale),
                            data,
                        ),
                        None => f64::NAN,
                    })
            }
            "byzantine_tokens" => mean(group(true)),
            "honest_tokens" => mean(group(false)),
            "byzantine_wealth" => wealth(true),
            "honest_wealth" => wealth(false),
            "byzantine_sum" => group(true).0,
            "honest_sum" => group(false).0,
            "byzantine_share" => crate::metrics::byzantine_share(&state.balances, &index.byzantine),
            "accepted" => state.accepted_count() as f64,
            "outliers" => state
                .submissions
                .iter()
                .filter(|s| s.verdict == Verdict::Outlier)
                .count() as f64,
            "pool" => index.tokens(state.holdings_units),
            "robots" => index.config.world.robots as f64,
            other => return Err(EvalError(format!("unknown identifier `{other}`"))),
        })
    }

    fn indexed(&self, name: &str, i: u32) -> Result<f64, EvalError> {
        let index = self.values.index;
        let state = index.contract_at(self.height);
        match name {
            "balance" => state
                .balances
                .get(i as usize)
                .map(|&u| index.tokens(u))
                .ok_or_else(|| no_robot(name, i, index.config.world.robots)),
            other => Err(EvalError(format!("`{other}` cannot be indexed"))),
        }
    }

    fn node(&self, i: u32, field: &str) -> Result<f64, EvalError> {
        let index = self.values.index;
        let row = &index.chain[self.height as usize];
        match field {
            "height" => row
                .node_heights
                .get(i as usize)
                .map(|&h| h as f64)
                .ok_or_else(|| no_robot("node", i, index.config.world.robots)),
            other => Err(EvalError(format!("node[{i}] has no field `{other}`"))),
        }
    }
}

fn no_robot(name: &str, i: u32, robots: u32) -> EvalError {
    EvalError(format!(
        "{name}[{i}]: there is no robot {i}, the swarm has robots 0 to {}",
        robots.saturating_sub(1)
    ))
}
