//! Position heterogeneity (`world.position_heterogeneity` in `summary.json`, issue #55): how
//! much the robots' training data differ in *position*, which is the trajectory model's input
//! and target. At each of a robot's learning phases the driver counts the waypoints of the
//! samples in the robot's training split (the first `floor(n * learn.train_fraction)` of its
//! data set, `learn::split_point`) per cell of a fixed grid over the arena; a round `k` is
//! every robot's `k`-th phase (all fall within one training period). Per round, the robots x
//! cells table gives
//! - the bias-corrected Cramer's V (Bergsma 2013; [`crate::data::cramers_v`]), and
//! - the generalised Jensen-Shannon divergence of the robots' cell distributions against
//!   their equal-weight mixture, in bits, over its largest value `log2 min(robots, cells)`
//!   ([`js_divergence`]), so 0 for identical distributions and 1 for disjoint ones;
//!
//! the summary holds their means over the rounds, the last round's, and both on the table
//! summed over the run. Counting reads the state and writes only the tally, which is
//! driver-side and outside every digest: it moves no record.
//!
//! The grid is the home ranges' regions grid (`world.home_range.regions`, a square, 3 x 3 by
//! default), fixed whatever `alpha`: it is the scale at which the knob confines robots, and a
//! finer grid would leave a few hundred samples per robot and training spread over more cells,
//! where the plug-in Jensen-Shannon divergence is biased upward by finite counts.

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

use crate::data::{self, Sample};

/// The measure of `summary.json`'s `world.position_heterogeneity` (see the module's doc).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PositionHeterogeneity {
    /// Bias-corrected Cramer's V of robots x position cells, mean over the rounds.
    pub cramers_v: f64,
    /// Normalised generalised Jensen-Shannon divergence, mean over the rounds.
    pub js_divergence: f64,
    /// Cramer's V of the last round measured.
    pub final_cramers_v: f64,
    /// Jensen-Shannon divergence of the last round measured.
    pub final_js_divergence: f64,
    /// Cramer's V of the table summed over every training of the run.
    pub run_cramers_v: f64,
    /// Jensen-Shannon divergence of the table summed over every training of the run.
    pub run_js_divergence: f64,
    /// Rounds measured: those where at least two robots held training data.
    pub rounds: u64,
    /// Trainings counted: (robot, phase) pairs whose training split held waypoints.
    pub trainings: u64,
    /// Cells of the grid.
    pub cells: u32,
}

/// The counts behind [`PositionHeterogeneity`], kept by the driver.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PositionTally {
    side: usize,
    half_m: f64,
    cell_m: f64,
    robots: usize,
    /// Per round: robot-major counts (`robot * cells + cell`).
    rounds: Vec<Vec<u64>>,
    trainings: u64,
}

impl PositionTally {
    /// A tally over a `side` x `side` grid on an arena of side `arena_side_m` centred on the
    /// origin, for `robots` robots.
    pub fn new(side: u32, arena_side_m: f64, robots: u32) -> PositionTally {
        let side = side.max(1) as usize;
        PositionTally {
            side,
            half_m: 0.5 * arena_side_m,
            cell_m: arena_side_m / side as f64,
            robots: robots as usize,
            rounds: Vec::new(),
            trainings: 0,
        }
    }

    fn cells(&self) -> usize {
        self.side * self.side
    }

    /// The cell of a coordinate (a point on or beyond a wall counts in the border cell).
    fn index(&self, v: f32) -> usize {
        let k = ((f64::from(v) + self.half_m) / self.cell_m).floor();
        if k.is_nan() || k < 0.0 {
            0
        } else {
            (k as usize).min(self.side - 1)
        }
    }

    /// Counts the waypoints of `robot`'s training split at its phase `phase`: the first
    /// `train` samples of `set`.
    pub fn count(&mut self, robot: usize, phase: u64, set: &VecDeque<Sample>, train: usize) {
        if robot >= self.robots {
            return;
        }
        let cells = self.cells();
        let phase = phase as usize;
        while self.rounds.len() <= phase {
            self.rounds.push(vec![0; self.robots * cells]);
        }
        let mut row = vec![0u64; cells];
        let mut any = false;
        for s in set.iter().take(train) {
            for p in &s.points {
                row[self.index(p[1]) * self.side + self.index(p[0])] += 1;
                any = true;
            }
        }
        for (t, c) in self.rounds[phase][robot * cells..(robot + 1) * cells]
            .iter_mut()
            .zip(row)
        {
            *t += c;
        }
        self.trainings += u64::from(any);
    }

    /// The measure of the counts so far.
    pub fn measure(&self) -> PositionHeterogeneity {
        let cells = self.cells();
        let mut out = PositionHeterogeneity {
            trainings: self.trainings,
            cells: cells as u32,
            ..PositionHeterogeneity::default()
        };
        let mut summed = vec![0u64; self.robots * cells];
        let (mut v_sum, mut js_sum) = (0.0, 0.0);
        for round in &self.rounds {
            for (s, &c) in summed.iter_mut().zip(round) {
                *s += c;
            }
            let rows: Vec<&[u64]> = round.chunks(cells).collect();
            if rows.iter().filter(|r| r.iter().any(|&c| c > 0)).count() < 2 {
                continue;
            }
            out.rounds += 1;
            out.final_cramers_v = data::cramers_v(&rows);
            out.final_js_divergence = js_divergence(&rows);
            v_sum += out.final_cramers_v;
            js_sum += out.final_js_divergence;
        }
        if out.rounds > 0 {
            out.cramers_v = v_sum / out.rounds as f64;
            out.js_divergence = js_sum / out.rounds as f64;
        }
        let rows: Vec<&[u64]> = summed.chunks(cells).collect();
        out.run_cramers_v = data::cramers_v(&rows);
        out.run_js_divergence = js_divergence(&rows);
        out
    }
}

/// The generalised Jensen-Shannon divergence of the rows' distributions (each row's counts
/// over its total; rows without counts left out) against their equal-weight mixture:
/// `H(mixture) - mean H(row)` in bits, over `log2 min(rows, columns)`, its largest value
/// (the mixture's entropy is at most `log2 columns`, and the divergence at most `log2 rows`).
/// In [0, 1]: 0 when every row has the same distribution, 1 when the rows are disjoint and
/// (with more rows than columns) spread evenly over the columns. 0 with fewer than two rows
/// or one column. Sums in row then column order.
pub fn js_divergence(table: &[&[u64]]) -> f64 {
    let rows: Vec<&[u64]> = table
        .iter()
        .copied()
        .filter(|r| r.iter().any(|&c| c > 0))
        .collect();
    let width = rows.iter().map(|r| r.len()).max().unwrap_or(0);
    if rows.len() < 2 || width < 2 {
        return 0.0;
    }
    let entropy = |p: &[f64]| -> f64 {
        p.iter()
            .filter(|&&q| q > 0.0)
            .map(|&q| -q * q.log2())
            .sum::<f64>()
    };
    let k = rows.len() as f64;
    let mut mixture = vec![0.0; width];
    let mut mean_entropy = 0.0;
    for r in &rows {
        let total = r.iter().sum::<u64>() as f64;
        let p: Vec<f64> = r.iter().map(|&c| c as f64 / total).collect();
        for (m, q) in mixture.iter_mut().zip(&p) {
            *m += q / k;
        }
        mean_entropy += entropy(&p) / k;
    }
    let top = (rows.len().min(width) as f64).log2();
    ((entropy(&mixture) - mean_entropy) / top).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(points: &[[f32; 2]]) -> Sample {
        Sample {
            time: crate::types::SimTime(0),
            points: points.to_vec(),
        }
    }

    #[test]
    fn identical_distributions_measure_about_zero_and_disjoint_ones_about_one() {
        let same: Vec<Vec<u64>> = (0..6).map(|_| vec![50, 30, 20, 0]).collect();
        let rows: Vec<&[u64]> = same.iter().map(|r| &r[..]).collect();
        assert!(data::cramers_v(&rows) < 1e-9);
        assert!(js_divergence(&rows) < 1e-12);
        // Disjoint: robot i only in cell i.
        let apart: Vec<Vec<u64>> = (0..4)
            .map(|i| (0..4).map(|c| if c == i { 80 } else { 0 }).collect())
            .collect();
        let rows: Vec<&[u64]> = apart.iter().map(|r| &r[..]).collect();
        assert!(data::cramers_v(&rows) > 0.99, "{}", data::cramers_v(&rows));
        assert!((js_divergence(&rows) - 1.0).abs() < 1e-12);
        // More robots than cells, each in one cell, spread evenly: still 1.
        let many: Vec<Vec<u64>> = (0..8)
            .map(|i| (0..4).map(|c| if c == i % 4 { 40 } else { 0 }).collect())
            .collect();
        let rows: Vec<&[u64]> = many.iter().map(|r| &r[..]).collect();
        assert!((js_divergence(&rows) - 1.0).abs() < 1e-12);
        // In between: half overlapping.
        let half = [vec![50u64, 50, 0], vec![0, 50, 50]];
        let rows: Vec<&[u64]> = half.iter().map(|r| &r[..]).collect();
        let js = js_divergence(&rows);
        assert!(js > 0.2 && js < 0.8, "{js}");
    }

    #[test]
    fn the_tally_counts_training_points_per_cell_and_round() {
        // A 2 x 2 grid on a 4 m arena: cells of 2 m, x then y.
        let mut t = PositionTally::new(2, 4.0, 2);
        let west: VecDeque<Sample> = vec![sample(&[[-1.0, -1.0], [-1.5, -0.5]]); 3].into();
        let east: VecDeque<Sample> = vec![sample(&[[1.0, -1.0], [9.0, -9.0]]); 3].into();
        // Only the training split (the first 2 samples) counts.
        t.count(0, 0, &west, 2);
        t.count(1, 0, &east, 2);
        assert_eq!(t.rounds[0], vec![4, 0, 0, 0, 0, 4, 0, 0]);
        let m = t.measure();
        assert_eq!((m.rounds, m.trainings, m.cells), (1, 2, 4));
        assert!((m.js_divergence - 1.0).abs() < 1e-12);
        assert!(m.cramers_v > 0.9);
        // A round where the robots share cells lowers the mean; the run table mixes both.
        t.count(0, 1, &west, 3);
        t.count(1, 1, &west, 3);
        let m = t.measure();
        assert_eq!(m.rounds, 2);
        assert!(m.final_js_divergence < 1e-12);
        assert!((m.js_divergence - 0.5).abs() < 1e-12);
        assert!(m.run_js_divergence > 0.0 && m.run_js_divergence < 1.0);
        // A round with one robot holding data is not a round; out-of-range robots are ignored.
        t.count(0, 2, &west, 3);
        t.count(5, 2, &west, 3);
        assert_eq!(t.measure().rounds, 2);
        assert_eq!(t.measure(), t.clone().measure());
    }
}
