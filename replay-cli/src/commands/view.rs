//! `swarmfl view LOG --out run.html`: one self-contained HTML file to watch a run in a browser
//! (no network, no server): the arena with obstacles, robots with ids, Byzantine marks and radio
//! links (with behaviours, `world.behaviour`: robots coloured by behaviour, the foraging nest and
//! food sources, each forager's state), animated over time with a scrubber that also jumps by block height; beside it each
//! robot's tokens, the loss per round and the chain (forks and reorgs) up to the current time.
//! A baseline run (`learn.aggregation` = `gossip` or `central`) has no blocks or tokens: its
//! page shows each robot's model version instead of its tokens, the loss per aggregation (the
//! rows of `export`'s rounds table, as `summary.json` counts them) and every aggregation over
//! time instead of the chain.
//!
//! Two folds of the log: [`inspect::index_run`] for the final canonical chain, its balances
//! and rounds; then a second fold that samples frames. Thinning: frames every
//! `duration / 2000` s (a whole number of ticks; every tick for short runs) plus one frame at
//! the sealing of every block of the final canonical chain, so the picture at a block is the
//! log's state at that block exactly (what `swarmfl inspect --block H` prints). Positions are
//! stored in millimetres and headings in degrees (integers), radio links as a bit set per
//! frame: a paper run (5000 s, 15 robots) makes a file of about 1 MB.
//!
//! The page writes its state into `<pre id="status">` (JSON: the time shown, the canonical
//! height, every robot's position and tokens, script errors), so a headless browser's
//! `--dump-dom` can check it against the log (`scripts/view_check.sh`).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;
use std::process::ExitCode;

use anyhow::Context;
use swarmfl_core::config::{Aggregation, Behaviour};
use swarmfl_core::event::{CheckpointCause, Event, Record};
use swarmfl_core::inspect::{self, expr::Env, Column};
use swarmfl_core::log::{LogError, LogReader};
use swarmfl_core::replay;
use swarmfl_core::state::State;
use swarmfl_core::world::{Forager, Obstacle};
use swarmfl_core::Digest;

use crate::cli::ViewArgs;
use crate::commands::inspect::warn_if_truncated;

/// Runs `swarmfl view`: writes the page and says what it holds.
pub fn command(args: ViewArgs) -> anyhow::Result<ExitCode> {
    let ViewArgs { log, out } = args;
    let v = view(&log, &out)?;
    if let Some((kind, count)) = v.aggregations {
        println!(
            "wrote {} ({:.1} MB: {} frames, one every {} s; a {kind} run has no blocks: its {count} \
             aggregations, as summary.json counts them); open it in a browser",
            out.display(),
            v.bytes as f64 / 1.0e6,
            v.frames,
            v.frame_s,
        );
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "wrote {} ({:.1} MB: {} frames, one every {} s plus one per block of the final \
         chain; {} sealings on all forks (every block any node sealed, genesis apart), final \
         canonical chain height {}); open it in a browser",
        out.display(),
        v.bytes as f64 / 1.0e6,
        v.frames,
        v.frame_s,
        v.sealings,
        v.height
    );
    Ok(ExitCode::SUCCESS)
}

/// Most uniform frames of a view (block frames come on top).
const MAX_FRAMES: u64 = 2000;

/// What `view` wrote.
pub struct ViewOutcome {
    /// Frames in the file.
    pub frames: usize,
    /// Blocks sealed by any node on any fork (genesis apart).
    pub sealings: u64,
    /// Height of the final canonical chain.
    pub height: u64,
    /// Size of the HTML file in bytes.
    pub bytes: usize,
    /// Seconds between uniform frames.
    pub frame_s: f64,
    /// A baseline run's aggregation (`gossip`, `central`) and its aggregations in the page;
    /// `None` for a chain run.
    pub aggregations: Option<(&'static str, usize)>,
}

/// Writes the viewer of `log` into `out`.
pub fn view(log: &Path, out: &Path) -> anyhow::Result<ViewOutcome> {
    let page = Page::build(log, None)?;
    warn_if_truncated(&page.index);
    let html = page.html();
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create the folder {}", dir.display()))?;
    }
    std::fs::write(out, &html).with_context(|| format!("cannot write {}", out.display()))?;
    Ok(ViewOutcome {
        frames: page.frames,
        sealings: page.sealings,
        height: page.index.last_height(),
        bytes: html.len(),
        frame_s: page.frame_ms as f64 / 1000.0,
        aggregations: page.aggregations,
    })
}

/// What the live view (`run --live`) adds to a page's data: where the run is, so the page
/// follows it and says when it has ended.
#[derive(Clone, Copy, Debug)]
pub struct LiveState {
    /// Counts the pages built during the run; the page asks for a newer one.
    pub version: u64,
    /// The run has ended and this page holds its whole log.
    pub ended: bool,
    /// How often the page asks for a newer version, in milliseconds.
    pub poll_ms: u64,
}

/// The viewer's data for a log (or the intact prefix of a log still being written): what
/// `swarmfl view` writes into its page and what the live view serves.
pub struct Page {
    /// The first fold: the canonical chain, balances and rounds.
    pub index: inspect::RunIndex,
    /// The page's title.
    pub title: String,
    /// The page's data object as JSON text.
    pub data: String,
    /// Frames in the data.
    pub frames: usize,
    /// Blocks sealed by any node on any fork (genesis apart): the log's block checkpoints.
    pub sealings: u64,
    /// Milliseconds between uniform frames.
    pub frame_ms: u64,
    /// A baseline run's aggregation and its aggregations in the data; `None` for a chain run.
    pub aggregations: Option<(&'static str, usize)>,
}

impl Page {
    /// Folds `log` (as far as it is intact) into the viewer's data; `live` is `None` for a
    /// finished run's page.
    pub fn build(log: &Path, live: Option<LiveState>) -> anyhow::Result<Page> {
        let index = inspect::index_run(log, None)?;
        let config = &index.config;
        // Uniform frames every `every_ticks` ticks.
        let tick_ms = (config.run.tick_s * 1000.0).round().max(1.0) as u64;
        let total_ticks = config.ticks().max(1);
        let every_ticks = total_ticks.div_ceil(MAX_FRAMES).max(1);
        let frame_ms = every_ticks * tick_ms;
        let walk = Walk::fold(log, &index, tick_ms, frame_ms)?;
        // The run first (what a reader of a screenshot wants), its file last.
        let title = format!(
            "{}preset {}, seed {}, {} robots, {} s — {}",
            if live.is_some() { "live: " } else { "" },
            config.preset,
            index.seed,
            config.world.robots,
            config.run.duration_s,
            log.display()
        );
        let upto_ms = walk.frames.t.iter().copied().max().unwrap_or(0);
        let data = page_data(
            &index,
            &walk,
            &title,
            total_ticks * tick_ms,
            frame_ms,
            live.map(|l| (l, upto_ms)),
        )?;
        let kind = config.learn.aggregation;
        let aggregations = (kind != Aggregation::Chain)
            .then(|| index.rounds_table().map(|t| (kind.name(), t.rows())))
            .transpose()?;
        Ok(Page {
            aggregations,
            frames: walk.frames.t.len(),
            sealings: walk.sealings,
            index,
            title,
            data,
            frame_ms,
        })
    }

    /// The self-contained page: the viewer with this data.
    pub fn html(&self) -> String {
        TEMPLATE
            .replace("__TITLE__", &html_escape(&self.title))
            // `</` cannot appear inside the data: JSON strings escape it.
            .replace("__DATA__", &self.data.replace("</", "<\\/"))
    }
}

/// The second fold of the log: frames, every node's blocks and the reorgs.
struct Walk {
    /// The state at the end of the intact prefix.
    state: State,
    /// Every block seen (any node's), numbered in sealing order; genesis is 0.
    ids: BTreeMap<Digest, u32>,
    /// JSON: `[id, parent id, height, node, time ms]` per block.
    blocks: String,
    /// JSON: `[time ms, node, depth]` per reorg.
    reorgs: String,
    /// Reorgs written into `reorgs`.
    reorg_count: usize,
    /// Block checkpoints folded: every sealing of any node.
    sealings: u64,
    /// Every node's head after the last ledger event.
    heads: Vec<Digest>,
    /// The sampled frames.
    frames: Frames,
}

impl Walk {
    /// Folds the records of the intact prefix of `log` (the `index.records` that
    /// [`inspect::index_run`] read), sampling a frame every `frame_ms` and at every block of
    /// the final canonical chain.
    fn fold(
        log: &Path,
        index: &inspect::RunIndex,
        tick_ms: u64,
        frame_ms: u64,
    ) -> anyhow::Result<Walk> {
        let name = log.display().to_string();
        let canonical: BTreeMap<Digest, u64> =
            index.chain.iter().map(|r| (r.hash, r.height)).collect();
        let mut reader = LogReader::open(log).map_err(replay::ReplayError::from)?;
        let header_config = replay::header_config(&reader, &name)?;
        let state = State::genesis(&header_config, index.seed).map_err(|cause| {
            replay::ReplayError::Start {
                path: name.clone(),
                cause,
            }
        })?;
        let genesis = state.ledger.head(0).0;
        let mut walk = Walk {
            ids: BTreeMap::from([(genesis, 0)]),
            blocks: String::from("[[0,-1,0,-1,0]"),
            reorgs: String::from("["),
            reorg_count: 0,
            sealings: 0,
            heads: vec![genesis; index.config.world.robots as usize],
            frames: Frames::default(),
            state,
        };
        walk.frames.push(&walk.state, &walk.ids, 0);
        let mut next_frame_ms = frame_ms;
        while reader.index() < index.records {
            let record = match reader.next_record() {
                Ok(Some(r)) => r,
                Ok(None) => break,
                Err(LogError::Truncated { .. }) => break,
                Err(e) => return Err(replay::ReplayError::from(e).into()),
            };
            let at = reader.index() - 1;
            replay::fold_record(&mut walk.state, &name, at, &record)?;
            match &record {
                Record::Event {
                    event: Event::Ledger(_),
                    time,
                } => walk.note_reorgs(time.0),
                Record::Checkpoint(cp) => {
                    if let CheckpointCause::Block { node, height } = cp.cause {
                        walk.sealings += 1;
                        walk.note_block(node, height, cp.time.0, &canonical);
                    }
                }
                Record::Event {
                    time,
                    event: Event::Tick(_),
                } => {
                    let now = time.0 + tick_ms;
                    if now >= next_frame_ms {
                        walk.frames.push(&walk.state, &walk.ids, now);
                        next_frame_ms = (now / frame_ms + 1) * frame_ms;
                    }
                }
                Record::Event { .. } => {}
            }
        }
        walk.blocks.push(']');
        walk.reorgs.push(']');
        Ok(walk)
    }

    /// After a ledger event at `time_ms`: every node whose new head does not descend from its
    /// old one had a reorg; records it with its depth (blocks of the old branch abandoned).
    fn note_reorgs(&mut self, time_ms: u64) {
        let ledger = &self.state.ledger;
        for (node, old) in self.heads.iter_mut().enumerate() {
            let (new, height) = ledger.head(node as u32);
            if new == *old {
                continue;
            }
            let old_height = ledger.block(old).map_or(0, |e| e.block.header.height);
            // The new head's ancestor at the old head's height.
            let mut cursor = new;
            let mut h = height;
            while h > old_height {
                match ledger.block(&cursor) {
                    Some(e) => cursor = e.block.header.parent,
                    None => break,
                }
                h -= 1;
            }
            if cursor != *old {
                let mut a = *old;
                let mut b = cursor;
                let mut depth = 0u64;
                while a != b {
                    let (Some(ea), Some(eb)) = (ledger.block(&a), ledger.block(&b)) else {
                        break;
                    };
                    a = ea.block.header.parent;
                    b = eb.block.header.parent;
                    depth += 1;
                }
                let _ = write!(
                    self.reorgs,
                    "{}[{time_ms},{node},{depth}]",
                    if self.reorg_count == 0 { "" } else { "," },
                );
                self.reorg_count += 1;
            }
            *old = new;
        }
    }

    /// At the checkpoint of `node` sealing a block at `height`: numbers the block if new, and
    /// takes a frame if it is a block of the final canonical chain.
    fn note_block(
        &mut self,
        node: u32,
        height: u64,
        time_ms: u64,
        canonical: &BTreeMap<Digest, u64>,
    ) {
        let (hash, _) = self.state.ledger.head(node);
        if !self.ids.contains_key(&hash) {
            let id = self.ids.len() as u32;
            self.ids.insert(hash, id);
            let parent = self
                .state
                .ledger
                .block(&hash)
                .and_then(|e| self.ids.get(&e.block.header.parent).copied())
                .map_or(-1, i64::from);
            let _ = write!(self.blocks, ",[{id},{parent},{height},{node},{time_ms}]");
        }
        if canonical.get(&hash) == Some(&height) {
            self.frames.push(&self.state, &self.ids, time_ms);
        }
    }
}

/// The page's data object as JSON text.
fn page_data(
    index: &inspect::RunIndex,
    walk: &Walk,
    title: &str,
    duration_ms: u64,
    frame_ms: u64,
    live: Option<(LiveState, u64)>,
) -> anyhow::Result<String> {
    let config = &index.config;
    let (chain, balances) = chain_json(index, &walk.ids);
    let rounds = rounds_json(index)?;
    let arena = walk.state.world.arena();
    let obstacles: Vec<String> = arena
        .obstacles
        .iter()
        .map(|o| match *o {
            Obstacle::Cylinder { x, y, radius_m } => format!("[\"c\",{x},{y},{radius_m}]"),
            Obstacle::Box { x, y, half_side_m } => format!("[\"b\",{x},{y},{half_side_m}]"),
        })
        .collect();
    let byzantine: Vec<&str> = index
        .byzantine
        .iter()
        .map(|&b| if b { "1" } else { "0" })
        .collect();
    // Behaviours: each robot's name, the nest `[x, y, r]` and food `[x, y]` (empty without).
    let behaviours = walk.state.world.behaviours();
    let names: Vec<String> = (0..config.world.robots as usize)
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
    let frames = &walk.frames;
    // A block's frame may be taken after the frame of the tick's end: order by time (stable,
    // so a block's frame follows a tick frame of the same time and wins at that time).
    let mut order: Vec<usize> = (0..frames.t.len()).collect();
    order.sort_by_key(|&k| frames.t[k]);
    let pick = |v: &[String]| {
        order
            .iter()
            .map(|&k| v[k].as_str())
            .collect::<Vec<_>>()
            .join(",")
    };
    let times = order
        .iter()
        .map(|&k| frames.t[k].to_string())
        .collect::<Vec<_>>()
        .join(",");
    let live = match live {
        Some((l, upto_ms)) => format!(
            "{{\"version\":{},\"ended\":{},\"poll_ms\":{},\"upto_ms\":{upto_ms}}}",
            l.version, l.ended, l.poll_ms
        ),
        None => "null".to_string(),
    };
    Ok(format!(
        "{{\"title\":{},\"robots\":{},\"half\":{},\"radius\":{},\"range\":{},\
         \"duration_ms\":{duration_ms},\"frame_ms\":{frame_ms},\"obstacles\":[{}],\"byzantine\":[{}],\
         \"behaviour\":[{}],\"nest\":{nest},\"food\":[{}],\"food_radius\":{food_radius},\
         \"t\":[{}],\"pose\":[{}],\"links\":[{}],\"heads\":[{}],\"forager\":[{}],\"versions\":[{}],\
         \"blocks\":{},\"aggregation\":\"{}\",\"chain\":{chain},\"balances\":{balances},\"rounds\":{rounds},\"reorgs\":{},\
         \"truncated\":{},\"live\":{live}}}",
        serde_json::to_string(title)?,
        config.world.robots,
        arena.half_side_m,
        config.world.robot_radius_m,
        config.world.rab_range_m,
        obstacles.join(","),
        byzantine.join(","),
        names.join(","),
        food.join(","),
        times,
        pick(&frames.pose),
        pick(&frames.links),
        pick(&frames.heads),
        pick(&frames.forager),
        pick(&frames.versions),
        walk.blocks,
        config.learn.aggregation.name(),
        walk.reorgs,
        serde_json::to_string(&index.truncated)?,
    ))
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
fn rounds_json(index: &inspect::RunIndex) -> anyhow::Result<String> {
    if index.config.learn.aggregation != Aggregation::Chain {
        return baseline_rounds_json(index);
    }
    let values = index.values();
    let mut rounds = String::from("[");
    for (k, r) in index.rounds().iter().enumerate() {
        let heldout = values.at(r.block).ident("heldout_loss").unwrap_or(f64::NAN);
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

/// Escapes text for HTML.
fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// The sampled frames, each field already JSON text.
#[derive(Default)]
struct Frames {
    t: Vec<u64>,
    pose: Vec<String>,
    links: Vec<String>,
    heads: Vec<String>,
    /// Each robot's forager state as one letter (`e` explore, `r` return, `s` rest, `-` not a
    /// forager); empty text when nobody forages.
    forager: Vec<String>,
    /// A baseline's model version of each robot (`gossip`: the merges it made; `central`: the
    /// server's round it holds); `null` for a chain run.
    versions: Vec<String>,
}

impl Frames {
    /// Adds the frame of `state` at `time_ms`: poses, links and every node's head block.
    fn push(&mut self, state: &State, ids: &BTreeMap<Digest, u32>, time_ms: u64) {
        let world = &state.world;
        let n = world.poses().len();
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
        let heads: Vec<String> = (0..n as u32)
            .map(|r| {
                let h = state.ledger.head(r).0;
                ids.get(&h).map_or("0".to_string(), |id| id.to_string())
            })
            .collect();
        self.heads.push(format!("[{}]", heads.join(",")));
        let forager: String = match world.behaviours().filter(|b| b.nest.is_some()) {
            Some(b) => {
                b.of.iter()
                    .zip(&b.foragers)
                    .map(|(&of, f)| match (of, f) {
                        (Behaviour::Foraging, Forager::Explore) => 'e',
                        (Behaviour::Foraging, Forager::Return) => 'r',
                        (Behaviour::Foraging, Forager::Rest { .. }) => 's',
                        _ => '-',
                    })
                    .collect()
            }
            None => String::new(),
        };
        self.forager.push(format!("\"{forager}\""));
        let versions = if state.aggregation.kind() == Aggregation::Chain {
            "null".to_string()
        } else {
            let v: Vec<String> = (0..n as u32)
                .map(|r| state.aggregation.current(r).round.to_string())
                .collect();
            format!("[{}]", v.join(","))
        };
        self.versions.push(versions);
    }
}

const TEMPLATE: &str = include_str!("view.html");

#[cfg(test)]
mod tests {
    use super::*;

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
        let html = TEMPLATE;
        assert!(html.contains("__DATA__") && html.contains("id=\"status\""));
        assert!(
            !html.contains("http://") && !html.contains("https://"),
            "no network"
        );
    }
}
