//! The page of a log whose plug-in rule is not loaded ([`world_page`]): the world alone,
//! folded from its ticks.

use std::collections::BTreeMap;
use std::path::Path;

use swarmfl_core::config::{Aggregation, Config, Rule};
use swarmfl_core::contract::rules::plugin as rule_plugin;
use swarmfl_core::event::{CheckpointCause, Event, Record};
use swarmfl_core::log::{LogReader, Next};
use swarmfl_core::replay;
use swarmfl_core::state::{apply_tick, SimError};
use swarmfl_core::world::World;

use super::data::{data_json, Parts};
use super::fold::MAX_REFOLDS;
use super::frames::Frames;
use super::walk::{Grid, Walk};
use super::Page;
use crate::progress::Watch;

/// The plug-in rule `log`'s contract runs when it is not loaded in this process (the `swarmfl`
/// command loads none): its name. `None` when the log runs a built-in rule, a baseline, or a
/// plug-in rule registered here (the Python package's `Run.view`).
pub(super) fn unloaded_rule(log: &Path) -> anyhow::Result<Option<String>> {
    let reader = LogReader::open(log).map_err(replay::ReplayError::from)?;
    let config = replay::header_config(&reader, &log.display().to_string())?;
    let name = &config.contract.rule_plugin;
    Ok((config.learn.aggregation == Aggregation::Chain
        && config.rule() == Rule::Plugin
        && rule_plugin::current(name).is_none())
    .then(|| name.clone()))
}

/// The page of a log whose plug-in rule `rule` is not loaded, from its records: the world (every
/// tick folded, its digest checked at every checkpoint) with its uniform frames, robots,
/// Byzantine marks and radio links. The contract's results (tokens, rounds, loss, which blocks
/// form the final chain) are recomputed by the rule, so the page shows a note in their place.
pub(super) fn world_page(log: &Path, rule: &str, watch: &dyn Watch) -> anyhow::Result<Page> {
    let reader = LogReader::open(log).map_err(replay::ReplayError::from)?;
    let name = log.display().to_string();
    let mut grid = Grid::of(&replay::header_config(&reader, &name)?);
    // A reconfiguration of the tick or the duration moves the grid: fold again on the last one.
    let mut refolds = 0;
    let fold = loop {
        let fold = fold_world(log, grid)?;
        let last = Grid::of(&fold.config);
        if last == grid {
            break fold;
        }
        anyhow::ensure!(
            refolds < MAX_REFOLDS,
            "{name}: the frame grid of the view moved {MAX_REFOLDS} times (reconfigurations of \
             run.tick_s or run.duration_s)"
        );
        grid = last;
        refolds += 1;
    };
    if let Some(cut) = &fold.truncated {
        watch.warn(&format!("warning: {cut}"));
        watch.warn(&format!(
            "warning: using the intact prefix: the world up to t = {:.3} s",
            fold.world.time().secs()
        ));
    }
    let config = &fold.config;
    let title = format!(
        "preset {}, seed {}, {} robots, {} s — {name}",
        config.preset, fold.seed, config.world.robots, config.run.duration_s,
    );
    let note = format!(
        "This run's aggregation rule is the plug-in `{rule}`, not loaded: contract results \
         (tokens, rounds, loss, which blocks form the final chain) need it; load it from Python: \
         swarmfl.open(LOG, rule=...).view(OUT). This page shows the world from the log's \
         records: robots, trajectories, Byzantine marks and radio links. Verified: the log's \
         hash chain{}, and the world's digest at each of its {} checkpoints (their ledger and \
         contract digests need the rule). The log records {} sealings by any node (genesis \
         apart), up to height {}.",
        if fold.truncated.is_none() {
            " and footer"
        } else {
            ""
        },
        fold.checkpoints,
        fold.walk.sealings,
        fold.top_height,
    );
    let n = config.world.robots as usize;
    let byzantine = swarmfl_core::byzantine::byzantine_robots(config, fold.seed);
    let balances = format!("[[{}]]", vec!["0"; n].join(","));
    let extra = format!(
        ",\"plugin_rule\":{{\"name\":{},\"note\":{}}}",
        serde_json::to_string(rule)?,
        serde_json::to_string(&note)?
    );
    let shown: Vec<usize> = (0..fold.walk.frames.t.len()).collect();
    let data = data_json(
        &Parts {
            config,
            world: &fold.world,
            byzantine: &byzantine,
            chain: "[[0,0]]",
            balances: &balances,
            rounds: "[]",
            truncated: &fold.truncated,
            extra: &extra,
        },
        &fold.walk,
        &shown,
        &title,
        None,
    )?;
    Ok(Page {
        title,
        data,
        frames: shown.len(),
        sealings: fold.walk.sealings,
        height: 0,
        frame_ms: grid.frame_ms,
        aggregations: None,
        rule_note: Some(note),
    })
}

/// A fold of a log's world alone (see [`world_page`]).
struct WorldFold {
    world: World,
    /// The configuration after the last record.
    config: Config,
    seed: u64,
    /// The uniform frames (every node's head is genesis: blocks need the contract).
    walk: Walk,
    /// Checkpoints whose world digest was checked.
    checkpoints: u64,
    /// The greatest height of a block checkpoint.
    top_height: u64,
    /// Why the log ends where it does; `None` when its footer was read.
    truncated: Option<String>,
}

/// Folds the ticks of `log` on `grid`, checking the world's digest at every checkpoint.
fn fold_world(log: &Path, grid: Grid) -> anyhow::Result<WorldFold> {
    let name = log.display().to_string();
    let mut reader = LogReader::open(log).map_err(replay::ReplayError::from)?;
    let mut config = replay::header_config(&reader, &name)?;
    let seed = reader.header().seed;
    let mut world = World::new(&config, seed).map_err(|source| replay::ReplayError::Start {
        path: name.clone(),
        cause: SimError::World(source),
    })?;
    let n = config.world.robots as usize;
    let genesis_heads = format!("[{}]", vec!["0"; n].join(","));
    let mut walk = Walk {
        grid,
        next_frame_ms: grid.frame_ms,
        ids: BTreeMap::new(),
        blocks: String::from("[[0,-1,0,-1,0]"),
        reorgs: String::from("["),
        reorg_count: 0,
        sealings: 0,
        heads: Vec::new(),
        frames: Frames::default(),
    };
    let null = || "null".to_string();
    walk.frames
        .push_world(&world, 0, None, genesis_heads.clone(), null());
    let (mut checkpoints, mut top_height) = (0, 0);
    let truncated = loop {
        let record = match reader.next_intact().map_err(replay::ReplayError::from)? {
            Next::Record(record) => record,
            Next::End => break None,
            Next::Pending(cut) => break Some(cut.to_string()),
        };
        let index = reader.index() - 1;
        match &record {
            Record::Event {
                time,
                event: Event::Tick(tick),
            } => {
                apply_tick(&mut world, *time, tick).map_err(|cause| {
                    replay::ReplayError::Apply {
                        path: name.clone(),
                        index,
                        kind: record.kind(),
                        time: *time,
                        cause,
                    }
                })?;
                let now = time.0 + grid.tick_ms;
                if now >= walk.next_frame_ms {
                    walk.frames
                        .push_world(&world, now, None, genesis_heads.clone(), null());
                    walk.next_frame_ms = (now / grid.frame_ms + 1) * grid.frame_ms;
                }
            }
            Record::Checkpoint(cp) => {
                if cp.world != world.digest() {
                    return Err(replay::ReplayError::Diverged {
                        path: name,
                        index,
                        kind: record.kind(),
                        time: cp.time,
                        component: "world".to_string(),
                        detail: " between the log's checkpoint and the replayed world".to_string(),
                    }
                    .into());
                }
                checkpoints += 1;
                if let CheckpointCause::Block { height, .. } = cp.cause {
                    walk.sealings += 1;
                    top_height = top_height.max(height);
                }
            }
            Record::Event { .. } => {}
        }
        if let Some(next) = replay::reconfigured(&record) {
            config = next;
        }
    };
    Ok(WorldFold {
        world,
        config,
        seed,
        walk,
        checkpoints,
        top_height,
        truncated,
    })
}
