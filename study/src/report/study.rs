//! The study reports: each draws the figures and tables of the experiments it owns (the
//! experiment's [`DrawnBy`](crate::experiments::DrawnBy) says which), behind one trait, and
//! the parent's [`STUDIES`](super::STUDIES) lists them. A new study is its module,
//! implementing [`StudyReport`], plus one line in that list; `report::make` runs them in the
//! list's order.

use std::path::Path;

use super::load::RunResult;
use super::plots::Figure;
use super::stats::ExperimentStats;
use crate::experiments::{self, Entry};

/// One study's part of a report (its `Debug` names it in messages).
pub(crate) trait StudyReport: std::fmt::Debug + Sync {
    /// Whether it draws the experiment `entry` (`None`: an experiment that is not built in,
    /// such as a `--grid` sweep's).
    fn draws(&self, entry: Option<&Entry>) -> bool;

    /// Adds the study's own numbers to its experiments' statistics, before the CSV files are
    /// written from them. Most studies add none.
    fn extend(&self, _results: &[RunResult], _stats: &mut [ExperimentStats]) {}

    /// Draws its experiments' figures into `out` and makes their files and `report.md`
    /// sections, adding to `notes` what the reader should know (a figure drawn without text).
    fn draw(
        &self,
        results: &[RunResult],
        stats: &[ExperimentStats],
        out: &Path,
        notes: &mut Vec<String>,
    ) -> anyhow::Result<Drawn>;
}

/// What a study report made.
#[derive(Debug, Default)]
pub(crate) struct Drawn {
    /// The figures drawn, for `report.md`.
    pub figures: Vec<Figure>,
    /// Further files of the report (name, text), such as a worst-case CSV.
    pub files: Vec<(String, String)>,
    /// Text for `report.md`, placed in its experiment's section after the figures.
    pub sections: Vec<Section>,
}

/// Text in an experiment's section of `report.md`.
#[derive(Debug)]
pub(crate) struct Section {
    /// The experiment.
    pub experiment: String,
    /// The markdown.
    pub text: String,
}

/// The experiments among `stats` that `study` draws, in the statistics' order.
pub(crate) fn drawn_by<'a>(
    study: &'a dyn StudyReport,
    stats: &'a [ExperimentStats],
) -> impl Iterator<Item = &'a ExperimentStats> + 'a {
    stats
        .iter()
        .filter(move |e| study.draws(experiments::entry(&e.name)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each experiment, built in or not, has exactly one study report that draws it: a new
    /// experiment's [`DrawnBy`](crate::experiments::DrawnBy) needs its report in
    /// [`STUDIES`](super::super::STUDIES).
    #[test]
    fn every_experiment_is_drawn_by_exactly_one_study() {
        for entry in experiments::ALL.iter().map(Some).chain([None]) {
            let by: Vec<&&dyn StudyReport> = super::super::STUDIES
                .iter()
                .filter(|s| s.draws(entry))
                .collect();
            assert_eq!(
                by.len(),
                1,
                "{} is drawn by {by:?}",
                entry.map_or("a --grid sweep", Entry::name)
            );
        }
    }
}
