//! The page's data object as JSON text ([`data_json`]): the arena, the behaviours, the frames
//! and the chain (or a baseline's aggregations).

use std::collections::BTreeMap;
use std::fmt::Write as _;

use swarmfl_core::config::{Aggregation, Behaviour, Config};
use swarmfl_core::inspect::{self, expr::Env, Column};
use swarmfl_core::world::{foraging_flowfl, Obstacle, World};
use swarmfl_core::Digest;

use super::frames::Frames;
use super::walk::{Grid, Walk};
use super::LiveState;

/// The page's data object as JSON text.
pub(super) fn page_data(
    index: &inspect::RunIndex,
    walk: &Walk,
    shown: &[usize],
    heldout: &mut BTreeMap<Digest, f64>,
    title: &str,
    live: Option<(LiveState, u64)>,
) -> anyhow::Result<String> {
    let (chain, balances) = chain_json(index, &walk.ids);
    let rounds = rounds_json(index, heldout)?;
    data_json(
        &Parts {
            config: &index.config,
            world: &index.final_state.world,
            byzantine: &index.byzantine,
            chain: &chain,
            balances: &balances,
            rounds: &rounds,
            truncated: &index.truncated,
            extra: "",
        },
        walk,
        shown,
        title,
        live,
    )
}

/// What the page's data holds besides the frames: a chain run's index gives it all; a log
/// whose plug-in rule is not loaded gives its world alone
/// ([`world_page`](super::world::world_page)).
pub(super) struct Parts<'a> {
    pub(super) config: &'a Config,
    /// The world at the end of the records folded.
    pub(super) world: &'a World,
    pub(super) byzantine: &'a [bool],
    /// JSON text: the final canonical chain, the balances after each of its blocks, the rounds.
    pub(super) chain: &'a str,
    pub(super) balances: &'a str,
    pub(super) rounds: &'a str,
    pub(super) truncated: &'a Option<String>,
    /// JSON members appended to the data object (each with its leading comma); empty for every
    /// log but a plug-in rule's drawn without the rule.
    pub(super) extra: &'a str,
}

/// The page's data object as JSON text from its parts and frames.
pub(super) fn data_json(
    parts: &Parts,
    walk: &Walk,
    shown: &[usize],
    title: &str,
    live: Option<(LiveState, u64)>,
) -> anyhow::Result<String> {
    let end = members(&[
        ("truncated", serde_json::to_string(parts.truncated)?),
        ("live", live_json(live)),
    ]);
    Ok(format!(
        "{{{},{},{},{},{end}{}}}",
        arena_json(parts, walk.grid, title)?,
        behaviours_json(parts),
        frames_json(&walk.frames, shown),
        ledger_json(parts, walk),
        parts.extra,
    ))
}

/// JSON object members `"name":value` (each value already JSON text), comma-separated.
fn members(list: &[(&str, String)]) -> String {
    let list: Vec<String> = list.iter().map(|(k, v)| format!("\"{k}\":{v}")).collect();
    list.join(",")
}

/// The data's members on the run and its arena: the title, the robots' count, size and radio
/// range, the duration and frame step, the obstacles and which robots are Byzantine.
fn arena_json(parts: &Parts, grid: Grid, title: &str) -> anyhow::Result<String> {
    let config = parts.config;
    let arena = parts.world.arena();
    let obstacles: Vec<String> = arena
        .obstacles
        .iter()
        .map(|o| match *o {
            Obstacle::Cylinder { x, y, radius_m } => format!("[\"c\",{x},{y},{radius_m}]"),
            Obstacle::Box { x, y, half_side_m } => format!("[\"b\",{x},{y},{half_side_m}]"),
        })
        .collect();
    let byzantine: Vec<&str> = parts
        .byzantine
        .iter()
        .map(|&b| if b { "1" } else { "0" })
        .collect();
    Ok(members(&[
        ("title", serde_json::to_string(title)?),
        ("robots", config.world.robots.to_string()),
        ("half", arena.half_side_m.to_string()),
        ("radius", config.world.robot_radius_m.to_string()),
        ("range", config.world.rab_range_m.to_string()),
        ("duration_ms", (grid.total_ticks * grid.tick_ms).to_string()),
        ("frame_ms", grid.frame_ms.to_string()),
        ("obstacles", format!("[{}]", obstacles.join(","))),
        ("byzantine", format!("[{}]", byzantine.join(","))),
    ]))
}

/// The data's members on behaviours: each robot's name, the nest `[x, y, r]` and food `[x, y]`
/// of the `simple` rule (null and empty without) and the food's radius.
fn behaviours_json(parts: &Parts) -> String {
    let behaviours = parts.world.behaviours();
    let names: Vec<String> = (0..parts.config.world.robots as usize)
        .map(|i| {
            let b = behaviours.map_or(Behaviour::Avoidance, |b| b.of[i]);
            format!("\"{}\"", b.name())
        })
        .collect();
    let nest = match behaviours.and_then(|b| b.nest) {
        Some(n) => format!("[{},{},{}]", n.x, n.y, n.radius_m),
        None => "null".to_string(),
    };
    let food: Vec<String> = behaviours
        .map(|b| {
            b.food
                .iter()
                .map(|f| format!("[{},{}]", f.x, f.y))
                .collect()
        })
        .unwrap_or_default();
    let food_radius = behaviours.map_or(0.0, |b| b.food_radius_m);
    members(&[
        ("behaviour", format!("[{}]", names.join(","))),
        ("nest", nest),
        ("food", format!("[{}]", food.join(","))),
        ("food_radius", food_radius.to_string()),
    ])
}

/// The data's members on the frames `shown`, in time order: their times, poses, links, heads,
/// foragers, behaviours by place and model versions; a Flow-FL foraging run's nest strip and
/// items first.
fn frames_json(frames: &Frames, shown: &[usize]) -> String {
    // A block's frame may be taken after the frame of the tick's end: order by time (stable,
    // so a block's frame follows a tick frame of the same time and wins at that time).
    let mut order = shown.to_vec();
    order.sort_by_key(|&k| frames.t[k]);
    let pick = |v: &[String]| {
        let list: Vec<&str> = order.iter().map(|&k| v[k].as_str()).collect();
        format!("[{}]", list.join(","))
    };
    let times: Vec<String> = order.iter().map(|&k| frames.t[k].to_string()).collect();
    let mut list = Vec::new();
    // Flow-FL's foraging arena: the nest strip west of its edge and, per frame, the items on
    // the floor. Only its runs have the keys, so every other run's data is as it was.
    if order.iter().any(|&k| frames.items[k] != "null") {
        list.push(("nest_strip", foraging_flowfl::NEST_EDGE_X_M.to_string()));
        list.push(("items", format!("[{}]", items_json(&order, &frames.items))));
    }
    list.extend([
        ("t", format!("[{}]", times.join(","))),
        ("pose", pick(&frames.pose)),
        ("links", pick(&frames.links)),
        ("heads", pick(&frames.heads)),
        ("forager", pick(&frames.forager)),
        ("of", pick(&frames.of)),
        ("versions", pick(&frames.versions)),
    ]);
    members(&list)
}

/// The data's members on the ledger: every block sealed, the aggregation, the final canonical
/// chain, the balances after each of its blocks, the rounds and the reorgs.
fn ledger_json(parts: &Parts, walk: &Walk) -> String {
    members(&[
        ("blocks", format!("{}]", walk.blocks)),
        (
            "aggregation",
            format!("\"{}\"", parts.config.learn.aggregation.name()),
        ),
        ("chain", parts.chain.to_string()),
        ("balances", parts.balances.to_string()),
        ("rounds", parts.rounds.to_string()),
        ("reorgs", format!("{}]", walk.reorgs)),
    ])
}

/// The live view's state as JSON (see [`LiveState`]), with the time of the last frame shown;
/// `null` for a finished run's page.
fn live_json(live: Option<(LiveState, u64)>) -> String {
    match live {
        Some((l, upto_ms)) => format!(
            "{{\"version\":{},\"ended\":{},\"poll_ms\":{},\"upto_ms\":{upto_ms}}}",
            l.version, l.ended, l.poll_ms
        ),
        None => "null".to_string(),
    }
}

/// The items of the frames `order` as JSON text without its brackets: a frame whose items are
/// those of the frame before it has the position (in `order`) of the frame that lists them.
/// Items change only when taken or delivered, so most frames of a short run repeat them.
fn items_json(order: &[usize], items: &[String]) -> String {
    let mut out = String::new();
    let mut listed: Option<(usize, &str)> = None;
    for (pos, &k) in order.iter().enumerate() {
        if pos > 0 {
            out.push(',');
        }
        match listed {
            Some((at, list)) if list == items[k] => {
                let _ = write!(out, "{at}");
            }
            _ => {
                out.push_str(&items[k]);
                listed = Some((pos, &items[k]));
            }
        }
    }
    out
}

/// The final canonical chain as JSON: `[block id, time ms]` per block, and every robot's
/// balance (tokens) after each block.
fn chain_json(index: &inspect::RunIndex, ids: &BTreeMap<Digest, u32>) -> (String, String) {
    let mut chain = String::from("[");
    let mut balances = String::from("[");
    for (k, row) in index.chain.iter().enumerate() {
        let id = ids.get(&row.hash).copied().unwrap_or(0);
        let _ = write!(
            chain,
            "{}[{id},{}]",
            if k == 0 { "" } else { "," },
            row.time.0
        );
        let state = index.contract_at(row.height);
        let list: Vec<String> = state
            .balances
            .iter()
            .map(|&u| format!("{:.3}", index.tokens(u)))
            .collect();
        let _ = write!(
            balances,
            "{}[{}]",
            if k == 0 { "" } else { "," },
            list.join(",")
        );
    }
    chain.push(']');
    balances.push(']');
    (chain, balances)
}

/// The closed rounds as JSON: `[round, block, time ms, loss, held-out loss]` each; a baseline's
/// aggregations (its rounds table: the same rows as `export` and `summary.json`) as
/// `[aggregation, -1, time ms, loss, held-out loss, robot (-1: the server), models averaged]`.
///
/// `heldout` keeps the held-out loss of each round's closing block between pages (the loss of
/// its shared model on the fixed held-out set: one model evaluation each, most of a page's
/// cost when computed anew every time).
fn rounds_json(
    index: &inspect::RunIndex,
    heldout: &mut BTreeMap<Digest, f64>,
) -> anyhow::Result<String> {
    if index.config.learn.aggregation != Aggregation::Chain {
        return baseline_rounds_json(index);
    }
    let mut values = None;
    let mut rounds = String::from("[");
    for (k, r) in index.rounds().iter().enumerate() {
        let hash = index.chain[r.block as usize].hash;
        let heldout = *heldout.entry(hash).or_insert_with(|| {
            let values = values.get_or_insert_with(|| index.values());
            values.at(r.block).ident("heldout_loss").unwrap_or(f64::NAN)
        });
        let _ = write!(
            rounds,
            "{}[{},{},{},{},{}]",
            if k == 0 { "" } else { "," },
            r.round,
            r.block,
            (r.time_s * 1000.0).round() as u64,
            json_num(r.loss),
            json_num(heldout)
        );
    }
    rounds.push(']');
    Ok(rounds)
}

/// A baseline's aggregations as JSON (see [`rounds_json`]), from its rounds table.
fn baseline_rounds_json(index: &inspect::RunIndex) -> anyhow::Result<String> {
    let table = index.rounds_table()?;
    let column = |name: &str| {
        table
            .column(name)
            .ok_or_else(|| anyhow::anyhow!("the rounds table of a baseline has no `{name}`"))
    };
    let (
        Column::U64(round),
        Column::F64(time_s),
        Column::I64(robot),
        Column::U64(models),
        Column::F64(loss),
        Column::F64(heldout),
    ) = (
        column("round")?,
        column("time_s")?,
        column("robot")?,
        column("models")?,
        column("loss")?,
        column("heldout_loss")?,
    )
    else {
        anyhow::bail!("the rounds table of a baseline has a column of another type");
    };
    let mut rounds = String::from("[");
    for k in 0..round.len() {
        let _ = write!(
            rounds,
            "{}[{},-1,{},{},{},{},{}]",
            if k == 0 { "" } else { "," },
            round[k],
            (time_s[k] * 1000.0).round() as u64,
            json_num(loss.get(k).copied().unwrap_or(f64::NAN)),
            json_num(heldout.get(k).copied().unwrap_or(f64::NAN)),
            robot[k],
            models[k]
        );
    }
    rounds.push(']');
    Ok(rounds)
}

/// A number as JSON (`null` for NaN and infinities).
fn json_num(v: f64) -> String {
    if v.is_finite() {
        format!("{v}")
    } else {
        "null".to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::super::fold::tests::{fixture, scratch, whole};
    use super::super::frames::forager_letter;
    use super::*;
    use std::path::Path;
    use swarmfl_core::replay;

    /// The page data of the log at `log` as JSON.
    fn data_of(log: &Path) -> serde_json::Value {
        serde_json::from_str(&whole(log, None).data).unwrap()
    }

    #[test]
    fn a_flowfl_foraging_page_has_the_nest_strip_and_each_frame_s_items() {
        let dir = scratch("flowfl");
        let config = Config::resolve(
            Some("flowfl-foraging"),
            None,
            &["run.duration_s=120".into()],
        )
        .unwrap();
        let total = config.world.foraging.food_count(config.world.robots) as usize;
        let out = crate::run::RunRequest::new(config, 1, &dir.join("run"))
            .run(&crate::progress::Quiet)
            .unwrap();
        let data = data_of(&out.log_path);
        assert_eq!(data["nest_strip"], -1.0, "the nest strip's east edge");
        assert_eq!(data["nest"], serde_json::Value::Null, "no disk nest");
        let (t, items, forager) = (
            data["t"].as_array().unwrap(),
            data["items"].as_array().unwrap(),
            data["forager"].as_array().unwrap(),
        );
        assert_eq!(items.len(), t.len(), "one item list per frame");
        let frame_ms = data["frame_ms"].as_u64().unwrap();
        let mut checked = 0;
        for k in (0..t.len()).step_by(t.len() / 6) {
            let list = items[k]
                .as_u64()
                .map_or(&items[k], |at| &items[at as usize]);
            let mm: Vec<i64> = list
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_i64().unwrap())
                .collect();
            let letters = forager[k].as_str().unwrap();
            let carried = letters.chars().filter(char::is_ascii_uppercase).count();
            assert_eq!(
                mm.len() / 2 + carried,
                total,
                "frame {k}: on the floor or carried"
            );
            // The items of a uniform frame are the log's state at that time, not the config's.
            let t_ms = t[k].as_u64().unwrap();
            if t_ms % frame_ms != 0 {
                continue;
            }
            let (state, _, _) =
                replay::state_at_time(&out.log_path, swarmfl_core::SimTime(t_ms)).unwrap();
            let b = state.world.behaviours().unwrap();
            let want: Vec<i64> = b
                .flowfl
                .as_ref()
                .unwrap()
                .items
                .iter()
                .flatten()
                .flat_map(|&(x, y)| [(x * 1000.0).round() as i64, (y * 1000.0).round() as i64])
                .collect();
            assert_eq!(mm, want, "items at {t_ms} ms");
            let want: String = (0..b.of.len()).map(|i| forager_letter(b, i)).collect();
            assert_eq!(letters, want, "foragers at {t_ms} ms");
            checked += 1;
        }
        assert!(
            checked >= 3,
            "{checked} uniform frames checked against the log"
        );
        let lists = items.iter().filter(|v| v.is_array()).count();
        assert!(
            lists > 1 && lists < items.len(),
            "items are taken and re-placed over the run, and each change is listed once: {lists} \
             lists for {} frames",
            items.len()
        );
        assert!(
            forager.iter().any(|f| f.as_str().unwrap().contains('R')),
            "some forager carries an item home"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn pages_of_other_runs_have_no_flowfl_keys() {
        let dir = scratch("simple");
        let log = dir.join("run.swlog");
        std::fs::write(&log, fixture("smoke-secure-seed1")).unwrap();
        let data = data_of(&log);
        assert!(data.get("nest_strip").is_none() && data.get("items").is_none());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
