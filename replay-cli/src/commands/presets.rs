//! `swarmfl presets`: the presets, one a line with its description.

use std::process::ExitCode;

use swarmfl_core::config::Preset;

/// Runs `swarmfl presets`.
pub fn command() -> anyhow::Result<ExitCode> {
    print!("{}", table());
    Ok(ExitCode::SUCCESS)
}

/// One line a preset, the descriptions aligned after the longest name.
fn table() -> String {
    let width = Preset::ALL
        .iter()
        .map(|p| p.name().len())
        .max()
        .unwrap_or(0);
    Preset::ALL
        .iter()
        .map(|p| format!("{:<width$}  {}\n", p.name(), p.description()))
        .collect()
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_description_starts_in_the_same_column() {
        let table = super::table();
        let columns: Vec<usize> = table
            .lines()
            .map(|line| {
                let name_end = line.find(' ').expect("a name, then a space");
                name_end + line[name_end..].len() - line[name_end..].trim_start().len()
            })
            .collect();
        assert!(columns.len() > 5);
        assert!(columns.iter().all(|&c| c == columns[0]), "{table}");
    }
}
