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
//! One pass over the log ([`Fold`]) feeds each record to the index
//! ([`inspect::Indexer`](swarmfl_core::inspect::Indexer): the final canonical chain, its
//! balances and rounds) and to a walk that samples frames from the index's state; kept between
//! pages, it lets the live view fold only what the log gained. Thinning: frames every
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
//!
//! Its parts: [`fold`] (the fold of a log and its frame grid), [`frames`] (the sampled
//! frames), [`data`] (the page's data object as JSON), [`world`] (the page of a log whose
//! plug-in rule is not loaded); this module writes the page.

mod blame_bar;
mod data;
mod fold;
mod frames;
mod walk;
mod world;

use std::path::Path;

use anyhow::Context;

use crate::progress::{warn_if_truncated, Watch};
pub use fold::Fold;
use world::{unloaded_rule, world_page};
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
    view_blamed(log, out, None, watch)
}

/// [`view`] with a blame report's pane (a per-robot influence bar beside the tokens) when
/// `blame` is given (`swarmfl view LOG --blame blame.json`).
pub fn view_blamed(
    log: &Path,
    out: &Path,
    blame: Option<&crate::blame::BlameReport>,
    watch: &dyn Watch,
) -> anyhow::Result<ViewOutcome> {
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
    let html = match blame {
        Some(report) => blame_bar::inject(&page.html(), report)?,
        None => page.html(),
    };
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

/// Escapes text for HTML.
fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

const TEMPLATE: &str = include_str!("view.html");
