//! The coordinates of a `sweep --grid` experiment's points, for its figures and tables: the
//! grid's keys and each point's value on each, numeric or text. Every key is drawn and tabled
//! by its values: the figures over time have a line per point (a combination of values) with
//! a legend naming `key=value`, the figure versus a key has that key's values on its x axis and
//! a series per combination of the other keys, and the report's table has a column per key.

use crate::grid;

/// What a point shows for a key it does not set: a results directory can hold two grids, one
/// with a key the other leaves at the preset's value.
pub const UNSET: &str = "(preset)";

/// The keys of a grid and every point's value on each.
#[derive(Clone, Debug, PartialEq)]
pub struct GridCoords {
    /// The grid's keys, in the order of the sweep's `--grid` options (first appearance over
    /// the points).
    pub keys: Vec<String>,
    /// Per point (in the experiment's order), its value on each key as given to `--grid` (a
    /// TOML string without its quotes); `None` where the point does not set the key.
    pub values: Vec<Vec<Option<String>>>,
    /// The key on the x axis of a figure versus the grid (see [`GridCoords::versus`]).
    pub x_key: usize,
}

/// A figure versus one key of a grid: where each point goes and in which series.
#[derive(Clone, Debug, PartialEq)]
pub struct Versus {
    /// Per point, its x: the key's value when every point has an integer there, else the
    /// position of its value among the key's values (first appearance order).
    pub x: Vec<f64>,
    /// The x axis' key points and their labels: each value of the key once, ascending.
    pub ticks: Vec<(f64, String)>,
    /// Per point, its series: `key=value` of the other keys (empty for a grid of one key).
    pub series: Vec<String>,
}

impl GridCoords {
    /// The coordinates of a grid's points, read from each point's name and recorded overrides
    /// ([`grid::coordinates`]), in the experiment's order. `None` when no point is a `--grid`
    /// point.
    pub fn of<'a>(points: impl IntoIterator<Item = (&'a str, &'a [String])>) -> Option<GridCoords> {
        let coords: Vec<Vec<(String, String)>> = points
            .into_iter()
            .map(|(point, overrides)| grid::coordinates(point, overrides))
            .collect();
        let mut keys: Vec<String> = Vec::new();
        for (k, _) in coords.iter().flatten() {
            if !keys.contains(k) {
                keys.push(k.clone());
            }
        }
        if keys.is_empty() {
            return None;
        }
        let values: Vec<Vec<Option<String>>> = coords
            .iter()
            .map(|c| {
                keys.iter()
                    .map(|k| {
                        c.iter()
                            .find(|(ck, _)| ck == k)
                            .map(|(_, v)| grid::shown_value(v).to_string())
                    })
                    .collect()
            })
            .collect();
        // The x axis: the first key every point gives an integer (a count, a size), else the
        // first key, its values in order.
        let x_key = (0..keys.len())
            .find(|&j| values.iter().all(|v| integer(v[j].as_deref()).is_some()))
            .unwrap_or(0);
        Some(GridCoords {
            keys,
            values,
            x_key,
        })
    }

    /// Point `point`'s value on key `key` as shown ([`UNSET`] where it does not set it).
    pub fn value(&self, point: usize, key: usize) -> &str {
        self.values[point][key].as_deref().unwrap_or(UNSET)
    }

    /// Point `point`'s legend label: `key=value` for every key, joined by `, `.
    pub fn label(&self, point: usize) -> String {
        self.label_without(point, None)
    }

    /// `key=value` of every key but `skip`, joined by `, `.
    fn label_without(&self, point: usize, skip: Option<usize>) -> String {
        (0..self.keys.len())
            .filter(|&j| Some(j) != skip)
            .map(|j| format!("{}={}", self.keys[j], self.value(point, j)))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The layout of a figure versus the key [`GridCoords::x_key`].
    pub fn versus(&self) -> Versus {
        let j = self.x_key;
        let numeric: Option<Vec<f64>> = self
            .values
            .iter()
            .map(|v| integer(v[j].as_deref()))
            .collect();
        let (x, mut ticks) = match numeric {
            Some(xs) => {
                let mut ticks: Vec<(f64, String)> = Vec::new();
                for (i, &x) in xs.iter().enumerate() {
                    if !ticks.iter().any(|(t, _)| *t == x) {
                        ticks.push((x, self.value(i, j).to_string()));
                    }
                }
                (xs, ticks)
            }
            None => {
                let mut seen: Vec<&str> = Vec::new();
                let xs = (0..self.values.len())
                    .map(|i| {
                        let v = self.value(i, j);
                        let at = seen.iter().position(|s| *s == v).unwrap_or_else(|| {
                            seen.push(v);
                            seen.len() - 1
                        });
                        at as f64
                    })
                    .collect();
                let ticks = seen
                    .iter()
                    .enumerate()
                    .map(|(i, v)| (i as f64, v.to_string()))
                    .collect();
                (xs, ticks)
            }
        };
        ticks.sort_by(|a, b| a.0.total_cmp(&b.0));
        Versus {
            x,
            ticks,
            series: (0..self.values.len())
                .map(|i| self.label_without(i, Some(j)))
                .collect(),
        }
    }
}

/// A grid value that is a whole number, as a float.
fn integer(value: Option<&str>) -> Option<f64> {
    value?
        .parse::<f64>()
        .ok()
        .filter(|x| x.is_finite() && x.fract() == 0.0)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::super::stats::{grid_coords, PointStats};
    use super::*;

    /// A point of `sweep --grid`, with the sweep's `--set` after the point's overrides.
    pub(crate) fn point(overrides: &[&str]) -> PointStats {
        let name = grid::safe(&overrides.join("+"));
        let mut overrides: Vec<String> = overrides.iter().map(|o| o.to_string()).collect();
        overrides.push("run.duration_s=300".into());
        PointStats {
            point: name,
            x: 0.0,
            seeds: vec![1, 2],
            overrides,
            duration_s: Some(300.0),
            loss: Vec::new(),
            heldout: Vec::new(),
            chain_mb: Vec::new(),
            metrics: Default::default(),
            wall_s: None,
            missing: Default::default(),
        }
    }

    /// The grid: a text key first, a count second.
    pub(crate) fn two_key_grid() -> Vec<PointStats> {
        [
            ["contract.rule=median", "byzantine.count=1"],
            ["contract.rule=median", "byzantine.count=3"],
            ["contract.rule=\"krum\"", "byzantine.count=1"],
            ["contract.rule=\"krum\"", "byzantine.count=3"],
        ]
        .iter()
        .map(|o| point(o))
        .collect()
    }

    #[test]
    fn a_two_key_grid_with_a_text_key_is_labelled_by_its_values() {
        let g = grid_coords(&two_key_grid()).expect("a grid");
        assert_eq!(g.keys, ["contract.rule", "byzantine.count"]);
        let labels: Vec<String> = (0..4).map(|i| g.label(i)).collect();
        assert_eq!(
            labels,
            [
                "contract.rule=median, byzantine.count=1",
                "contract.rule=median, byzantine.count=3",
                "contract.rule=krum, byzantine.count=1",
                "contract.rule=krum, byzantine.count=3",
            ]
        );
        // Versus the count (the integer key), one series per rule.
        assert_eq!(g.keys[g.x_key], "byzantine.count");
        let v = g.versus();
        assert_eq!(v.x, [1.0, 3.0, 1.0, 3.0]);
        assert_eq!(v.ticks, [(1.0, "1".to_string()), (3.0, "3".to_string())]);
        assert_eq!(
            v.series,
            [
                "contract.rule=median",
                "contract.rule=median",
                "contract.rule=krum",
                "contract.rule=krum"
            ]
        );
    }

    #[test]
    fn a_text_only_grid_is_drawn_at_its_values_positions() {
        let points: Vec<PointStats> = ["median", "krum", "trimmed-mean"]
            .iter()
            .map(|r| point(&[&format!("contract.rule={r}")]))
            .collect();
        let g = grid_coords(&points).unwrap();
        let v = g.versus();
        assert_eq!(v.x, [0.0, 1.0, 2.0]);
        let ticks: Vec<&str> = v.ticks.iter().map(|(_, t)| t.as_str()).collect();
        assert_eq!(ticks, ["median", "krum", "trimmed-mean"]);
        assert_eq!(v.series, ["", "", ""]);
        assert_eq!(g.label(2), "contract.rule=trimmed-mean");
    }

    #[test]
    fn a_directory_of_two_grids_shows_the_unset_key_as_the_presets() {
        // claim12-onset: a grid over the count, and one over the count and the ranking.
        let points = vec![
            point(&["byzantine.count=1"]),
            point(&["byzantine.count=1", "contract.rank_order=nearest"]),
            point(&["byzantine.count=2"]),
        ];
        let g = grid_coords(&points).unwrap();
        assert_eq!(g.keys, ["byzantine.count", "contract.rank_order"]);
        assert_eq!(g.value(0, 1), UNSET);
        assert_eq!(g.label(1), "byzantine.count=1, contract.rank_order=nearest");
        let v = g.versus();
        assert_eq!(v.x, [1.0, 1.0, 2.0]);
        assert_eq!(v.series[0], "contract.rank_order=(preset)");
        // Points that are not a grid's have no coordinates.
        let mut other = point(&["byzantine.count=1"]);
        other.point = "byzantine-1".into();
        assert_eq!(grid_coords(&[other]), None);
    }
}
