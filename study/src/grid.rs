//! `swarmfl sweep --grid KEY=V1,V2 ...`: a grid over any configuration keys, as an
//! [`Experiment`] whose points are every combination of the axes' values (the first axis
//! varies slowest), so that the sweep's task list, shards, resumption and report are the
//! built-in experiments' own.
//!
//! A grid on preset `P` writes its results under `DIR/grid-P/<point>/seed<N>.json`; a point's
//! name is its coordinates, `key=value` joined by `+` (`contract.rule=median+byzantine.count=3`),
//! with any character a file name should not hold replaced by `_`.

use anyhow::Context;

use crate::experiments::{Experiment, Point};

/// One axis of a grid: a configuration key and the values it takes, as `--set` text.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Axis {
    /// The configuration key (`contract.rule`).
    pub key: String,
    /// Its values in the order given, each as `--set` takes it (`median`, `3`, `[1, 2]`).
    pub values: Vec<String>,
}

/// Parses one `--grid KEY=V1,V2,...`. Values are split at commas outside brackets and quotes,
/// so an array value (`[1, 2]`) or a quoted string holding a comma stays one value.
pub fn parse_axis(text: &str) -> anyhow::Result<Axis> {
    let (key, values) = text.split_once('=').with_context(|| {
        format!("--grid {text:?}: expected KEY=V1,V2,..., e.g. --grid contract.rule=median,krum")
    })?;
    let key = key.trim();
    anyhow::ensure!(
        !key.is_empty(),
        "--grid {text:?}: the key before `=` is empty (e.g. --grid byzantine.count=1,3)"
    );
    let values = split_values(values);
    if let Some(i) = values.iter().position(String::is_empty) {
        anyhow::bail!(
            "--grid {text:?}: value {} of {key} is empty; list the values separated by single \
             commas",
            i + 1
        );
    }
    for (i, v) in values.iter().enumerate() {
        if values[..i].contains(v) {
            anyhow::bail!("--grid {text:?}: {key} lists the value {v} twice");
        }
    }
    Ok(Axis {
        key: key.to_string(),
        values,
    })
}

/// Splits at commas that are outside `[...]`, `{...}` and quotes; trims each value.
fn split_values(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut current = String::new();
    let mut depth = 0i32;
    let mut quote: Option<char> = None;
    for c in text.chars() {
        match (quote, c) {
            (Some(q), c) if c == q => quote = None,
            (Some(_), _) => {}
            (None, '"' | '\'') => quote = Some(c),
            (None, '[' | '{') => depth += 1,
            (None, ']' | '}') => depth -= 1,
            (None, ',') if depth == 0 => {
                out.push(current.trim().to_string());
                current.clear();
                continue;
            }
            _ => {}
        }
        current.push(c);
    }
    out.push(current.trim().to_string());
    out
}

/// The key of an override `key=value`.
fn key_of(o: &str) -> &str {
    o.split_once('=').map_or(o, |(k, _)| k).trim()
}

/// A file-name-safe form of a point's coordinates.
pub(crate) fn safe(text: &str) -> String {
    text.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '=' | '-' | '+' | ',') {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// A grid point's coordinates from what its result files record: of its overrides (the
/// point's own, then the sweep's `--set`), the leading ones whose `+`-joined safe form is the
/// point's name `point`, each as `(key, value)` (value as given to `--grid`). Empty when no
/// prefix names the point (not a `--grid` point).
pub fn coordinates(point: &str, overrides: &[String]) -> Vec<(String, String)> {
    let Some(n) = (1..=overrides.len())
        .rev()
        .find(|&n| safe(&overrides[..n].join("+")) == point)
    else {
        return Vec::new();
    };
    overrides[..n]
        .iter()
        .map(|o| {
            let (k, v) = o.split_once('=').unwrap_or((o, ""));
            (k.trim().to_string(), v.trim().to_string())
        })
        .collect()
}

/// A grid value as figures and tables show it: a TOML string without its quotes (`"krum"`
/// is `krum`), anything else as given.
pub fn shown_value(value: &str) -> &str {
    let v = value.trim();
    ['"', '\'']
        .iter()
        .find_map(|&q| v.strip_prefix(q).and_then(|t| t.strip_suffix(q)))
        .unwrap_or(v)
}

/// The experiment of a grid: every combination of `axes` (first axis slowest) on `preset`.
/// Refuses (naming the key) a key given twice or also in `--set` (`set`): one of the two values
/// would be silently lost.
pub fn experiment(preset: &str, axes: &[Axis], set: &[String]) -> anyhow::Result<Experiment> {
    anyhow::ensure!(
        !axes.is_empty(),
        "a grid needs at least one --grid KEY=V1,V2"
    );
    for (i, a) in axes.iter().enumerate() {
        anyhow::ensure!(
            !axes[..i].iter().any(|b| b.key == a.key),
            "--grid {} is given twice: put all its values in one --grid {}=V1,V2",
            a.key,
            a.key
        );
        if let Some(o) = set.iter().find(|o| key_of(o) == a.key) {
            anyhow::bail!(
                "{} is both a grid axis (--grid {}=...) and fixed by --set {o}: drop one",
                a.key,
                a.key
            );
        }
    }
    let mut combos: Vec<Vec<(usize, &str)>> = vec![Vec::new()];
    for a in axes {
        combos = combos
            .into_iter()
            .flat_map(|c| {
                a.values.iter().enumerate().map(move |(i, v)| {
                    let mut c = c.clone();
                    c.push((i, v.as_str()));
                    c
                })
            })
            .collect();
    }
    let mut points: Vec<Point> = Vec::with_capacity(combos.len());
    for combo in combos {
        let overrides: Vec<String> = axes
            .iter()
            .zip(&combo)
            .map(|(a, (_, v))| format!("{}={v}", a.key))
            .collect();
        let (first_index, first_value) = combo[0];
        let x = first_value
            .trim_matches('"')
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .unwrap_or(first_index as f64);
        let name = safe(&overrides.join("+"));
        if let Some(other) = points.iter().find(|p| p.name == name) {
            anyhow::bail!(
                "grid points {} and {} have the same directory name {name:?} once made safe for \
                 a file name; use values that differ in letters or digits",
                other.overrides.join(" "),
                overrides.join(" ")
            );
        }
        points.push(Point {
            name,
            x,
            overrides,
            tags: Vec::new(),
        });
    }
    Ok(Experiment {
        name: format!("grid-{preset}"),
        preset: preset.to_string(),
        axis: axes[0].key.clone(),
        points,
        runs: 1,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axes_split_at_top_level_commas_and_refuse_bad_text() {
        let a = parse_axis("contract.rule=median, krum").unwrap();
        assert_eq!(a.key, "contract.rule");
        assert_eq!(a.values, ["median", "krum"]);
        let a = parse_axis("x.y=[1, 2],[3],\"a,b\"").unwrap();
        assert_eq!(a.values, ["[1, 2]", "[3]", "\"a,b\""]);
        let e = |t: &str| parse_axis(t).unwrap_err().to_string();
        assert!(e("contract.rule").contains("expected KEY=V1,V2"));
        assert!(e("=1,2").contains("key before `=` is empty"));
        assert!(e("byzantine.count=1,,3").contains("value 2 of byzantine.count is empty"));
        assert!(e("byzantine.count=1,1").contains("lists the value 1 twice"));
    }

    #[test]
    fn a_grid_is_every_combination_first_axis_slowest() {
        let axes = [
            parse_axis("contract.rule=median,krum").unwrap(),
            parse_axis("byzantine.count=1,3").unwrap(),
        ];
        let exp = experiment("smoke", &axes, &["run.duration_s=300".into()]).unwrap();
        assert_eq!(exp.name, "grid-smoke");
        assert_eq!(exp.preset, "smoke");
        let names: Vec<&str> = exp.points.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "contract.rule=median+byzantine.count=1",
                "contract.rule=median+byzantine.count=3",
                "contract.rule=krum+byzantine.count=1",
                "contract.rule=krum+byzantine.count=3",
            ]
        );
        assert_eq!(
            exp.points[2].overrides,
            ["contract.rule=krum", "byzantine.count=1"]
        );
        // A non-numeric first axis: x is the value's position on it.
        assert_eq!(exp.points[2].x, 1.0);
        let numeric = experiment("smoke", &axes[1..], &[]).unwrap();
        assert_eq!(numeric.points[1].x, 3.0);
    }

    #[test]
    fn a_points_coordinates_are_the_overrides_that_name_it() {
        let overrides: Vec<String> = [
            "contract.rule=\"krum\"",
            "byzantine.count=3",
            "run.duration_s=300",
        ]
        .map(String::from)
        .into();
        let c = coordinates("contract.rule=_krum_+byzantine.count=3", &overrides);
        assert_eq!(
            c,
            [
                ("contract.rule".to_string(), "\"krum\"".to_string()),
                ("byzantine.count".to_string(), "3".to_string())
            ]
        );
        assert_eq!(shown_value(&c[0].1), "krum");
        assert_eq!(shown_value("'a,b'"), "a,b");
        assert_eq!(shown_value("[1, 2]"), "[1, 2]");
        assert!(coordinates("byzantine-3", &overrides).is_empty());
    }

    #[test]
    fn a_key_twice_or_also_set_is_refused_naming_it() {
        let a = parse_axis("byzantine.count=1,3").unwrap();
        let e = experiment("smoke", &[a.clone(), a.clone()], &[])
            .unwrap_err()
            .to_string();
        assert!(e.contains("--grid byzantine.count is given twice"), "{e}");
        let e = experiment("smoke", &[a], &["byzantine.count=2".into()])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("byzantine.count is both a grid axis")
                && e.contains("--set byzantine.count=2"),
            "{e}"
        );
        assert!(experiment("smoke", &[], &[]).is_err());
        let a = parse_axis("x=a/b,a_b").unwrap();
        let e = experiment("smoke", &[a], &[]).unwrap_err().to_string();
        assert!(e.contains("same directory name"), "{e}");
    }
}
