//! Faults on the radio and the robots: the `[faults]` table of the configuration and the
//! driver-side schedule that applies it.
//!
//! Every fault is part of the configuration (hence of the log's header) and acts through the
//! events it causes, so a run with faults replays like any other:
//! - *partitions* cut radio links for a time window: `split` cuts every link between the two
//!   halves of the arena (x < 0 and x >= 0, decided from the robots' positions at each tick, as
//!   a wall of radio shadow would), `isolate` cuts every link of one robot, `sealer` cuts every
//!   link of the robot whose turn it is to seal the next block on the highest head (Clique's
//!   in-turn sealer, re-evaluated every tick);
//! - *loss bursts* raise the loss probability of every gossip message sent in a window;
//! - *delays* add a fixed latency to every message sent in a window;
//! - *crashes* stop a robot for a window: its node neither seals, gossips nor submits, and its
//!   radio is silent; at the restart (`Restart` ledger event) its node has lost its mempool and
//!   everything in flight to it, keeps its chain (on disk) and resyncs from its peers by the
//!   ordinary gossip;
//! - *clock skew* shifts one robot's clock for the whole run: its sealings carry its own clock's
//!   time and it judges "from the future" against its own clock (see `ledger`).
//!
//! The fault windows are `[start_s, end_s)` in simulated seconds. The last heal
//! ([`FaultsConfig::last_heal_ms`]) is the end of the latest window; the chaos campaign measures
//! liveness from there.

use serde::{Deserialize, Serialize};

use crate::rng::Rng;
use crate::types::{show_f64, RobotId};

/// What a partition cuts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PartitionKind {
    /// Two halves of the arena (x < 0 and x >= 0) cannot hear each other.
    Split,
    /// One robot (`robot`) hears nobody and nobody hears it.
    Isolate,
    /// The in-turn sealer of the next block on the highest head is isolated.
    Sealer,
}

/// A partition of the radio for a time window.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Partition {
    /// What is cut.
    pub kind: PartitionKind,
    /// The isolated robot (`isolate` only; ignored otherwise).
    #[serde(default)]
    pub robot: RobotId,
    /// Start of the window, simulated seconds.
    pub start_s: f64,
    /// End of the window (the heal), simulated seconds.
    pub end_s: f64,
}

/// A window of extra packet loss.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LossBurst {
    /// Probability that a message sent in the window is lost (replaces `ledger.packet_loss`
    /// when higher).
    pub loss: f64,
    /// Start, simulated seconds.
    pub start_s: f64,
    /// End, simulated seconds.
    pub end_s: f64,
}

/// A window of extra latency.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Delay {
    /// Milliseconds added to the delivery of every message sent in the window.
    pub extra_ms: u64,
    /// Start, simulated seconds.
    pub start_s: f64,
    /// End, simulated seconds.
    pub end_s: f64,
}

/// A robot down for a window, restarted at its end.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Crash {
    /// The robot.
    pub robot: RobotId,
    /// Crash time, simulated seconds.
    pub start_s: f64,
    /// Restart time, simulated seconds.
    pub end_s: f64,
}

/// A robot whose clock is off.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClockSkew {
    /// The robot.
    pub robot: RobotId,
    /// Its clock minus the true time, in milliseconds (negative: late).
    pub skew_ms: i64,
}

/// The `[faults]` table: every fault of a run (none by default; the paper has none).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FaultsConfig {
    /// Radio partitions.
    pub partitions: Vec<Partition>,
    /// Bursts of packet loss.
    pub loss_bursts: Vec<LossBurst>,
    /// Windows of extra latency.
    pub delays: Vec<Delay>,
    /// Robot crashes (with restart).
    pub crashes: Vec<Crash>,
    /// Clock skews.
    pub clock_skews: Vec<ClockSkew>,
}

/// Seconds to whole milliseconds (validated finite and non-negative).
fn ms(s: f64) -> u64 {
    (s * 1000.0).round() as u64
}

/// Largest clock skew accepted, in ms (one minute).
pub const MAX_SKEW_MS: i64 = 60_000;

impl FaultsConfig {
    /// True when no fault is configured.
    pub fn is_empty(&self) -> bool {
        self == &FaultsConfig::default()
    }

    /// Checks every window and id; the error names the key, the value and the allowed range.
    pub fn check(&self, robots: u32, duration_s: f64) -> Result<(), (String, String, String)> {
        let window = |key: String, start: f64, end: f64| {
            if start.is_finite() && end.is_finite() && start >= 0.0 && end > start {
                Ok(())
            } else {
                Err((
                    key,
                    format!("[{}, {})", show_f64(start), show_f64(end)),
                    "0 <= start_s < end_s, finite".to_string(),
                ))
            }
        };
        let robot = |key: String, r: RobotId| {
            if r < robots {
                Ok(())
            } else {
                Err((
                    key,
                    r.to_string(),
                    format!("a robot id from 0 to {}", robots.saturating_sub(1)),
                ))
            }
        };
        let _ = duration_s;
        for (i, p) in self.partitions.iter().enumerate() {
            window(format!("faults.partitions[{i}]"), p.start_s, p.end_s)?;
            if p.kind == PartitionKind::Isolate {
                robot(format!("faults.partitions[{i}].robot"), p.robot)?;
            }
        }
        for (i, b) in self.loss_bursts.iter().enumerate() {
            window(format!("faults.loss_bursts[{i}]"), b.start_s, b.end_s)?;
            if !(0.0..=1.0).contains(&b.loss) {
                return Err((
                    format!("faults.loss_bursts[{i}].loss"),
                    show_f64(b.loss),
                    "a probability in [0, 1]".to_string(),
                ));
            }
        }
        for (i, d) in self.delays.iter().enumerate() {
            window(format!("faults.delays[{i}]"), d.start_s, d.end_s)?;
            if d.extra_ms > 600_000 {
                return Err((
                    format!("faults.delays[{i}].extra_ms"),
                    d.extra_ms.to_string(),
                    "at most 600000 (10 minutes)".to_string(),
                ));
            }
        }
        for (i, c) in self.crashes.iter().enumerate() {
            window(format!("faults.crashes[{i}]"), c.start_s, c.end_s)?;
            robot(format!("faults.crashes[{i}].robot"), c.robot)?;
        }
        for (i, s) in self.clock_skews.iter().enumerate() {
            robot(format!("faults.clock_skews[{i}].robot"), s.robot)?;
            if s.skew_ms.abs() > MAX_SKEW_MS {
                return Err((
                    format!("faults.clock_skews[{i}].skew_ms"),
                    s.skew_ms.to_string(),
                    format!("within +-{MAX_SKEW_MS}"),
                ));
            }
        }
        Ok(())
    }

    /// The clock skew of every robot, in ms (the last entry for a robot wins).
    pub fn skews_ms(&self, robots: u32) -> Vec<i64> {
        let mut out = vec![0i64; robots as usize];
        for s in &self.clock_skews {
            if let Some(slot) = out.get_mut(s.robot as usize) {
                *slot = s.skew_ms;
            }
        }
        out
    }

    /// The end of the latest fault window, in ms (0 without windows). Clock skews last the
    /// whole run and do not count.
    pub fn last_heal_ms(&self) -> u64 {
        let ends = self
            .partitions
            .iter()
            .map(|p| p.end_s)
            .chain(self.loss_bursts.iter().map(|b| b.end_s))
            .chain(self.delays.iter().map(|d| d.end_s))
            .chain(self.crashes.iter().map(|c| c.end_s));
        ends.map(ms).max().unwrap_or(0)
    }

    /// A random fault schedule for a run of `robots` over `duration_s` (the chaos campaign):
    /// up to two partitions, a loss burst, a delay window, a crash and a few clock skews, each
    /// window inside the first 70 % of the run so that the end of the run can show liveness.
    pub fn draw(rng: &mut Rng, robots: u32, duration_s: f64) -> FaultsConfig {
        let horizon = (duration_s * 0.7).floor().max(2.0);
        let window = |rng: &mut Rng, max_len: f64| {
            let start = rng.below(horizon as u64) as f64;
            let len = 1.0 + rng.below(max_len.max(1.0) as u64) as f64;
            (start, (start + len).min(horizon.max(start + 1.0)))
        };
        let mut f = FaultsConfig::default();
        for _ in 0..rng.below(3) {
            let (start_s, end_s) = window(rng, duration_s * 0.4);
            let kind = match rng.below(3) {
                0 => PartitionKind::Split,
                1 => PartitionKind::Isolate,
                _ => PartitionKind::Sealer,
            };
            f.partitions.push(Partition {
                kind,
                robot: rng.below(u64::from(robots)) as RobotId,
                start_s,
                end_s,
            });
        }
        if rng.chance(0.5) {
            let (start_s, end_s) = window(rng, duration_s * 0.3);
            f.loss_bursts.push(LossBurst {
                loss: 0.2 + 0.7 * rng.uniform(),
                start_s,
                end_s,
            });
        }
        if rng.chance(0.5) {
            let (start_s, end_s) = window(rng, duration_s * 0.3);
            f.delays.push(Delay {
                extra_ms: 100 + rng.below(5_000),
                start_s,
                end_s,
            });
        }
        if rng.chance(0.5) {
            let (start_s, end_s) = window(rng, duration_s * 0.3);
            f.crashes.push(Crash {
                robot: rng.below(u64::from(robots)) as RobotId,
                start_s,
                end_s,
            });
        }
        for _ in 0..rng.below(3) {
            f.clock_skews.push(ClockSkew {
                robot: rng.below(u64::from(robots)) as RobotId,
                skew_ms: rng.below(6_001) as i64 - 3_000,
            });
        }
        f
    }
}

/// The driver side of the faults: what is cut, lost, delayed or down at a time.
#[derive(Clone, Debug)]
pub struct FaultSchedule {
    config: FaultsConfig,
    robots: u32,
}

impl FaultSchedule {
    /// The schedule of a configuration.
    pub fn new(config: &FaultsConfig, robots: u32) -> FaultSchedule {
        FaultSchedule {
            config: config.clone(),
            robots,
        }
    }

    fn active(start_s: f64, end_s: f64, t_ms: u64) -> bool {
        ms(start_s) <= t_ms && t_ms < ms(end_s)
    }

    /// Whether `robot` is crashed at `t_ms`.
    pub fn is_down(&self, robot: RobotId, t_ms: u64) -> bool {
        self.config
            .crashes
            .iter()
            .any(|c| c.robot == robot && Self::active(c.start_s, c.end_s, t_ms))
    }

    /// The restarts in `(from_ms, to_ms]` as (time, robot), in time then id order, for the
    /// robots that are up again then.
    pub fn restart_times(&self, from_ms: u64, to_ms: u64) -> Vec<(u64, RobotId)> {
        let mut out: Vec<(u64, RobotId)> = self
            .config
            .crashes
            .iter()
            .map(|c| (ms(c.end_s), c.robot))
            .filter(|&(t, r)| from_ms < t && t <= to_ms && !self.is_down(r, t))
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// The robots restarted in `(from_ms, to_ms]`, in id order, each once.
    pub fn restarts(&self, from_ms: u64, to_ms: u64) -> Vec<RobotId> {
        let mut out: Vec<RobotId> = self
            .config
            .crashes
            .iter()
            .filter(|c| from_ms < ms(c.end_s) && ms(c.end_s) <= to_ms)
            .map(|c| c.robot)
            .filter(|&r| !self.is_down(r, to_ms))
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// The loss probability of a message sent at `t_ms` on a radio whose base loss is `base`.
    pub fn loss_at(&self, base: f64, t_ms: u64) -> f64 {
        self.config
            .loss_bursts
            .iter()
            .filter(|b| Self::active(b.start_s, b.end_s, t_ms))
            .map(|b| b.loss)
            .fold(base, f64::max)
    }

    /// Latency added to a message sent at `t_ms`, in ms.
    pub fn extra_delay_ms(&self, t_ms: u64) -> u64 {
        self.config
            .delays
            .iter()
            .filter(|d| Self::active(d.start_s, d.end_s, t_ms))
            .map(|d| d.extra_ms)
            .sum()
    }

    /// The clock skew of every robot, in ms.
    pub fn skews_ms(&self) -> Vec<i64> {
        self.config.skews_ms(self.robots)
    }

    /// Cuts the links that the faults active at `t_ms` cut from the peer sets. `x_m` gives each
    /// robot's x coordinate (for `split`); `in_turn` is the in-turn sealer of the next block on
    /// the highest head (for `sealer`).
    pub fn filter_peers(
        &self,
        peers: &mut [Vec<RobotId>],
        t_ms: u64,
        x_m: &[f64],
        in_turn: RobotId,
    ) {
        let mut cut = vec![false; self.robots as usize];
        let mut split = false;
        for p in &self.config.partitions {
            if !Self::active(p.start_s, p.end_s, t_ms) {
                continue;
            }
            match p.kind {
                PartitionKind::Split => split = true,
                PartitionKind::Isolate => {
                    if let Some(c) = cut.get_mut(p.robot as usize) {
                        *c = true;
                    }
                }
                PartitionKind::Sealer => {
                    if let Some(c) = cut.get_mut(in_turn as usize) {
                        *c = true;
                    }
                }
            }
        }
        for r in 0..self.robots {
            if self.is_down(r, t_ms) {
                cut[r as usize] = true;
            }
        }
        let side = |r: RobotId| x_m.get(r as usize).is_some_and(|&x| x >= 0.0);
        for (a, list) in peers.iter_mut().enumerate() {
            if cut.get(a).copied().unwrap_or(false) {
                list.clear();
                continue;
            }
            list.retain(|&b| {
                !cut.get(b as usize).copied().unwrap_or(false)
                    && (!split || side(a as RobotId) == side(b))
            });
        }
    }

    /// Whether any partition or crash may cut links at some time (a fast path for the driver).
    pub fn cuts_links(&self) -> bool {
        !self.config.partitions.is_empty() || !self.config.crashes.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{self, Purpose};

    #[test]
    fn windows_cut_links_and_heal() {
        let config = FaultsConfig {
            partitions: vec![
                Partition {
                    kind: PartitionKind::Split,
                    robot: 0,
                    start_s: 10.0,
                    end_s: 20.0,
                },
                Partition {
                    kind: PartitionKind::Isolate,
                    robot: 2,
                    start_s: 30.0,
                    end_s: 40.0,
                },
            ],
            crashes: vec![Crash {
                robot: 1,
                start_s: 50.0,
                end_s: 60.0,
            }],
            ..FaultsConfig::default()
        };
        config.check(4, 100.0).unwrap();
        let s = FaultSchedule::new(&config, 4);
        let all = || vec![vec![1, 2, 3], vec![0, 2, 3], vec![0, 1, 3], vec![0, 1, 2]];
        let x = [-1.0, -1.0, 1.0, 1.0];
        let mut p = all();
        s.filter_peers(&mut p, 5_000, &x, 0);
        assert_eq!(p, all());
        s.filter_peers(&mut p, 10_000, &x, 0);
        assert_eq!(p, vec![vec![1], vec![0], vec![3], vec![2]]);
        let mut p = all();
        s.filter_peers(&mut p, 35_000, &x, 0);
        assert_eq!(p, vec![vec![1, 3], vec![0, 3], vec![], vec![0, 1]]);
        let mut p = all();
        s.filter_peers(&mut p, 55_000, &x, 0);
        assert!(p[1].is_empty() && !p[0].contains(&1));
        assert!(s.is_down(1, 59_999) && !s.is_down(1, 60_000));
        assert_eq!(s.restarts(59_900, 60_000), vec![1]);
        assert!(s.restarts(60_000, 60_100).is_empty());
        assert_eq!(config.last_heal_ms(), 60_000);
    }

    #[test]
    fn drawn_schedules_are_valid_and_reproducible() {
        for seed in 0..50 {
            let a = FaultsConfig::draw(&mut rng::stream(seed, Purpose::Faults, 0), 15, 600.0);
            let b = FaultsConfig::draw(&mut rng::stream(seed, Purpose::Faults, 0), 15, 600.0);
            assert_eq!(a, b);
            a.check(15, 600.0).unwrap();
            assert!(a.last_heal_ms() <= 420_000);
        }
    }

    #[test]
    fn bad_windows_are_named() {
        let config = FaultsConfig {
            crashes: vec![Crash {
                robot: 9,
                start_s: 1.0,
                end_s: 2.0,
            }],
            ..FaultsConfig::default()
        };
        let (key, value, _) = config.check(4, 10.0).unwrap_err();
        assert_eq!(
            (key.as_str(), value.as_str()),
            ("faults.crashes[0].robot", "9")
        );
    }
}
