//! `e6-scale` and its 1000-robot companions (issues 32 and 56): the paper's system at growing
//! swarm sizes at the paper's density, under the paper's rounds, the buffered protocol, its
//! matched ideal and the gossip baseline.

use super::Point;

/// The protocols `e6-scale` compares: the paper's rounds, the buffered protocol, its matched
/// ideal (`learn.aggregation = matched`: the buffered rule on every K updates of the same
/// trainings, without delay, staleness bound or outlier check) and the gossip baseline, as a
/// point-name prefix and its overrides.
pub const E6_PROTOCOLS: [(&str, &[&str]); 4] = [
    ("rounds", &["contract.protocol=rounds"]),
    ("buffered", &["contract.protocol=buffered"]),
    (
        "matched",
        &["contract.protocol=buffered", "learn.aggregation=matched"],
    ),
    (
        "gossip",
        &["contract.protocol=rounds", "learn.aggregation=gossip"],
    ),
];

/// The protocols of the chain and its ideals (all of [`E6_PROTOCOLS`] but gossip, which runs
/// at 1000 robots in an experiment of its own).
const E6_CHAIN_AND_IDEAL: usize = 3;

/// The index of the buffered protocol in [`E6_PROTOCOLS`]: the protocol of the point with
/// faults.
const E6_BUFFERED: usize = 1;

/// The swarm of `e6-scale`'s point with faults.
pub const E6_FAULTY_SWARM: u32 = 240;

/// The faulty robots of `e6-scale`'s point with faults: 10 % of [`E6_FAULTY_SWARM`].
pub const E6_FAULTY: u32 = E6_FAULTY_SWARM / 10;

/// The overrides that put the paper's system at `robots` robots at its density (the rule of
/// `bench scale`): the arena side grown by `sqrt(robots / 15)`, the obstacles with the area.
pub fn paper_density(robots: u32) -> Vec<String> {
    let scale = f64::from(robots) / 15.0;
    let obstacles = (5.0 * scale).round() as u32;
    vec![
        format!("world.robots={robots}"),
        format!("world.arena_side_m={}", 5.0 * scale.sqrt()),
        format!("world.cylinders={obstacles}"),
        format!("world.boxes={obstacles}"),
    ]
}

/// The training period of every `e6-scale` robot, at every size: the paper's 100 s (issue 56;
/// the study made before capped the swarm at one training a second, so at 1000 robots each
/// robot trained every 1000 s and the chain was never separated from the training budget).
/// [`e6_capped_training_period_s`] is that cap, kept for a sweep that wants it (`--set
/// learn.training_period_s=...`).
pub const E6_TRAINING_PERIOD_S: f64 = 100.0;

/// The training period under a cap of `trainings_per_s` trainings a second in the whole swarm,
/// never faster than the paper's: `max(100, robots / trainings_per_s)`.
pub fn e6_capped_training_period_s(robots: u32, trainings_per_s: f64) -> f64 {
    (f64::from(robots) / trainings_per_s).max(E6_TRAINING_PERIOD_S)
}

/// The overrides of an `e6-scale` swarm of `robots`: the paper's density and training period.
fn e6_swarm(robots: u32) -> Vec<String> {
    let mut all = paper_density(robots);
    all.push(format!("learn.training_period_s={E6_TRAINING_PERIOD_S}"));
    all
}

/// One clean `e6-scale` point: `protocol` at `robots` robots.
fn e6_point(robots: u32, protocol: &str, overrides: &[&str]) -> Point {
    let mut all = e6_swarm(robots);
    all.extend(overrides.iter().map(|o| o.to_string()));
    Point {
        name: format!("{protocol}-{robots}"),
        x: f64::from(robots),
        overrides: all,
        tags: vec![
            ("protocol", protocol.to_string()),
            ("condition", "clean".to_string()),
        ],
    }
}

/// The grid of `e6-scale`: every size in `sizes` x [`E6_PROTOCOLS`] (`<protocol>-<robots>`;
/// without `gossip`, the chain's protocols and the matched ideal only), then, with `faulty`,
/// the buffered protocol at 240 robots with [`E6_FAULTY`] faulty robots
/// (`buffered-240-faulty-24`). x is the swarm's size.
pub(super) fn e6_points(sizes: &[u32], faulty: bool) -> Vec<Point> {
    let protocols = if faulty {
        &E6_PROTOCOLS[..]
    } else {
        &E6_PROTOCOLS[..E6_CHAIN_AND_IDEAL]
    };
    let mut points = Vec::new();
    for &robots in sizes {
        for (protocol, overrides) in protocols {
            points.push(e6_point(robots, protocol, overrides));
        }
    }
    if faulty {
        let (protocol, overrides) = E6_PROTOCOLS[E6_BUFFERED];
        let mut point = e6_point(E6_FAULTY_SWARM, protocol, overrides);
        point.overrides.push("byzantine.kind=faulty".into());
        point.overrides.push(format!("byzantine.count={E6_FAULTY}"));
        point.name = format!("{protocol}-{E6_FAULTY_SWARM}-faulty-{E6_FAULTY}");
        point.tags[1].1 = format!("faulty-{E6_FAULTY}");
        points.push(point);
    }
    points
}

/// The gossip points of `sizes` (`gossip-<robots>`).
pub(super) fn e6_gossip_points(sizes: &[u32]) -> Vec<Point> {
    let (protocol, overrides) = E6_PROTOCOLS[E6_CHAIN_AND_IDEAL];
    sizes
        .iter()
        .map(|&robots| e6_point(robots, protocol, overrides))
        .collect()
}
