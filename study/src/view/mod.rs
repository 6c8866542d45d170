//! `swarmfl view LOG --out run.html`: one self-contained HTML file to watch a run in a browser
//! (no network, no server): the arena with obstacles, robots with ids, Byzantine marks and radio
//! links (with behaviours, `world.behaviour`: robots coloured by behaviour, the foraging nest and
//! food sources, each forager's state; under Flow-FL's foraging, `world.foraging.rule =
//! "flowfl"`, its nest strip and the items on the floor at each frame), animated over time with a scrubber that also jumps by block height; beside it each
//! robot's tokens, the loss per round and the chain (forks and reorgs) up to the current time.
//! A baseline run (`learn.aggregation` = `gossip` or `central`) has no blocks or tokens: its
//! page shows each robot's model version instead of its tokens, the loss per aggregation (the
//! rows of `export`'s rounds table, as `summary.json` counts them) and every aggregation over
//! time instead of the chain.
//!
//! One pass over the log ([`Fold`]) feeds each record to the index ([`inspect::Indexer`]: the
//! final canonical chain, its balances and rounds) and to a walk that samples frames from the
//! index's state; kept between pages, it lets the live view fold only what the log gained.
//! Thinning: frames every
//! `duration / 2000` s (a whole number of ticks; every tick for short runs) plus one frame at
//! the sealing of every block of the final canonical chain, so the picture at a block is the
//! log's state at that block exactly (what `swarmfl inspect --block H` prints). Positions are
//! stored in millimetres and headings in degrees (integers), radio links as a bit set per
//! frame: a paper run (5000 s, 15 robots) makes a file of about 1 MB.
//!
//! A log whose contract runs a plug-in rule this process has not loaded (the command loads
//! none) cannot be indexed: the rule computes its tokens, rounds and chain. Its page
//! (`world_page`) holds the world alone, folded from the ticks with the world's digest checked
//! at every checkpoint, and a note in place of the contract's panes naming the rule and the
//! Python call that draws them.
//!
//! The page writes its state into `<pre id="status">` (JSON: the time shown, the canonical
//! height, every robot's position and tokens, script errors), so a headless browser's
//! `--dump-dom` can check it against the log (`scripts/view_check.sh`).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use anyhow::Context;
use swarmfl_core::config::{Aggregation, Behaviour, Config, MixedAssign, Rule};
use swarmfl_core::contract::rules::plugin as rule_plugin;
use swarmfl_core::event::{CheckpointCause, Event, Record};
use swarmfl_core::inspect::{self, expr::Env, Column};
use swarmfl_core::log::{LogReader, Next};
use swarmfl_core::replay;
use swarmfl_core::state::{apply_tick, SimError, State};
use swarmfl_core::world::{foraging_flowfl, Behaviours, Forager, Obstacle, World};
use swarmfl_core::Digest;

use crate::progress::{warn_if_truncated, Watch};

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
    /// For a log whose plug-in rule is not loaded, the page's note on what it shows (the world)
    /// and where the contract's results are drawn; `None` for every other log.
    pub rule_note: Option<String>,
}

/// Writes the viewer of `log` into `out`; a truncated log is warned of on `watch`.
pub fn view(log: &Path, out: &Path, watch: &dyn Watch) -> anyhow::Result<ViewOutcome> {
    let page = match unloaded_rule(log)? {
        // The contract's results need the rule: the page draws the world from its records.
        Some(rule) => world_page(log, &rule, watch)?,
        None => {
            let mut fold = Fold::open(log)?;
            fold.advance()?;
            let page = fold.page(None)?;
            warn_if_truncated(watch, fold.index()?);
            page
        }
    };
    let html = page.html();
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create the folder {}", dir.display()))?;
    }
    std::fs::write(out, &html).with_context(|| format!("cannot write {}", out.display()))?;
    Ok(ViewOutcome {
        frames: page.frames,
        sealings: page.sealings,
        height: page.height,
        bytes: html.len(),
        frame_s: page.frame_ms as f64 / 1000.0,
        aggregations: page.aggregations,
        rule_note: page.rule_note,
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
    /// The page's title.
    pub title: String,
    /// The page's data object as JSON text.
    pub data: String,
    /// Frames in the data.
    pub frames: usize,
    /// Blocks sealed by any node on any fork (genesis apart): the log's block checkpoints.
    pub sealings: u64,
    /// Height of the final canonical chain (of the records folded).
    pub height: u64,
    /// Milliseconds between uniform frames.
    pub frame_ms: u64,
    /// A baseline run's aggregation and its aggregations in the data; `None` for a chain run.
    pub aggregations: Option<(&'static str, usize)>,
    /// A log whose plug-in rule is not loaded: the note the page shows instead of the
    /// contract's panes (see [`world_page`]); `None` for every other log.
    pub rule_note: Option<String>,
}

impl Page {
    /// The self-contained page: the viewer with this data.
    pub fn html(&self) -> String {
        let html = TEMPLATE
            .replace("__TITLE__", &html_escape(&self.title))
            // `</` cannot appear inside the data: JSON strings escape it.
            .replace("__DATA__", &self.data.replace("</", "<\\/"));
        match &self.rule_note {
            // The note takes the place of the contract's panes, which stay hidden (the page
            // of every other log is the template's, byte for byte).
            Some(note) => html.replacen(
                RULE_NOTE_ANCHOR,
                &format!(
                    "{RULE_NOTE_STYLE}<div class=\"note\" id=\"ruleNote\">{}</div>\n{RULE_NOTE_ANCHOR}",
                    html_escape(note)
                ),
                1,
            ),
            None => html,
        }
    }
}

/// Where a plug-in rule's note goes: the top of the side column, before the contract's panes.
const RULE_NOTE_ANCHOR: &str = "<div class=\"label\" id=\"tokensLabel\">";

/// Hides the contract's panes (and the block slider) of a page drawn without its plug-in rule.
const RULE_NOTE_STYLE: &str = "<style>#tokensLabel, #tokens, #lossLabel, #loss, #chainLabel, \
     #reorgs, #chain, #chainNote, #blockBox { display: none; } #ruleNote { border: 1px solid \
     #a86; background: #f8e8e0; padding: 6px 8px; max-width: 540px; }</style>";

/// The viewer's fold of a log, kept between pages: each record is read and folded once, so the
/// live view's page after the log grew costs the new records (and the page's own size), not
/// the whole log again. One pass feeds both the index of the canonical chain
/// ([`inspect::Indexer`]) and the [`Walk`] that samples frames from the same state.
pub struct Fold {
    path: PathBuf,
    reader: LogReader<BufReader<File>>,
    indexer: inspect::Indexer,
    walk: Walk,
    /// Why the log ends where the reader stands; `None` once its footer has been read.
    truncated: Option<String>,
    /// The held-out loss at each round's closing block, by block (see [`rounds_json`]); emptied
    /// by a reconfiguration, which may change the model or the held-out set.
    heldout: BTreeMap<Digest, f64>,
}

/// Most times [`Fold::page`] folds the log again because its frame grid moved.
const MAX_REFOLDS: u32 = 8;

impl Fold {
    /// Opens `log` and reads its header; nothing is folded yet.
    pub fn open(log: &Path) -> anyhow::Result<Fold> {
        let reader = LogReader::open(log).map_err(replay::ReplayError::from)?;
        let name = log.display().to_string();
        let indexer = inspect::Indexer::start(&reader, &name, None)?;
        let walk = Walk::start(indexer.state(), Grid::of(indexer.config()));
        Ok(Fold {
            path: log.to_path_buf(),
            reader,
            indexer,
            walk,
            truncated: Some("nothing read yet".to_string()),
            heldout: BTreeMap::new(),
        })
    }

    /// Folds every record the file holds past the last one folded, up to its end or to a frame
    /// still being written. A damaged record is an error (and the fold must not be used again).
    pub fn advance(&mut self) -> anyhow::Result<()> {
        loop {
            match self
                .reader
                .next_intact()
                .map_err(replay::ReplayError::from)?
            {
                Next::Record(record) => {
                    let at = self.reader.index() - 1;
                    self.indexer.feed(at, &record)?;
                    self.walk.note(self.indexer.state(), &record);
                    if replay::reconfigured(&record).is_some() {
                        self.heldout.clear();
                    }
                }
                Next::End => {
                    self.truncated = None;
                    return Ok(());
                }
                Next::Pending(cut) => {
                    self.truncated = Some(cut.to_string());
                    return Ok(());
                }
            }
        }
    }

    /// The index of the records folded.
    pub fn index(&mut self) -> anyhow::Result<&inspect::RunIndex> {
        Ok(self.indexer.index(self.truncated.clone())?)
    }

    /// The page of the records folded (`live`: `None` for a finished run's page): the same
    /// data, byte for byte, as the page of one fold of a file that holds just those records.
    pub fn page(&mut self, live: Option<LiveState>) -> anyhow::Result<Page> {
        // The grid comes from the configuration after the last record: a reconfiguration of
        // the tick or the duration moves it, and the frames are sampled again from the start.
        let mut refolds = 0;
        while Grid::of(self.indexer.config()) != self.walk.grid {
            anyhow::ensure!(
                refolds < MAX_REFOLDS,
                "{}: the frame grid of the view moved {MAX_REFOLDS} times (reconfigurations \
                 of run.tick_s or run.duration_s); view the finished log",
                self.path.display()
            );
            self.refold(Grid::of(self.indexer.config()))?;
            refolds += 1;
        }
        let path = self.path.display().to_string();
        let truncated = self.truncated.clone();
        let walk = &self.walk;
        let index = self.indexer.index(truncated)?;
        let config = &index.config;
        let grid = walk.grid;
        // The run first (what a reader of a screenshot wants), its file last.
        let title = format!(
            "{}preset {}, seed {}, {} robots, {} s — {path}",
            if live.is_some() { "live: " } else { "" },
            config.preset,
            index.seed,
            config.world.robots,
            config.run.duration_s,
        );
        let frames = walk.frames.shown(index);
        let upto_ms = frames.iter().map(|&k| walk.frames.t[k]).max().unwrap_or(0);
        let data = page_data(
            index,
            walk,
            &frames,
            &mut self.heldout,
            &title,
            live.map(|l| (l, upto_ms)),
        )?;
        let kind = config.learn.aggregation;
        let aggregations = (kind != Aggregation::Chain)
            .then(|| index.rounds_table().map(|t| (kind.name(), t.rows())))
            .transpose()?;
        Ok(Page {
            aggregations,
            frames: frames.len(),
            sealings: walk.sealings,
            height: index.last_height(),
            title,
            data,
            frame_ms: grid.frame_ms,
            rule_note: None,
        })
    }

    /// Folds the log again from its start on `grid`, as far as the records folded so far.
    fn refold(&mut self, grid: Grid) -> anyhow::Result<()> {
        let mut fresh = Fold::open(&self.path)?;
        fresh.walk = Walk::start(fresh.indexer.state(), grid);
        let name = self.path.display().to_string();
        while fresh.indexer.records() < self.indexer.records() {
            let Next::Record(record) = fresh
                .reader
                .next_intact()
                .map_err(replay::ReplayError::from)?
            else {
                anyhow::bail!("{name}: the log became shorter while it was read");
            };
            let at = fresh.reader.index() - 1;
            fresh.indexer.feed(at, &record)?;
            fresh.walk.note(fresh.indexer.state(), &record);
        }
        // The same records and the same end: the footer, or the cut as it was.
        if self.truncated.is_none() {
            fresh.advance()?;
        }
        fresh.truncated = self.truncated.clone();
        *self = fresh;
        Ok(())
    }
}

/// The plug-in rule `log`'s contract runs when it is not loaded in this process (the `swarmfl`
/// command loads none): its name. `None` when the log runs a built-in rule, a baseline, or a
/// plug-in rule registered here (the Python package's `Run.view`).
fn unloaded_rule(log: &Path) -> anyhow::Result<Option<String>> {
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
fn world_page(log: &Path, rule: &str, watch: &dyn Watch) -> anyhow::Result<Page> {
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

/// Where the uniform frames fall: every `frame_ms`, a whole number of ticks (every tick of a
/// short run), at most [`MAX_FRAMES`] over the run's duration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Grid {
    tick_ms: u64,
    total_ticks: u64,
    frame_ms: u64,
    robots: u32,
}

impl Grid {
    /// The grid of a run with `config`.
    fn of(config: &Config) -> Grid {
        let tick_ms = (config.run.tick_s * 1000.0).round().max(1.0) as u64;
        let total_ticks = config.ticks().max(1);
        let every_ticks = total_ticks.div_ceil(MAX_FRAMES).max(1);
        Grid {
            tick_ms,
            total_ticks,
            frame_ms: every_ticks * tick_ms,
            robots: config.world.robots,
        }
    }
}

/// The second fold of the log: frames, every node's blocks and the reorgs, read from the
/// index's state after each record.
struct Walk {
    /// Where the uniform frames fall.
    grid: Grid,
    /// The time of the next uniform frame.
    next_frame_ms: u64,
    /// Every block seen (any node's), numbered in sealing order; genesis is 0.
    ids: BTreeMap<Digest, u32>,
    /// JSON without its closing bracket: `[id, parent id, height, node, time ms]` per block.
    blocks: String,
    /// JSON without its closing bracket: `[time ms, node, depth]` per reorg.
    reorgs: String,
    /// Reorgs written into `reorgs`.
    reorg_count: usize,
    /// Block checkpoints folded: every sealing of any node.
    sealings: u64,
    /// Every node's head after the last ledger event.
    heads: Vec<Digest>,
    /// The sampled frames: every uniform one, and one at every sealing (shown when its block
    /// is on the final canonical chain of the records folded).
    frames: Frames,
}

impl Walk {
    /// A walk at genesis (`state`) on `grid`, with the frame at time 0.
    fn start(state: &State, grid: Grid) -> Walk {
        let genesis = state.ledger.head(0).0;
        let mut walk = Walk {
            grid,
            next_frame_ms: grid.frame_ms,
            ids: BTreeMap::from([(genesis, 0)]),
            blocks: String::from("[[0,-1,0,-1,0]"),
            reorgs: String::from("["),
            reorg_count: 0,
            sealings: 0,
            heads: vec![genesis; grid.robots as usize],
            frames: Frames::default(),
        };
        walk.frames.push(state, &walk.ids, 0, None);
        walk
    }

    /// Notes `record`, which the index has just folded into `state`: a ledger event's reorgs,
    /// a block checkpoint's block and frame, a tick's uniform frame when one falls due.
    fn note(&mut self, state: &State, record: &Record) {
        match record {
            Record::Event {
                event: Event::Ledger(_),
                time,
            } => self.note_reorgs(state, time.0),
            Record::Checkpoint(cp) => {
                if let CheckpointCause::Block { node, height } = cp.cause {
                    self.sealings += 1;
                    self.note_block(state, node, height, cp.time.0);
                }
            }
            Record::Event {
                time,
                event: Event::Tick(_),
            } => {
                let now = time.0 + self.grid.tick_ms;
                if now >= self.next_frame_ms {
                    self.frames.push(state, &self.ids, now, None);
                    let frame_ms = self.grid.frame_ms;
                    self.next_frame_ms = (now / frame_ms + 1) * frame_ms;
                }
            }
            Record::Event { .. } => {}
        }
    }

    /// After a ledger event at `time_ms`: every node whose new head does not descend from its
    /// old one had a reorg; records it with its depth (blocks of the old branch abandoned).
    fn note_reorgs(&mut self, state: &State, time_ms: u64) {
        let ledger = &state.ledger;
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
    /// takes its frame (shown if the block is on the final canonical chain).
    fn note_block(&mut self, state: &State, node: u32, height: u64, time_ms: u64) {
        let (hash, _) = state.ledger.head(node);
        if !self.ids.contains_key(&hash) {
            let id = self.ids.len() as u32;
            self.ids.insert(hash, id);
            let parent = state
                .ledger
                .block(&hash)
                .and_then(|e| self.ids.get(&e.block.header.parent).copied())
                .map_or(-1, i64::from);
            let _ = write!(self.blocks, ",[{id},{parent},{height},{node},{time_ms}]");
        }
        self.frames
            .push(state, &self.ids, time_ms, Some((hash, height)));
    }
}

/// The page's data object as JSON text.
fn page_data(
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
/// whose plug-in rule is not loaded gives its world alone ([`world_page`]).
struct Parts<'a> {
    config: &'a Config,
    /// The world at the end of the records folded.
    world: &'a World,
    byzantine: &'a [bool],
    /// JSON text: the final canonical chain, the balances after each of its blocks, the rounds.
    chain: &'a str,
    balances: &'a str,
    rounds: &'a str,
    truncated: &'a Option<String>,
    /// JSON members appended to the data object (each with its leading comma); empty for every
    /// log but a plug-in rule's drawn without the rule.
    extra: &'a str,
}

/// The page's data object as JSON text from its parts and frames.
fn data_json(
    parts: &Parts,
    walk: &Walk,
    shown: &[usize],
    title: &str,
    live: Option<(LiveState, u64)>,
) -> anyhow::Result<String> {
    let grid = walk.grid;
    let (duration_ms, frame_ms) = (grid.total_ticks * grid.tick_ms, grid.frame_ms);
    let config = parts.config;
    let (chain, balances, rounds) = (parts.chain, parts.balances, parts.rounds);
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
    // Behaviours: each robot's name, the nest `[x, y, r]` and food `[x, y]` of the `simple`
    // rule (null and empty without).
    let behaviours = parts.world.behaviours();
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
    let mut order = shown.to_vec();
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
    // Flow-FL's foraging arena: the nest strip west of its edge and, per frame, the items on
    // the floor. Only its runs have the keys, so every other run's data is as it was.
    let flowfl = if order.iter().any(|&k| frames.items[k] != "null") {
        format!(
            ",\"nest_strip\":{},\"items\":[{}]",
            foraging_flowfl::NEST_EDGE_X_M,
            items_json(&order, &frames.items)
        )
    } else {
        String::new()
    };
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
         \"behaviour\":[{}],\"nest\":{nest},\"food\":[{}],\"food_radius\":{food_radius}{flowfl},\
         \"t\":[{}],\"pose\":[{}],\"links\":[{}],\"heads\":[{}],\"forager\":[{}],\"of\":[{}],\"versions\":[{}],\
         \"blocks\":{}],\"aggregation\":\"{}\",\"chain\":{chain},\"balances\":{balances},\"rounds\":{rounds},\"reorgs\":{}],\
         \"truncated\":{},\"live\":{live}{}}}",
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
        pick(&frames.of),
        pick(&frames.versions),
        walk.blocks,
        config.learn.aggregation.name(),
        walk.reorgs,
        serde_json::to_string(parts.truncated)?,
        parts.extra,
    ))
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

/// Escapes text for HTML.
fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// The sampled frames, each field already JSON text.
#[derive(Default)]
struct Frames {
    /// The block (and its height) of a frame taken at its sealing; `None` for a uniform one.
    block: Vec<Option<(Digest, u64)>>,
    t: Vec<u64>,
    pose: Vec<String>,
    links: Vec<String>,
    heads: Vec<String>,
    /// Each robot's forager state as one letter (see [`forager_letter`]); empty text when
    /// nobody forages.
    forager: Vec<String>,
    /// Flow-FL's items on the floor (`world.foraging.rule = "flowfl"`), `[x, y, ...]` in
    /// millimetres in item order (carried ones left out); `null` under any other rule. The
    /// page's data lists each change once ([`items_json`]).
    items: Vec<String>,
    /// Each robot's behaviour at the frame as one letter (`a` avoidance, `f` flocking, `o`
    /// foraging) when behaviours follow places (`world.mixed.assign = "place"`); empty text
    /// when each robot keeps one behaviour (the page's `behaviour` then holds it).
    of: Vec<String>,
    /// A baseline's model version of each robot (`gossip`: the merges it made; `central`: the
    /// server's round it holds); `null` for a chain run.
    versions: Vec<String>,
}

impl Frames {
    /// The frames the page shows, in the order taken: every uniform one, and those taken at
    /// the sealing of a block of the final canonical chain of `index`.
    fn shown(&self, index: &inspect::RunIndex) -> Vec<usize> {
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
    fn push(
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
    fn push_world(
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
fn forager_letter(b: &Behaviours, i: usize) -> char {
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

const TEMPLATE: &str = include_str!("view.html");

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write as _;

    fn fixture(name: &str) -> Vec<u8> {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../fixtures/logs")
            .join(format!("{name}.swlog"));
        std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
    }

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("swarmfl-view-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// A page of one fold of the file at `log` as it is now.
    fn whole(log: &Path, live: Option<LiveState>) -> Page {
        let mut fold = Fold::open(log).unwrap();
        fold.advance().unwrap();
        fold.page(live).unwrap()
    }

    /// Grows a copy of `bytes` at `cuts` (byte counts, rising; the last the whole file), one
    /// fold following it: after each growth its page must be that of one fold of the file as
    /// it is then. Returns the folds' largest count of frames not shown (taken at a sealing
    /// of a block that was, or is not yet known to be, off the final chain).
    fn check_growing(name: &str, bytes: &[u8], cuts: &[usize]) -> usize {
        let dir = scratch(name);
        let log = dir.join("run.swlog");
        let mut file = std::fs::File::create(&log).unwrap();
        file.write_all(&bytes[..cuts[0]]).unwrap();
        let mut fold = Fold::open(&log).unwrap();
        let mut hidden = 0;
        let mut written = cuts[0];
        for (k, &cut) in cuts.iter().enumerate() {
            file.write_all(&bytes[written..cut]).unwrap();
            written = cut;
            fold.advance().unwrap();
            let live = LiveState {
                version: k as u64 + 1,
                ended: cut == bytes.len(),
                poll_ms: 1000,
            };
            let page = fold.page(Some(live)).unwrap();
            let once = whole(&log, Some(live));
            assert_eq!(
                page.data,
                once.data,
                "{name}: after {cut} of {} bytes",
                bytes.len()
            );
            assert_eq!(
                (page.frames, page.sealings, page.height),
                (once.frames, once.sealings, once.height)
            );
            hidden = hidden.max(fold.walk.frames.t.len() - page.frames);
        }
        // The finished log's page is what `swarmfl view` writes, byte for byte.
        assert_eq!(cuts.last(), Some(&bytes.len()));
        let out = dir.join("run.html");
        view(&log, &out, &crate::progress::Quiet).unwrap();
        let html = std::fs::read_to_string(&out).unwrap();
        assert_eq!(
            fold.page(None).unwrap().html(),
            html,
            "{name}: the finished page"
        );
        let _ = std::fs::remove_dir_all(&dir);
        hidden
    }

    /// `count` cut points after the header, spread by a fixed pseudo-random sequence (most fall
    /// inside a record), then the whole file.
    fn cuts(bytes: &[u8], count: usize, mut seed: u64) -> Vec<usize> {
        let header_end = 24 + u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        let mut cuts: Vec<usize> = (0..count)
            .map(|_| {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                header_end + (seed >> 33) as usize % (bytes.len() - header_end)
            })
            .collect();
        cuts.push(bytes.len());
        cuts.sort_unstable();
        cuts
    }

    #[test]
    fn a_fold_that_follows_a_growing_log_makes_the_page_of_one_fold() {
        let bytes = fixture("short-resim-seed7");
        let header_end = 24 + u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        let n = bytes.len();
        // The header alone, a cut one byte into a frame, inside the footer, and the end.
        check_growing("edges", &bytes, &[header_end, header_end + 1, n - 3, n]);
        check_growing("random", &bytes, &cuts(&bytes, 7, 35));
        // One growth: the whole log at once.
        check_growing("once", &bytes, &[header_end, n]);
    }

    #[test]
    fn a_growing_log_with_forks_shows_the_frames_of_its_chain_as_it_stands() {
        // A run with forks: frames taken at sealings of blocks later abandoned are kept but not
        // shown, as one fold of that prefix would not have them.
        let bytes = fixture("smoke-e1-faulty-seed3");
        let hidden = check_growing("forks", &bytes, &cuts(&bytes, 5, 11));
        assert!(hidden > 0, "the log has sealings off the final chain");
    }

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
        let out = crate::run::run(config, 1, &dir.join("run"), &crate::progress::Quiet).unwrap();
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
