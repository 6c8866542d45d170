//! The viewer's fold of a log ([`Fold`]): one pass feeds each record to the index of the
//! canonical chain and to the [`Walk`] that samples frames on the [`Grid`].

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use swarmfl_core::config::Aggregation;
use swarmfl_core::inspect;
use swarmfl_core::log::{LogReader, Next};
use swarmfl_core::replay;
use swarmfl_core::Digest;

use super::data::page_data;
use super::walk::{Grid, Walk};
use super::{LiveState, Page};

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
    /// The held-out loss at each round's closing block, by block (see
    /// [`rounds_json`](super::data::rounds_json)); emptied by a reconfiguration, which may
    /// change the model or the held-out set.
    heldout: BTreeMap<Digest, f64>,
}

/// Most times [`Fold::page`] folds the log again because its frame grid moved.
pub(super) const MAX_REFOLDS: u32 = 8;

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

#[cfg(test)]
pub(super) mod tests {
    use super::super::view;
    use super::*;
    use std::io::Write as _;

    pub(crate) fn fixture(name: &str) -> Vec<u8> {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../fixtures/logs")
            .join(format!("{name}.swlog"));
        std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
    }

    pub(crate) fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("swarmfl-view-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// A page of one fold of the file at `log` as it is now.
    pub(crate) fn whole(log: &Path, live: Option<LiveState>) -> Page {
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
}
