//! Trajectory data: the samples a robot records about its neighbours (docs/SPEC.md section 1).
//!
//! Each tick a robot hears some neighbours (range-and-bearing) and records their absolute
//! positions. `trajectory_ticks` consecutive ticks of the same neighbour form one trajectory; a
//! missed tick discards the partial trajectory; windows do not overlap (after a complete
//! trajectory the next one starts at the next tick it hears that neighbour). A [`Sample`] keeps
//! the first `input_waypoints + target_waypoints` positions; the rest of the trajectory is only
//! counted. Samples expire `data.expiration_s` after their completion.
//!
//! [`Recorder`] is one robot's recorder and data set; [`HeldoutObserver`] is the noise-free
//! ground-truth observer that builds the held-out set.

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

use crate::config::{DataConfig, WindowRule};
use crate::types::{RobotId, SimTime};

/// One training example cut from a 100-tick trajectory of a neighbour: `input_waypoints`
/// (x, y) positions followed by `target_waypoints` positions, in world metres (not normalised).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sample {
    /// When the trajectory was completed; the sample expires `data.expiration_s` after this.
    pub time: SimTime,
    /// Input waypoints then target waypoints, each an (x, y) pair.
    pub points: Vec<[f32; 2]>,
}

/// The trajectory lengths and the expiry, in the units the recorders use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Recording {
    /// Ticks of one trajectory.
    pub trajectory_ticks: u32,
    /// Waypoints kept in a sample (input + target).
    pub kept_waypoints: u32,
    /// Age in milliseconds beyond which a sample is dropped.
    pub expiration_ms: u64,
}

impl Recording {
    /// From the data configuration (validated: kept <= trajectory).
    pub fn new(data: &DataConfig) -> Recording {
        let kept_waypoints = data.input_waypoints + data.target_waypoints;
        assert!(kept_waypoints <= data.trajectory_ticks && data.trajectory_ticks >= 1);
        Recording {
            trajectory_ticks: data.trajectory_ticks,
            kept_waypoints,
            expiration_ms: SimTime::from_secs(data.expiration_s).0,
        }
    }
}

/// `Track::ticks` of a gap marker (`WindowRule::Confirmed` only).
const GAP: u32 = u32::MAX;

/// A trajectory of one neighbour being recorded.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct Track {
    neighbour: RobotId,
    ticks: u32,
    points: Vec<[f32; 2]>,
}

/// One robot's trajectory recorder and data set.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Recorder {
    /// Trajectories in progress, ascending by neighbour.
    tracks: Vec<Track>,
    /// Unexpired samples, oldest first.
    samples: VecDeque<Sample>,
    /// Samples ever completed.
    completed: u64,
    /// Partial trajectories ever discarded because a tick was missed.
    discarded: u64,
    /// Reused buffer (always empty between ticks).
    #[serde(skip)]
    spare: Vec<Track>,
}

impl Recorder {
    /// Records one tick: `heard` are the neighbours heard this tick, ascending. `position(j,
    /// kept)` gives neighbour `j`'s measured position; `kept` says whether the point is stored
    /// (callers may skip drawing noise otherwise). It is called once per heard neighbour whose
    /// reading extends a window, in the order of `heard`. Returns the number of samples
    /// completed (appended at the back, timed `now`). `rule` says when a window completes
    /// ([`WindowRule`]).
    pub fn observe(
        &mut self,
        rec: &Recording,
        rule: WindowRule,
        now: SimTime,
        heard: &[RobotId],
        mut position: impl FnMut(RobotId, bool) -> [f32; 2],
    ) -> u32 {
        debug_assert!(
            heard.windows(2).all(|w| w[0] < w[1]),
            "heard must be ascending"
        );
        let confirmed = rule == WindowRule::Confirmed;
        let mut old = std::mem::take(&mut self.tracks);
        let mut new = std::mem::take(&mut self.spare);
        debug_assert!(new.is_empty());
        let mut completed = 0;
        let mut discarded = 0;
        // A track not heard this tick: discarded; under `confirmed`, it stays as a gap marker
        // (the authors' code notices the gap only at the neighbour's next reading, which it
        // drops).
        let mut missed = |t: Track, new: &mut Vec<Track>| {
            if t.ticks == GAP {
                new.push(t);
            } else {
                discarded += 1;
                if confirmed {
                    new.push(Track {
                        neighbour: t.neighbour,
                        ticks: GAP,
                        points: Vec::new(),
                    });
                }
            }
        };
        {
            let mut old_iter = old.drain(..).peekable();
            for &j in heard {
                while let Some(t) = old_iter.next_if(|t| t.neighbour < j) {
                    missed(t, &mut new);
                }
                let mut track = match old_iter.next_if(|t| t.neighbour == j) {
                    // The reading after a gap: dropped, the next one starts a window.
                    Some(t) if t.ticks == GAP => continue,
                    // A full window confirmed by this reading, which starts nothing.
                    Some(t) if t.ticks == rec.trajectory_ticks => {
                        self.samples.push_back(Sample {
                            time: now,
                            points: t.points,
                        });
                        completed += 1;
                        continue;
                    }
                    Some(t) => t,
                    None => Track {
                        neighbour: j,
                        ticks: 0,
                        points: Vec::with_capacity(rec.kept_waypoints as usize),
                    },
                };
                let kept = track.ticks < rec.kept_waypoints;
                let p = position(j, kept);
                if kept {
                    track.points.push(p);
                }
                track.ticks += 1;
                if track.ticks == rec.trajectory_ticks && !confirmed {
                    debug_assert_eq!(track.points.len(), rec.kept_waypoints as usize);
                    self.samples.push_back(Sample {
                        time: now,
                        points: track.points,
                    });
                    completed += 1;
                } else {
                    new.push(track);
                }
            }
            for t in old_iter {
                missed(t, &mut new);
            }
        }
        self.tracks = new;
        self.spare = old;
        self.completed += u64::from(completed);
        self.discarded += discarded;
        completed
    }

    /// Drops the samples older than the expiration at time `now`.
    pub fn expire(&mut self, rec: &Recording, now: SimTime) {
        while self
            .samples
            .front()
            .is_some_and(|s| now.0 - s.time.0 > rec.expiration_ms)
        {
            self.samples.pop_front();
        }
    }

    /// The unexpired samples, oldest first.
    pub fn samples(&self) -> &VecDeque<Sample> {
        &self.samples
    }

    /// Samples ever completed by this robot.
    pub fn completed(&self) -> u64 {
        self.completed
    }

    /// Partial trajectories ever discarded by this robot.
    pub fn discarded(&self) -> u64 {
        self.discarded
    }

    /// The neighbours being tracked and how many ticks each has so far, ascending.
    pub fn tracks(&self) -> impl Iterator<Item = (RobotId, u32)> + '_ {
        self.tracks.iter().map(|t| (t.neighbour, t.ticks))
    }
}

/// Speed bins of [`heterogeneity`]'s histogram: end-to-end speed over a sample's waypoints,
/// in steps of 0.01 m/s (the last bin open).
const SPEED_BINS: usize = 6;
/// Turn bins: the angle between the first and second half of the sample's displacement,
/// uniform over [0, pi].
const TURN_BINS: usize = 4;

/// The (speed, turn) histogram cell of one sample, or `None` for a sample too short to have
/// two halves. Speed = distance between the first and last kept waypoints over their time
/// span; turn = angle between the displacements of the first and second half. Both are
/// computed from end points, not from steps, so the range-and-bearing noise (1 cm against 2.5
/// mm a tick) barely moves them.
fn cell(sample: &Sample, tick_s: f64) -> Option<usize> {
    let n = sample.points.len();
    if n < 3 {
        return None;
    }
    let p = |k: usize| {
        (
            f64::from(sample.points[k][0]),
            f64::from(sample.points[k][1]),
        )
    };
    let (a, m, b) = (p(0), p(n / 2), p(n - 1));
    let (d1, d2) = ((m.0 - a.0, m.1 - a.1), (b.0 - m.0, b.1 - m.1));
    let dist = libm::hypot(b.0 - a.0, b.1 - a.1);
    let speed = dist / ((n - 1) as f64 * tick_s);
    let speed_bin = ((speed / 0.01) as usize).min(SPEED_BINS - 1);
    let turn = libm::atan2(d1.0 * d2.1 - d1.1 * d2.0, d1.0 * d2.0 + d1.1 * d2.1).abs();
    let turn_bin = ((turn / std::f64::consts::PI * TURN_BINS as f64) as usize).min(TURN_BINS - 1);
    Some(speed_bin * TURN_BINS + turn_bin)
}

/// Motion heterogeneity between robots (`world.data_heterogeneity` in `summary.json`, a key
/// kept from before position was measured; position is `world/heterogeneity.rs`): how much
/// a sample's robot tells about its motion features,
/// as the bias-corrected Cramer's V (Bergsma 2013, J. Korean Stat. Soc. 42) of the
/// contingency table of robots (those that hold samples) x feature cells (end-to-end speed x
/// turn, [`SPEED_BINS`] x [`TURN_BINS`] cells, those that hold samples). 0 when every robot's
/// data follows the same distribution, 1 when each robot's data lies in cells of its own.
/// Why this: federated learning's hard case is robots whose local data follow different
/// distributions; speed and turning are what a trajectory model learns, and they are what
/// differs between behaviours (a flock moves together at cruise speed, foragers shuttle and
/// rest, avoiders wander). The correction removes what finite samples alone contribute (the
/// chi-square's expectation under one shared distribution): the measure used until issue
/// #38's second session, the mean total-variation distance of each robot's histogram to the
/// pooled one, grew as robots held fewer samples, so a swarm of stuck robots scored above a
/// mixed one. It is computed on the data sets robots train on (after expiry), with sums in a
/// fixed order, so it is a deterministic function of the state. docs/SPEC.md section 1 ("Is a
/// mixed swarm more heterogeneous?") gives the measurements behind keeping it: a mixed swarm is
/// not more heterogeneous per robot under this or any other measure of the data tried, since
/// robots record their neighbours and the behaviours barely differ over one window.
pub fn heterogeneity<'a>(sets: impl Iterator<Item = &'a VecDeque<Sample>>, tick_s: f64) -> f64 {
    const CELLS: usize = SPEED_BINS * TURN_BINS;
    let hists: Vec<[u64; CELLS]> = sets
        .map(|set| {
            let mut h = [0u64; CELLS];
            for c in set.iter().filter_map(|s| cell(s, tick_s)) {
                h[c] += 1;
            }
            h
        })
        .filter(|h| h.iter().any(|&v| v > 0))
        .collect();
    let rows: Vec<&[u64]> = hists.iter().map(|h| &h[..]).collect();
    cramers_v(&rows)
}

/// The bias-corrected Cramer's V (Bergsma 2013, J. Korean Stat. Soc. 42) of a contingency
/// table given by its rows (equal lengths; rows without counts and columns without counts are
/// left out): 0 when every row follows the pooled distribution beyond what finite counts
/// alone give, 1 when each row's counts lie in columns of its own. 0 when fewer than two rows
/// or two columns hold counts, or fewer than 2 counts in all. Sums run in row then column
/// order, so the result is a deterministic function of the table.
pub fn cramers_v(table: &[&[u64]]) -> f64 {
    let hists: Vec<&[u64]> = table
        .iter()
        .copied()
        .filter(|h| h.iter().any(|&v| v > 0))
        .collect();
    let width = hists.iter().map(|h| h.len()).max().unwrap_or(0);
    let mut pooled = vec![0u64; width];
    for h in &hists {
        for (p, &v) in pooled.iter_mut().zip(h.iter()) {
            *p += v;
        }
    }
    let total: u64 = pooled.iter().sum();
    let rows = hists.len() as f64;
    let cols = pooled.iter().filter(|&&c| c > 0).count() as f64;
    if total < 2 || rows < 2.0 || cols < 2.0 {
        return 0.0;
    }
    let n = total as f64;
    let mut chi2 = 0.0;
    for h in &hists {
        let row: u64 = h.iter().sum();
        for (&o, &c) in h.iter().zip(&pooled) {
            if c > 0 {
                let e = row as f64 * c as f64 / n;
                chi2 += (o as f64 - e) * (o as f64 - e) / e;
            }
        }
    }
    let phi2 = (chi2 / n - (cols - 1.0) * (rows - 1.0) / (n - 1.0)).max(0.0);
    let cols_c = cols - (cols - 1.0) * (cols - 1.0) / (n - 1.0);
    let rows_c = rows - (rows - 1.0) * (rows - 1.0) / (n - 1.0);
    let dim = (cols_c - 1.0).min(rows_c - 1.0);
    if dim <= 0.0 {
        return 0.0;
    }
    (phi2 / dim).sqrt().min(1.0)
}

/// The noise-free ground-truth observer: it sees every robot every tick, so every robot yields
/// one trajectory per `trajectory_ticks` ticks; it keeps samples in robot order until it has
/// `wanted` of them.
#[derive(Clone, Debug, PartialEq)]
pub struct HeldoutObserver {
    rec: Recording,
    wanted: usize,
    ticks: u32,
    windows: Vec<Vec<[f32; 2]>>,
    samples: Vec<Sample>,
}

impl HeldoutObserver {
    /// An observer of `robots` robots that wants `wanted` samples.
    pub fn new(rec: Recording, robots: usize, wanted: usize) -> HeldoutObserver {
        HeldoutObserver {
            rec,
            wanted,
            ticks: 0,
            windows: vec![Vec::with_capacity(rec.kept_waypoints as usize); robots],
            samples: Vec::with_capacity(wanted),
        }
    }

    /// Whether enough samples have been collected.
    pub fn done(&self) -> bool {
        self.samples.len() >= self.wanted
    }

    /// Records the true positions of every robot at time `now`.
    pub fn observe(&mut self, now: SimTime, positions: impl Iterator<Item = [f32; 2]>) {
        if self.ticks < self.rec.kept_waypoints {
            for (w, p) in self.windows.iter_mut().zip(positions) {
                w.push(p);
            }
        }
        self.ticks += 1;
        if self.ticks == self.rec.trajectory_ticks {
            for w in &mut self.windows {
                if self.samples.len() < self.wanted {
                    self.samples.push(Sample {
                        time: now,
                        points: std::mem::take(w),
                    });
                }
                w.clear();
            }
            self.ticks = 0;
        }
    }

    /// The collected samples.
    pub fn into_samples(self) -> Vec<Sample> {
        self.samples
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec() -> Recording {
        Recording {
            trajectory_ticks: 5,
            kept_waypoints: 3,
            expiration_ms: 1000,
        }
    }

    /// Feeds `heard` lists tick by tick (tick k at time 100 k ms) and returns the recorder.
    fn feed(ticks: &[&[RobotId]]) -> Recorder {
        let mut r = Recorder::default();
        for (k, heard) in ticks.iter().enumerate() {
            let now = SimTime(100 * (k as u64 + 1));
            r.observe(&rec(), WindowRule::Contiguous, now, heard, |j, _| {
                [j as f32, k as f32]
            });
        }
        r
    }

    fn check(ticks: &[&[RobotId]], completed: u64, discarded: u64, tracks: &[(RobotId, u32)]) {
        let r = feed(ticks);
        assert_eq!(
            (r.completed(), r.discarded()),
            (completed, discarded),
            "{ticks:?}"
        );
        assert_eq!(r.tracks().collect::<Vec<_>>(), tracks, "{ticks:?}");
    }

    #[test]
    fn trajectories_complete_are_discarded_on_gaps_and_do_not_overlap() {
        check(&[&[1], &[1], &[1], &[1], &[1]], 1, 0, &[]);
        check(&[&[1], &[1], &[1], &[1], &[1], &[1]], 1, 0, &[(1, 1)]);
        check(&[&[1], &[1], &[], &[1], &[1]], 0, 1, &[(1, 2)]);
        check(
            &[&[1, 2], &[2], &[1, 2], &[1, 2, 3], &[2, 3]],
            1,
            2,
            &[(3, 2)],
        );
        check(
            &[&[0, 4], &[4], &[4], &[4], &[4], &[4], &[4]],
            1,
            1,
            &[(4, 2)],
        );
    }

    #[test]
    fn samples_keep_the_first_waypoints_and_expire() {
        let mut r = feed(&[&[7 as RobotId][..]; 10]);
        let s = r.samples();
        assert_eq!(s.len(), 2);
        assert_eq!(s[0].time, SimTime(500));
        assert_eq!(s[0].points, vec![[7.0, 0.0], [7.0, 1.0], [7.0, 2.0]]);
        assert_eq!(s[1].points, vec![[7.0, 5.0], [7.0, 6.0], [7.0, 7.0]]);
        r.expire(&rec(), SimTime(1500));
        assert_eq!(
            r.samples().len(),
            2,
            "age 1000 ms is not older than the expiration"
        );
        r.expire(&rec(), SimTime(1501));
        assert_eq!(r.samples().len(), 1);
        assert_eq!(r.samples()[0].time, SimTime(1000));
        r.expire(&rec(), SimTime(2001));
        assert!(r.samples().is_empty());
        assert_eq!(r.completed(), 2);
    }

    #[test]
    fn the_observer_collects_windows_in_robot_order() {
        let mut o = HeldoutObserver::new(rec(), 2, 3);
        let mut k = 0.0;
        while !o.done() {
            k += 1.0;
            o.observe(SimTime(0), [[0.0, k], [1.0, k]].into_iter());
        }
        let s = o.into_samples();
        assert_eq!(s.len(), 3);
        assert_eq!(s[0].points, vec![[0.0, 1.0], [0.0, 2.0], [0.0, 3.0]]);
        assert_eq!(s[1].points, vec![[1.0, 1.0], [1.0, 2.0], [1.0, 3.0]]);
        assert_eq!(s[2].points, vec![[0.0, 6.0], [0.0, 7.0], [0.0, 8.0]]);
    }

    #[test]
    fn the_confirmed_rule_saves_a_window_at_the_next_reading_and_drops_the_reading_after_a_gap() {
        let mut r = Recorder::default();
        let mut completions = Vec::new();
        // Heard at ticks 0..12 except tick 7.
        for k in 0..12u64 {
            let heard: &[RobotId] = if k == 7 { &[] } else { &[1] };
            let done = r.observe(
                &rec(),
                WindowRule::Confirmed,
                SimTime(k * 100),
                heard,
                |_, _| [0.0, 0.0],
            );
            if done > 0 {
                completions.push(k);
            }
        }
        // Window 0..5 (5 readings) confirmed at tick 5, which starts nothing; 6 starts a window
        // that the gap at 7 discards; 8 (the reading after the gap) is dropped; 9..12 start
        // the next window, still open.
        assert_eq!(completions, vec![5]);
        assert_eq!(r.discarded(), 1);
        assert_eq!(r.tracks().collect::<Vec<_>>(), vec![(1, 3)]);
        let mut c = Recorder::default();
        let mut contiguous = Vec::new();
        for k in 0..12u64 {
            let heard: &[RobotId] = if k == 7 { &[] } else { &[1] };
            if c.observe(
                &rec(),
                WindowRule::Contiguous,
                SimTime(k * 100),
                heard,
                |_, _| [0.0, 0.0],
            ) > 0
            {
                contiguous.push(k);
            }
        }
        assert_eq!(contiguous, vec![4]);
    }

    #[test]
    fn heterogeneity_is_zero_for_identical_data_and_grows_when_robots_differ() {
        let slow: Sample = Sample {
            time: SimTime(0),
            points: (0..10).map(|k| [k as f32 * 0.001, 0.0]).collect(),
        };
        let fast: Sample = Sample {
            time: SimTime(0),
            points: (0..10).map(|k| [k as f32 * 0.005, 0.0]).collect(),
        };
        let same: Vec<VecDeque<Sample>> = vec![vec![slow.clone(), fast.clone()].into(); 2];
        assert_eq!(heterogeneity(same.iter(), 0.1), 0.0);
        // Each robot's data in a cell of its own: 1.
        let apart: Vec<VecDeque<Sample>> =
            vec![vec![slow.clone(); 10].into(), vec![fast.clone(); 10].into()];
        assert!((heterogeneity(apart.iter(), 0.1) - 1.0).abs() < 1e-12);
        // Half of one robot's data like the other's: in between.
        let mut half = vec![slow.clone(); 5];
        half.extend(vec![fast.clone(); 5]);
        let partly: Vec<VecDeque<Sample>> = vec![vec![slow.clone(); 10].into(), half.into()];
        let v = heterogeneity(partly.iter(), 0.1);
        assert!(v > 0.3 && v < 0.9, "{v}");
        // One sample each is no evidence of a difference: the finite-sample part is removed
        // (the mean total-variation distance used before gave 0.5 here).
        let one_each: Vec<VecDeque<Sample>> = vec![vec![slow].into(), vec![fast].into()];
        assert_eq!(heterogeneity(one_each.iter(), 0.1), 0.0);
    }

    /// A straight sample of 10 waypoints at `speed` m/s along x (ticks of 0.1 s): turn 0, so
    /// its cell is its speed bin times `TURN_BINS`.
    fn straight(speed: f32) -> Sample {
        Sample {
            time: SimTime(0),
            points: (0..10).map(|k| [k as f32 * speed * 0.1, 0.0]).collect(),
        }
    }

    /// A data set of `slow` samples at 0.005 m/s (speed bin 0) and `fast` at 0.025 (bin 2).
    fn slow_fast(slow: usize, fast: usize) -> VecDeque<Sample> {
        let mut v = vec![straight(0.005); slow];
        v.extend(vec![straight(0.025); fast]);
        v.into()
    }

    /// Robot 0 holds `a` slow and `b` fast samples, robot 1 `c` slow and `d` fast.
    fn two_by_two(a: usize, b: usize, c: usize, d: usize) -> f64 {
        heterogeneity([slow_fast(a, b), slow_fast(c, d)].iter(), 0.1)
    }

    #[test]
    fn heterogeneity_matches_hand_computed_tables() {
        assert_eq!(cell(&straight(0.005), 0.1), Some(0));
        assert_eq!(cell(&straight(0.025), 0.1), Some(2 * TURN_BINS));
        // [[10, 0], [5, 5]]: n = 20, expected counts 7.5 / 2.5 in both rows, chi2 = 2 (2.5^2 /
        // 7.5 + 2.5^2 / 2.5) = 20/3, phi2 = 1/3 - 1/19 = 16/57, each corrected dimension
        // 2 - 1/19, so V^2 = (16/57) / (18/19) = 8/27.
        let v = two_by_two(10, 0, 5, 5);
        assert!((v - (8.0f64 / 27.0).sqrt()).abs() < 1e-12, "{v}");
        // [[6, 4], [4, 6]]: n = 20, expected 5 everywhere, chi2 = 4 (1/5) = 0.8, phi2 = 0.04 -
        // 1/19 < 0: a difference this small is what 20 samples of one distribution show, so 0.
        assert_eq!(two_by_two(6, 4, 4, 6), 0.0);
        // [[30, 10], [10, 30]]: n = 80, chi2 = 4 (10^2 / 20) = 20, phi2 = 1/4 - 1/79 = 75/316,
        // dimension 1 - 1/79 = 78/79, so V^2 = 75/312.
        let v = two_by_two(30, 10, 10, 30);
        assert!((v - (75.0f64 / 312.0).sqrt()).abs() < 1e-12, "{v}");
        // Robots in the other order, or a robot without data: the same value.
        assert_eq!(two_by_two(10, 30, 30, 10), v);
        let with_empty = [VecDeque::new(), slow_fast(30, 10), slow_fast(10, 30)];
        assert_eq!(heterogeneity(with_empty.iter(), 0.1), v);
    }
}
