//! The numbers of `swarmfl ranking`, from the ranked submissions of runs: per round, per run
//! and per point (ranking order x Byzantine kind x count).
//!
//! Distances shrink by orders of magnitude as a run converges, so every per-round position is
//! relative to the round's median distance `m` of the accepted models (the paper's ranking
//! centre): a submission at distance `d` sits at `d / m` (1 = on the median) and
//! `|d - m| / m` off it. A group's value in a round is the mean over its accepted
//! submissions; its value in a run is the mean over all its accepted submissions of the run
//! (every submission counts once). Ranks are 1-based (1 = paid best); a penalised rank is one
//! whose reward weight is negative. Token gains are each robot's final balance minus its
//! initial tokens on the final canonical chain, averaged over the group's robots.

use std::collections::BTreeMap;

use swarmfl_core::inspect::RankedSubmission;

use crate::report::stats::Stat;

/// One group of submitters: the Byzantine robots or the honest ones.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Group {
    /// The Byzantine robots.
    Byzantine,
    /// The honest robots.
    Honest,
}

impl Group {
    /// Both groups, Byzantine first.
    pub const BOTH: [Group; 2] = [Group::Byzantine, Group::Honest];

    /// The group's name in column names.
    pub fn name(self) -> &'static str {
        match self {
            Group::Byzantine => "byzantine",
            Group::Honest => "honest",
        }
    }

    fn holds(self, r: &RankedSubmission) -> bool {
        r.byzantine == (self == Group::Byzantine)
    }
}

/// One group's position in one round, or over a run's rounds: means over its accepted
/// submissions (NaN when it had none).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Position {
    /// Accepted submissions counted.
    pub submissions: u64,
    /// Mean `d / m`.
    pub distance_ratio: f64,
    /// Mean `|d - m| / m`.
    pub off_median_ratio: f64,
    /// Mean rank (1 = best).
    pub rank: f64,
    /// Share of the submissions in a penalised rank.
    pub penalised: f64,
    /// Mean tokens paid minus staked per submission.
    pub gain_tokens: f64,
}

/// Sums behind a [`Position`].
#[derive(Clone, Copy, Debug, Default)]
struct Sums {
    n: u64,
    ratio: f64,
    off: f64,
    rank: f64,
    penalised: f64,
    gain: f64,
}

impl Sums {
    fn add(&mut self, r: &RankedSubmission, token_units: u64) {
        // A round's median is 0 only when its models all equal the shared model; such a
        // submission sits on the median.
        let m = r.median_units as f64;
        let (ratio, off) = if r.median_units == 0 {
            (1.0, 0.0)
        } else {
            (r.distance_units as f64 / m, r.off_median_units as f64 / m)
        };
        self.n += 1;
        self.ratio += ratio;
        self.off += off;
        self.rank += f64::from(r.rank.unwrap_or(0));
        self.penalised += f64::from(u8::from(r.reward_weight.is_some_and(|k| k < 0)));
        self.gain += (r.paid_units as f64 - r.stake_units as f64) / token_units as f64;
    }

    fn position(self) -> Position {
        let mean = |sum: f64| {
            if self.n == 0 {
                f64::NAN
            } else {
                sum / self.n as f64
            }
        };
        Position {
            submissions: self.n,
            distance_ratio: mean(self.ratio),
            off_median_ratio: mean(self.off),
            rank: mean(self.rank),
            penalised: mean(self.penalised),
            gain_tokens: mean(self.gain),
        }
    }
}

/// One closed round of a run.
#[derive(Clone, Debug, PartialEq)]
pub struct RoundMeasure {
    /// The round (from 1).
    pub round: u64,
    /// Accepted submissions.
    pub accepted: u64,
    /// Accepted Byzantine submissions.
    pub byzantine_accepted: u64,
    /// The median distance, mean absolute distance per weight (model units).
    pub median_distance: f64,
    /// Whether the submission at the median (the first one ranked, when ranked around it)
    /// is Byzantine: the median distance is one of the accepted distances (the lower middle);
    /// the first accepted submission at that distance is taken.
    pub median_byzantine: bool,
    /// Whether every accepted Byzantine submission is closer to the shared model than every
    /// accepted honest one (false without both).
    pub byzantine_below_honest: bool,
    /// The groups' positions, Byzantine then honest.
    pub groups: [Position; 2],
}

/// Groups a run's ranked submissions by round (they come in round order) and measures each.
/// `per_weight` converts distance units to the mean absolute distance per weight.
pub fn rounds(
    rows: &[RankedSubmission],
    token_units: u64,
    per_weight: impl Fn(u64) -> f64,
) -> Vec<RoundMeasure> {
    let mut out = Vec::new();
    let mut start = 0;
    while start < rows.len() {
        let round = rows[start].round;
        let end = start + rows[start..].partition_point(|r| r.round == round);
        let accepted: Vec<&RankedSubmission> =
            rows[start..end].iter().filter(|r| r.accepted).collect();
        let mut sums = [Sums::default(); 2];
        for r in &accepted {
            let g = if r.byzantine { 0 } else { 1 };
            sums[g].add(r, token_units);
        }
        let median = accepted.first().map_or(0, |r| r.median_units);
        let max_byzantine = accepted
            .iter()
            .filter(|r| r.byzantine)
            .map(|r| r.distance_units)
            .max();
        let min_honest = accepted
            .iter()
            .filter(|r| !r.byzantine)
            .map(|r| r.distance_units)
            .min();
        out.push(RoundMeasure {
            round,
            accepted: accepted.len() as u64,
            byzantine_accepted: sums[0].n,
            median_distance: per_weight(median),
            median_byzantine: accepted
                .iter()
                .find(|r| r.distance_units == median)
                .is_some_and(|r| r.byzantine),
            byzantine_below_honest: matches!((max_byzantine, min_honest), (Some(b), Some(h)) if b < h),
            groups: [sums[0].position(), sums[1].position()],
        });
        start = end;
    }
    out
}

/// One run's numbers.
#[derive(Clone, Debug, PartialEq)]
pub struct RunMeasure {
    /// Closed rounds.
    pub rounds: u64,
    /// Share of the rounds with a Byzantine submission at the median.
    pub median_byzantine: f64,
    /// Share of the rounds with both groups where every Byzantine model is closer to the
    /// shared model than every honest one (NaN without such a round).
    pub byzantine_below_honest: f64,
    /// The groups' positions over all their accepted submissions, Byzantine then honest.
    pub groups: [Position; 2],
    /// Mean final gain in tokens of the groups' robots, Byzantine then honest (NaN for a group
    /// without robots).
    pub token_gain: [f64; 2],
}

impl RunMeasure {
    /// Byzantine minus honest mean token gain.
    pub fn gain_difference(&self) -> f64 {
        self.token_gain[0] - self.token_gain[1]
    }
}

/// A run's numbers from its ranked submissions and rounds, and its robots' final gains
/// (`gains[r]` in tokens, `byzantine[r]` whether robot `r` is Byzantine).
pub fn run(
    rows: &[RankedSubmission],
    rounds: &[RoundMeasure],
    token_units: u64,
    gains: &[f64],
    byzantine: &[bool],
) -> RunMeasure {
    let mut sums = [Sums::default(); 2];
    for r in rows.iter().filter(|r| r.accepted) {
        let g = Group::BOTH
            .iter()
            .position(|g| g.holds(r))
            .expect("two groups");
        sums[g].add(r, token_units);
    }
    let share = |hits: usize, of: usize| {
        if of == 0 {
            f64::NAN
        } else {
            hits as f64 / of as f64
        }
    };
    let both: Vec<&RoundMeasure> = rounds
        .iter()
        .filter(|m| m.byzantine_accepted > 0 && m.byzantine_accepted < m.accepted)
        .collect();
    let mean_gain = |want: bool| {
        let g: Vec<f64> = gains
            .iter()
            .zip(byzantine)
            .filter(|(_, &b)| b == want)
            .map(|(&g, _)| g)
            .collect();
        if g.is_empty() {
            f64::NAN
        } else {
            g.iter().sum::<f64>() / g.len() as f64
        }
    };
    RunMeasure {
        rounds: rounds.len() as u64,
        median_byzantine: share(
            rounds.iter().filter(|m| m.median_byzantine).count(),
            rounds.len(),
        ),
        byzantine_below_honest: share(
            both.iter().filter(|m| m.byzantine_below_honest).count(),
            both.len(),
        ),
        groups: [sums[0].position(), sums[1].position()],
        token_gain: [mean_gain(true), mean_gain(false)],
    }
}

/// A configuration point: the ranking it ran under, the Byzantine kind and count, and the
/// value of every other configuration key on which the measured runs differ.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Point {
    /// The ranking (`contract.rank_order`, with the key when not the exact distance).
    pub ranking: String,
    /// `byzantine.kind`.
    pub kind: String,
    /// `byzantine.count`.
    pub count: u32,
    /// `(key, value)` of each other key whose value differs between the runs measured
    /// together (`contract.rule` in a grid over rules), in key order; empty when they differ
    /// only in the three above.
    pub setting: Vec<(String, String)>,
}

impl Point {
    /// The other keys' `key=value`, joined by `, ` (empty without any).
    pub fn setting_text(&self) -> String {
        self.setting
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// The configuration keys a [`Point`] has fields for: never among its `setting`.
pub const POINT_KEYS: [&str; 4] = [
    "contract.rank_order",
    "contract.rank_key",
    "byzantine.kind",
    "byzantine.count",
];

/// What a run shows for a key its recorded configuration leaves out (a key recorded only
/// away from its default).
pub const LEFT_OUT: &str = "(default)";

/// The keys that tell runs apart beyond a [`Point`]'s own fields: every configuration key
/// (`Config::flat_values`) whose value is not the same in all `configs`, but [`POINT_KEYS`];
/// sorted. Then per run, its `(key, value)` on each (a TOML string without its quotes;
/// [`LEFT_OUT`] where its configuration does not hold the key).
pub fn settings(configs: &[BTreeMap<String, String>]) -> Vec<Vec<(String, String)>> {
    let mut keys: Vec<&String> = configs.iter().flat_map(|c| c.keys()).collect();
    keys.sort();
    keys.dedup();
    keys.retain(|k| {
        !POINT_KEYS.contains(&k.as_str()) && configs.iter().any(|c| c.get(*k) != configs[0].get(*k))
    });
    configs
        .iter()
        .map(|c| {
            keys.iter()
                .map(|k| {
                    let v = c.get(*k).map_or(LEFT_OUT, |v| crate::grid::shown_value(v));
                    ((*k).clone(), v.to_string())
                })
                .collect()
        })
        .collect()
}

/// The per-run metrics a point summarises, by column name, in column order.
pub fn metrics(m: &RunMeasure) -> Vec<(String, f64)> {
    let mut out = vec![
        ("rounds".to_string(), m.rounds as f64),
        ("median_byzantine".to_string(), m.median_byzantine),
        (
            "byzantine_below_honest".to_string(),
            m.byzantine_below_honest,
        ),
    ];
    for (g, p) in Group::BOTH.iter().zip(&m.groups) {
        let name = g.name();
        out.push((format!("{name}_distance_ratio"), p.distance_ratio));
        out.push((format!("{name}_off_median_ratio"), p.off_median_ratio));
        out.push((format!("{name}_rank"), p.rank));
        out.push((format!("{name}_penalised"), p.penalised));
        out.push((format!("{name}_submission_gain"), p.gain_tokens));
    }
    out.push(("byzantine_gain".to_string(), m.token_gain[0]));
    out.push(("honest_gain".to_string(), m.token_gain[1]));
    out.push(("gain_difference".to_string(), m.gain_difference()));
    out
}

/// A point with its statistics: per metric of [`metrics`] (in column order), its 95 %
/// interval over the runs where it is defined.
pub type PointStats = (Point, Vec<(String, Option<Stat>)>);

/// Every point's statistics over its runs: per metric of [`metrics`], the 95 % interval of
/// the runs where it is defined (a NaN value is left out; `None` when no run has it).
pub fn points(runs: &BTreeMap<Point, Vec<RunMeasure>>) -> Vec<PointStats> {
    runs.iter()
        .map(|(point, measures)| {
            let per_run: Vec<Vec<(String, f64)>> = measures.iter().map(metrics).collect();
            let names: Vec<String> = per_run
                .first()
                .map(|m| m.iter().map(|(n, _)| n.clone()).collect())
                .unwrap_or_default();
            let stats = names
                .iter()
                .enumerate()
                .map(|(i, name)| {
                    let values: Vec<f64> = per_run
                        .iter()
                        .map(|m| m[i].1)
                        .filter(|v| !v.is_nan())
                        .collect();
                    (name.clone(), Stat::of(&values))
                })
                .collect();
            (point.clone(), stats)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ranked submission of round `round` with median distance 100 units.
    fn sub(round: u64, byzantine: bool, d: u64, rank: u32, k: i64, paid: u64) -> RankedSubmission {
        RankedSubmission {
            round,
            block: round * 10,
            robot: 0,
            byzantine,
            accepted: true,
            distance_units: d,
            median_units: 100,
            off_median_units: d.abs_diff(100),
            rank: Some(rank),
            ranked: 3,
            reward_weight: Some(k),
            stake_units: 5_000,
            paid_units: paid,
        }
    }

    #[test]
    fn a_lone_byzantine_model_below_the_cluster_is_measured_off_the_median() {
        // Round 1: honest at 100 (the median) and 120, Byzantine at 40, ranked last and
        // penalised. Round 2: the Byzantine model at 100 holds the median, honest at 90, 130.
        let mut outlier = sub(1, false, 9_000, 0, 0, 0);
        outlier.accepted = false;
        outlier.rank = None;
        outlier.reward_weight = None;
        let rows = vec![
            sub(1, false, 100, 1, 1, 6_000),
            sub(1, true, 40, 3, -1, 2_000),
            outlier,
            sub(1, false, 120, 2, 1, 7_000),
            sub(2, false, 90, 2, 1, 6_000),
            sub(2, true, 100, 1, 1, 8_000),
            sub(2, false, 130, 3, -1, 1_000),
        ];
        let rounds = rounds(&rows, 1_000, |u| u as f64 / 10.0);
        assert_eq!(rounds.len(), 2);
        let r1 = &rounds[0];
        assert_eq!((r1.round, r1.accepted, r1.byzantine_accepted), (1, 3, 1));
        assert_eq!(r1.median_distance, 10.0);
        assert!(!r1.median_byzantine && r1.byzantine_below_honest);
        let b = r1.groups[0];
        assert_eq!((b.distance_ratio, b.off_median_ratio), (0.4, 0.6));
        assert_eq!((b.rank, b.penalised, b.gain_tokens), (3.0, 1.0, -3.0));
        let h = r1.groups[1];
        assert!((h.distance_ratio - 1.1).abs() < 1e-12);
        assert!((h.off_median_ratio - 0.1).abs() < 1e-12);
        assert_eq!((h.rank, h.penalised, h.gain_tokens), (1.5, 0.0, 1.5));
        assert!(rounds[1].median_byzantine && !rounds[1].byzantine_below_honest);

        // Robots 0 and 1 honest (+2 and -1 tokens), robot 2 Byzantine (-4).
        let m = run(
            &rows,
            &rounds,
            1_000,
            &[2.0, -1.0, -4.0],
            &[false, false, true],
        );
        assert_eq!(m.rounds, 2);
        assert_eq!((m.median_byzantine, m.byzantine_below_honest), (0.5, 0.5));
        // Byzantine over both rounds: ratios 0.4 and 1.0, ranks 3 and 1, gains -3 and +3.
        let b = m.groups[0];
        assert_eq!(b.submissions, 2);
        assert!((b.distance_ratio - 0.7).abs() < 1e-12);
        assert_eq!((b.rank, b.penalised, b.gain_tokens), (2.0, 0.5, 0.0));
        // Honest: 1.0, 1.2, 0.9, 1.3 -> 1.1; ranks 1, 2, 2, 3 -> 2; gains 1, 2, 1, -4 -> 0.
        let h = m.groups[1];
        assert_eq!(h.submissions, 4);
        assert!((h.distance_ratio - 1.1).abs() < 1e-12);
        assert_eq!((h.rank, h.penalised, h.gain_tokens), (2.0, 0.25, 0.0));
        assert_eq!(m.token_gain, [-4.0, 0.5]);
        assert_eq!(m.gain_difference(), -4.5);
    }

    #[test]
    fn the_keys_runs_differ_on_are_their_settings() {
        let config = |pairs: &[(&str, &str)]| -> BTreeMap<String, String> {
            pairs
                .iter()
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect()
        };
        let configs = [
            config(&[
                ("contract.rule", "\"median\""),
                ("byzantine.count", "1"),
                ("run.duration_s", "300.0"),
                ("byzantine.search_evals", "40"),
            ]),
            config(&[
                ("contract.rule", "\"krum\""),
                ("byzantine.count", "3"),
                ("run.duration_s", "300.0"),
            ]),
        ];
        // The count has its own field; the duration is the same; a key one configuration
        // leaves out (at its default) is shown so.
        assert_eq!(
            settings(&configs),
            [
                vec![
                    ("byzantine.search_evals".to_string(), "40".to_string()),
                    ("contract.rule".to_string(), "median".to_string()),
                ],
                vec![
                    ("byzantine.search_evals".to_string(), LEFT_OUT.to_string()),
                    ("contract.rule".to_string(), "krum".to_string()),
                ],
            ]
        );
        assert_eq!(settings(&configs[..1]), [Vec::new()]);
    }

    #[test]
    fn points_summarise_runs_and_leave_undefined_values_out() {
        let run_with = |gain: f64, below: f64| RunMeasure {
            rounds: 10,
            median_byzantine: 0.0,
            byzantine_below_honest: below,
            groups: [Sums::default().position(); 2],
            token_gain: [gain, 0.0],
        };
        let point = Point {
            ranking: "median".into(),
            kind: "smart".into(),
            count: 1,
            setting: Vec::new(),
        };
        let runs = BTreeMap::from([(
            point.clone(),
            vec![run_with(-2.0, f64::NAN), run_with(4.0, 0.5)],
        )]);
        let stats = points(&runs);
        assert_eq!(stats.len(), 1);
        let get = |name: &str| {
            stats[0]
                .1
                .iter()
                .find(|(n, _)| n == name)
                .and_then(|(_, s)| *s)
        };
        // Mean 1, s = sqrt(18), t(0.975, 1) = 12.706: half-width 12.706 * 3 = 38.118.
        let diff = get("gain_difference").expect("two runs");
        assert_eq!((diff.n, diff.mean), (2, 1.0));
        assert!((diff.ci.expect("n = 2") - 38.118).abs() < 1e-9);
        let below = get("byzantine_below_honest").expect("one run");
        assert_eq!((below.n, below.mean, below.ci), (1, 0.5, None));
        // A group without submissions has no rank in any run.
        assert_eq!(get("honest_rank"), None);
    }
}
