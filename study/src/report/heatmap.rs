//! Heatmaps (rule x attack) in the paper style: row and column names, axis titles, a number in
//! every cell, and a colour bar whose scale is clipped at a stated percentile, so one outlier
//! (a loss of 8.8 beside a field of 2.2) does not wash every other cell out to white.
//!
//! The layout is computed here in logical pixels (see [`super::style`]) rather than by a
//! plotters chart: the canvas is exactly as large as the grid, its names and the colour bar.
//! A map too wide for the paper's 900 px (7 in) layout with its column names written across
//! (e4's 13 attacks) gets narrow cells, as wide as their numbers, with the column names written
//! upwards under them, and its subtitle wrapped to the grid's width, so that it prints at full
//! page width with its text at the style's sizes (9 pt and up) instead of shrunk.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::stats::fixed;
use super::style::{self, Style};

/// The percentile at which the colour scale stops: cells above it are drawn in the top colour
/// (their numbers still say their value).
pub(super) const CLIP_PERCENTILE: f64 = 95.0;

/// A heatmap's values: `values[row][col]`.
pub(super) struct Heatmap {
    pub(super) title: String,
    /// What the rows are (the y axis title).
    pub(super) row_title: String,
    /// What the columns are (the x axis title).
    pub(super) col_title: String,
    /// What the colour measures (the colour bar's title).
    pub(super) value_title: String,
    pub(super) rows: Vec<String>,
    pub(super) cols: Vec<String>,
    pub(super) values: Vec<Vec<Option<f64>>>,
    /// Diverging colours around 0 (blue positive, red negative); else white (low) to red
    /// (high) on a log scale.
    pub(super) diverging: bool,
    /// A name written above each cell's number (`labels[row][col]`; the best rule of an
    /// aggregated map), or empty for numbers only.
    pub(super) labels: Vec<Vec<String>>,
    /// A colour scale shared with other maps (see [`Scale::of`]), so that maps drawn side by
    /// side compare by colour; `None`: this map's own values decide it.
    pub(super) shared_scale: Option<Scale>,
}

/// Logical sizes of the layout that do not depend on the text (see [`Layout`] for those).
/// A cell is at least this wide, wider when a column name or a number needs it.
const CELL_W: f64 = 78.0;
const CELL_H: f64 = 32.0;
const MARGIN: f64 = 14.0;
const BAR_GAP: f64 = 22.0;
const BAR_W: f64 = 18.0;
/// Room a text keeps from the cell border or the next text.
const PAD: f64 = 8.0;
/// Room a cell's number keeps from the cell's borders in a narrow (upright names) layout.
const NUMBER_PAD: f64 = 4.0;
/// A line of text's height, in ems (DejaVu Sans' ascent plus descent is 1.17 em).
const LINE: f64 = 1.25;
/// The title's line, in its ems: a little more, to set it apart from the subtitle.
const TITLE_LINE: f64 = 1.45;

/// The sizes of the layout that its text decides, measured at the paper style's font sizes
/// so that no name, number or title is clipped or runs into its neighbour.
#[derive(Clone, Debug)]
struct Layout {
    /// A cell's width.
    cell_w: f64,
    /// The column of row names left of the grid.
    row_names: f64,
    /// From the top margin to the grid: title, subtitle, the rows' title.
    title_h: f64,
    /// Below the grid: the column names (one or two lines, or written upwards).
    col_names: f64,
    /// Whether the column names are written upwards (the narrow layout).
    upright: bool,
    /// The subtitle, in lines that fit the canvas.
    subtitle: Vec<String>,
    /// Below the column names: the columns' title.
    axis_title_h: f64,
    /// Right of the colour bar: its tick labels.
    bar_labels: f64,
    /// The canvas' width at least (the title and subtitle fit).
    min_w: f64,
}

/// The colour scale: the values' range with its top (or, diverging, its magnitude) clipped at
/// [`CLIP_PERCENTILE`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Scale {
    pub(super) lo: f64,
    pub(super) hi: f64,
    /// Whether any value lies beyond the clip.
    pub(super) clipped: bool,
    /// What the top was clipped at, for the subtitle; `None`: [`CLIP_PERCENTILE`].
    pub(super) clipped_at: Option<&'static str>,
}

/// The `p`-th percentile of `sorted` (nearest rank), `None` when empty.
fn percentile(sorted: &[f64], p: f64) -> Option<f64> {
    if sorted.is_empty() {
        return None;
    }
    let rank = ((p / 100.0) * sorted.len() as f64).ceil() as usize;
    Some(sorted[rank.clamp(1, sorted.len()) - 1])
}

impl Scale {
    /// The scale of `values` (non-finite ones ignored): their range, the top (or, diverging,
    /// the magnitude) clipped at [`CLIP_PERCENTILE`].
    pub(super) fn of(values: impl IntoIterator<Item = f64>, diverging: bool) -> Scale {
        let mut values: Vec<f64> = values.into_iter().filter(|v| v.is_finite()).collect();
        if values.is_empty() {
            return Scale {
                lo: 0.0,
                hi: 1.0,
                clipped: false,
                clipped_at: None,
            };
        }
        if diverging {
            let mut magnitudes: Vec<f64> = values.iter().map(|v| v.abs()).collect();
            magnitudes.sort_by(f64::total_cmp);
            let max = *magnitudes.last().expect("not empty");
            let m = percentile(&magnitudes, CLIP_PERCENTILE)
                .unwrap_or(max)
                .max(1e-12);
            Scale {
                lo: -m,
                hi: m,
                clipped: max > m,
                clipped_at: None,
            }
        } else {
            values.sort_by(f64::total_cmp);
            let max = *values.last().expect("not empty");
            let hi = percentile(&values, CLIP_PERCENTILE).unwrap_or(max);
            Scale {
                lo: values[0],
                hi,
                clipped: max > hi,
                clipped_at: None,
            }
        }
    }
}

impl Heatmap {
    /// The colour scale: the shared one if set, else that of this map's values.
    pub(super) fn scale(&self) -> Scale {
        self.shared_scale.unwrap_or_else(|| {
            Scale::of(
                self.values.iter().flatten().flatten().copied(),
                self.diverging,
            )
        })
    }

    /// A row's height: one line of text, two with labels.
    fn cell_h(&self) -> f64 {
        if self.labels.is_empty() {
            CELL_H
        } else {
            CELL_H + style::CELL * LINE
        }
    }

    /// The label of a cell, if the map has labels.
    fn label(&self, row: usize, col: usize) -> Option<&str> {
        self.labels
            .get(row)
            .and_then(|r| r.get(col))
            .map(String::as_str)
    }

    /// Where `v` sits on the colour scale, 0 (lowest colour) to 1 (top), clipped; for a
    /// diverging map -1 to 1.
    fn position(&self, scale: Scale, v: f64) -> f64 {
        if self.diverging {
            (v / scale.hi).clamp(-1.0, 1.0)
        } else {
            let (l, h) = (scale.lo.max(1e-12).ln(), scale.hi.max(1e-12).ln());
            if h > l {
                ((v.max(1e-12).ln() - l) / (h - l)).clamp(0.0, 1.0)
            } else {
                0.0
            }
        }
    }

    /// The value at a position of the scale (the inverse of [`Heatmap::position`]).
    fn value_at(&self, scale: Scale, t: f64) -> f64 {
        if self.diverging {
            t * scale.hi
        } else {
            let (l, h) = (scale.lo.max(1e-12).ln(), scale.hi.max(1e-12).ln());
            (l + (h - l) * t).exp()
        }
    }

    /// The colour of a position of the scale.
    fn colour(&self, t: f64) -> RGBColor {
        let mix = |a: (f64, f64, f64), b: (f64, f64, f64), t: f64| {
            let t = t.clamp(0.0, 1.0);
            RGBColor(
                (a.0 + (b.0 - a.0) * t).round() as u8,
                (a.1 + (b.1 - a.1) * t).round() as u8,
                (a.2 + (b.2 - a.2) * t).round() as u8,
            )
        };
        let white = (255.0, 255.0, 255.0);
        let (blue, red) = ((33.0, 102.0, 172.0), (178.0, 24.0, 43.0));
        if self.diverging {
            if t >= 0.0 {
                mix(white, blue, t)
            } else {
                mix(white, red, -t)
            }
        } else {
            mix(white, red, t)
        }
    }

    /// The colour bar's five tick labels, bottom to top.
    fn bar_ticks(&self, scale: Scale) -> Vec<String> {
        (0..=4)
            .map(|k| {
                let t = k as f64 / 4.0;
                let label =
                    number(self.value_at(scale, if self.diverging { 2.0 * t - 1.0 } else { t }));
                if scale.clipped && k == 4 {
                    format!(">= {label}")
                } else if scale.clipped && k == 0 && self.diverging {
                    format!("<= {label}")
                } else {
                    label
                }
            })
            .collect()
    }

    /// The subtitle: what the colour shows and where its scale is clipped.
    fn subtitle(&self, scale: Scale) -> String {
        let clip = if !scale.clipped {
            String::new()
        } else if self.diverging {
            format!(
                "; scale clipped at the {CLIP_PERCENTILE:.0}th percentile of |value| ({}): \
                 cells beyond +-{} take the end colours",
                number(scale.hi),
                number(scale.hi)
            )
        } else if let Some(at) = scale.clipped_at {
            format!(
                "; scale clipped at {at} ({}): cells above it take the top colour",
                number(scale.hi)
            )
        } else {
            format!(
                "; scale clipped at the {CLIP_PERCENTILE:.0}th percentile ({}): cells above \
                 it take the top colour",
                number(scale.hi)
            )
        };
        format!("colour: {}{clip}", self.value_title)
    }

    /// The text-dependent sizes, measured.
    fn layout(&self) -> Layout {
        let scale = self.scale();
        let widest = |em: f64, texts: &mut dyn Iterator<Item = String>| {
            texts.map(|t| style::text_width(em, &t)).fold(0.0, f64::max)
        };
        // The cells are as wide as the widest number, or the widest name once split at
        // its hyphen if it has one; a name that fits that width then stays on one line.
        let split = widest(
            style::TICK,
            &mut self.cols.iter().flat_map(|c| col_lines(c, CELL_W)),
        );
        let numbers = widest(
            style::CELL,
            &mut self
                .values
                .iter()
                .flatten()
                .map(|v| v.map_or_else(|| "n/a".to_string(), number))
                .chain(self.labels.iter().flatten().cloned()),
        );
        let row_names = widest(style::TICK, &mut self.rows.iter().cloned())
            .max(style::text_width(style::AXIS, &self.row_title))
            + 2.0 * PAD;
        let bar_labels = PAD + widest(style::CELL, &mut self.bar_ticks(scale).into_iter()) + PAD;
        let around = MARGIN + row_names + BAR_GAP + BAR_W + bar_labels + MARGIN;
        let n = self.cols.len() as f64;
        let across = CELL_W.max(split.max(numbers) + 2.0 * PAD);
        // Names across the columns while the grid fits the paper's width; else narrow cells
        // and the names written upwards (a name's height is then one line of text).
        let upright = around + across * n > style::LAYOUT_WIDTH_PX;
        let (cell_w, col_names) = if upright {
            let names = widest(style::TICK, &mut self.cols.iter().cloned());
            (
                (numbers + 2.0 * NUMBER_PAD).max(style::TICK * LINE + 2.0 * NUMBER_PAD),
                PAD + names + PAD,
            )
        } else {
            let lines = self
                .cols
                .iter()
                .map(|c| col_lines(c, across).len())
                .max()
                .unwrap_or(1);
            (across, PAD + lines as f64 * style::TICK * LINE + PAD)
        };
        // The subtitle wraps at the width the grid and its names take (the paper's width at
        // least); the title is one line.
        let width = (around + cell_w * n).max(style::LAYOUT_WIDTH_PX) - 2.0 * MARGIN;
        let subtitle = wrap(style::CELL, &self.subtitle(scale), width);
        let title = subtitle
            .iter()
            .map(|line| style::text_width(style::CELL, line))
            .fold(style::text_width(style::TITLE, &self.title), f64::max);
        Layout {
            cell_w,
            row_names,
            title_h: style::TITLE * TITLE_LINE
                + (style::CELL * subtitle.len() as f64 + style::AXIS) * LINE
                + 2.0 * PAD,
            col_names,
            upright,
            subtitle,
            axis_title_h: style::AXIS * LINE,
            bar_labels,
            min_w: MARGIN + title + MARGIN,
        }
    }

    /// The logical canvas size.
    fn canvas(&self) -> (u32, u32) {
        let l = self.layout();
        let w = MARGIN
            + l.row_names
            + l.cell_w * self.cols.len() as f64
            + BAR_GAP
            + BAR_W
            + l.bar_labels
            + MARGIN;
        let h = MARGIN
            + l.title_h
            + self.cell_h() * self.rows.len() as f64
            + l.col_names
            + l.axis_title_h
            + MARGIN;
        (w.max(l.min_w).ceil() as u32, h.ceil() as u32)
    }
}

/// Draws `map` as `stem.svg` (logical size) and `stem.png` (twice it); returns whether the
/// text could be drawn.
pub(super) fn draw(map: &Heatmap, out: &Path, stem: &str) -> anyhow::Result<bool> {
    let svg = out.join(format!("{stem}.svg"));
    let png = out.join(format!("{stem}.png"));
    let size = map.canvas();
    for text in [true, false] {
        let result = (|| -> Result<(), String> {
            let root = SVGBackend::new(&svg, Style::SVG.size(size)).into_drawing_area();
            draw_on(&root, map, text, Style::SVG).map_err(|e| e.to_string())?;
            root.present().map_err(|e| e.to_string())?;
            crate::png::draw_png(&png, Style::PNG.size(size), |root| {
                draw_on(root, map, text, Style::PNG).map_err(|e| e.to_string())
            })
        })();
        match result {
            Ok(()) => return Ok(text),
            Err(_) if text => {}
            Err(e) => anyhow::bail!("cannot draw {stem}: {e}"),
        }
    }
    Ok(false)
}

type DrawResult<DB> = Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

/// A number for a cell or a bar tick: 3 significant digits.
fn number(v: f64) -> String {
    if v == 0.0 {
        return "0".to_string();
    }
    // A model an attack blew up (1e11) in three digits, not twelve.
    if v.abs() >= 1e5 {
        return format!("{v:.2e}");
    }
    let digits = (2 - v.abs().log10().floor() as i32).clamp(0, 6) as usize;
    fixed(v, digits)
}

/// `text` in lines no wider than `width` at an em of `em`, broken at spaces (a word wider
/// than `width` gets a line of its own).
fn wrap(em: f64, text: &str, width: f64) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    for word in text.split(' ') {
        match lines.last_mut() {
            Some(line) if style::text_width(em, &format!("{line} {word}")) <= width => {
                line.push(' ');
                line.push_str(word);
            }
            _ => lines.push(word.to_string()),
        }
    }
    lines
}

/// A column name in one or two lines: split at the hyphen nearest its middle when it would not
/// fit a cell `cell_w` wide.
fn col_lines(name: &str, cell_w: f64) -> Vec<String> {
    let fits = style::text_width(style::TICK, name) <= cell_w - 2.0 * PAD;
    if fits {
        return vec![name.to_string()];
    }
    let middle = name.len() / 2;
    match name
        .match_indices('-')
        .map(|(i, _)| i)
        .min_by_key(|i| i.abs_diff(middle))
    {
        Some(i) => vec![name[..=i].to_string(), name[i + 1..].to_string()],
        None => vec![name.to_string()],
    }
}

/// Where a heatmap's grid and colour bar fall on its canvas (logical px), from its layout.
struct Placement {
    l: Layout,
    scale: Scale,
    cell_w: f64,
    cell_h: f64,
    /// The grid's left and top edges.
    left: f64,
    top: f64,
    /// The colour bar's left edge and height (the grid's).
    bar_x: f64,
    bar_h: f64,
}

impl Placement {
    /// The placement of `map`'s parts.
    fn of(map: &Heatmap) -> Placement {
        let scale = map.scale();
        let l = map.layout();
        let cell_w = l.cell_w;
        let cell_h = map.cell_h();
        let (nc, nr) = (map.cols.len() as f64, map.rows.len() as f64);
        let left = MARGIN + l.row_names;
        let top = MARGIN + l.title_h;
        let (bar_x, bar_h) = (left + cell_w * nc + BAR_GAP, cell_h * nr);
        Placement {
            l,
            scale,
            cell_w,
            cell_h,
            left,
            top,
            bar_x,
            bar_h,
        }
    }
}

/// Draws `map` on `root` at scale `st`: the cells, the colour bar and (with `text`) the
/// numbers, names and titles.
fn draw_on<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    map: &Heatmap,
    text: bool,
    st: Style,
) -> DrawResult<DB> {
    root.fill(&WHITE)?;
    let at = Placement::of(map);
    draw_cells(root, map, &at, text, st)?;
    draw_bar(root, map, &at, st)?;
    if !text {
        return Ok(());
    }
    draw_bar_ticks(root, map, &at, st)?;
    draw_titles(root, map, &at, st)?;
    draw_names(root, map, &at, st)
}

/// The cells, each filled with its value's colour (with `text`, its number and name).
fn draw_cells<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    map: &Heatmap,
    at: &Placement,
    text: bool,
    st: Style,
) -> DrawResult<DB> {
    let (scale, cell_w, cell_h) = (at.scale, at.cell_w, at.cell_h);
    let (left, top) = (at.left, at.top);
    let p = |x: f64, y: f64| (st.px(x), st.px(y));
    for (r, row) in map.values.iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            let (x, y) = (left + cell_w * c as f64, top + cell_h * r as f64);
            let fill = match v {
                Some(v) if v.is_finite() => map.colour(map.position(scale, *v)),
                _ => RGBColor(225, 225, 225),
            };
            root.draw(&Rectangle::new(
                [p(x, y), p(x + cell_w, y + cell_h)],
                fill.filled(),
            ))?;
            root.draw(&Rectangle::new(
                [p(x, y), p(x + cell_w, y + cell_h)],
                BLACK.mix(0.15).stroke_width(st.upx(1.0)),
            ))?;
            if text {
                let label = v.map_or_else(|| "n/a".to_string(), number);
                // Dark cells get white numbers.
                let dark = v.is_some_and(|v| map.position(scale, v).abs() > 0.6);
                let font = st
                    .font(style::CELL)
                    .color(if dark { &WHITE } else { &BLACK })
                    .pos(Pos::new(HPos::Center, VPos::Center));
                // With a name, the name on the upper line and the number under it.
                let line = style::CELL * LINE / 2.0;
                let number_y = match map.label(r, c) {
                    Some(name) => {
                        root.draw(&Text::new(
                            name.to_string(),
                            p(x + cell_w / 2.0, y + cell_h / 2.0 - line),
                            font.clone(),
                        ))?;
                        y + cell_h / 2.0 + line
                    }
                    None => y + cell_h / 2.0,
                };
                root.draw(&Text::new(label, p(x + cell_w / 2.0, number_y), font))?;
            }
        }
    }
    Ok(())
}

/// The colour bar, top colour at the top, and its outline.
fn draw_bar<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    map: &Heatmap,
    at: &Placement,
    st: Style,
) -> DrawResult<DB> {
    let (top, bar_x, bar_h) = (at.top, at.bar_x, at.bar_h);
    let p = |x: f64, y: f64| (st.px(x), st.px(y));
    let steps = 64;
    for i in 0..steps {
        let t0 = i as f64 / steps as f64;
        let t1 = (i + 1) as f64 / steps as f64;
        let t = (t0 + t1) / 2.0;
        let t = if map.diverging { 2.0 * t - 1.0 } else { t };
        let (y0, y1) = (top + bar_h * (1.0 - t1), top + bar_h * (1.0 - t0));
        root.draw(&Rectangle::new(
            [p(bar_x, y0), p(bar_x + BAR_W, y1)],
            map.colour(t).filled(),
        ))?;
    }
    root.draw(&Rectangle::new(
        [p(bar_x, top), p(bar_x + BAR_W, top + bar_h)],
        BLACK.mix(0.4).stroke_width(st.upx(1.0)),
    ))?;
    Ok(())
}

/// The colour bar's ticks and their labels.
fn draw_bar_ticks<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    map: &Heatmap,
    at: &Placement,
    st: Style,
) -> DrawResult<DB> {
    let (scale, top, bar_x, bar_h) = (at.scale, at.top, at.bar_x, at.bar_h);
    let p = |x: f64, y: f64| (st.px(x), st.px(y));
    let anchored = |size: f64, h: HPos, v: VPos| st.font(size).color(&BLACK).pos(Pos::new(h, v));
    for (k, label) in map.bar_ticks(scale).into_iter().enumerate() {
        let y = top + bar_h * (1.0 - k as f64 / 4.0);
        root.draw(&PathElement::new(
            vec![p(bar_x + BAR_W, y), p(bar_x + BAR_W + 4.0, y)],
            BLACK.stroke_width(st.upx(1.0)),
        ))?;
        root.draw(&Text::new(
            label,
            p(bar_x + BAR_W + PAD, y),
            anchored(style::CELL, HPos::Left, VPos::Center),
        ))?;
    }
    Ok(())
}

/// The title, then what the colour shows and where it is clipped.
fn draw_titles<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    map: &Heatmap,
    at: &Placement,
    st: Style,
) -> DrawResult<DB> {
    let l = &at.l;
    let p = |x: f64, y: f64| (st.px(x), st.px(y));
    let anchored = |size: f64, h: HPos, v: VPos| st.font(size).color(&BLACK).pos(Pos::new(h, v));
    // Title, then what the colour shows and where it is clipped.
    root.draw(&Text::new(
        map.title.clone(),
        p(MARGIN, MARGIN),
        anchored(style::TITLE, HPos::Left, VPos::Top),
    ))?;
    for (k, line) in l.subtitle.iter().enumerate() {
        root.draw(&Text::new(
            line.clone(),
            p(
                MARGIN,
                MARGIN + style::TITLE * TITLE_LINE + k as f64 * style::CELL * LINE,
            ),
            anchored(style::CELL, HPos::Left, VPos::Top).color(&BLACK.mix(0.7)),
        ))?;
    }
    Ok(())
}

/// The row names, right-aligned against the grid, the rows' title above them; the column
/// names under the grid, the columns' title under them.
fn draw_names<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    map: &Heatmap,
    at: &Placement,
    st: Style,
) -> DrawResult<DB> {
    let (l, cell_w, cell_h, bar_h) = (&at.l, at.cell_w, at.cell_h, at.bar_h);
    let (left, top) = (at.left, at.top);
    let nc = map.cols.len() as f64;
    let p = |x: f64, y: f64| (st.px(x), st.px(y));
    let anchored = |size: f64, h: HPos, v: VPos| st.font(size).color(&BLACK).pos(Pos::new(h, v));
    // Row names, right-aligned against the grid; the rows' title above them.
    for (r, name) in map.rows.iter().enumerate() {
        root.draw(&Text::new(
            name.clone(),
            p(left - PAD, top + cell_h * (r as f64 + 0.5)),
            anchored(style::TICK, HPos::Right, VPos::Center),
        ))?;
    }
    // Column names under the grid (two lines when long, or upwards in a narrow layout, ending
    // at the grid), the columns' title under them.
    for (c, name) in map.cols.iter().enumerate() {
        let x = left + cell_w * (c as f64 + 0.5);
        if l.upright {
            let font = st
                .font(style::TICK)
                .transform(FontTransform::Rotate270)
                .color(&BLACK)
                .pos(Pos::new(HPos::Right, VPos::Center));
            root.draw(&Text::new(name.clone(), p(x, top + bar_h + PAD), font))?;
            continue;
        }
        for (line, part) in col_lines(name, cell_w).into_iter().enumerate() {
            root.draw(&Text::new(
                part,
                p(x, top + bar_h + PAD + line as f64 * style::TICK * LINE),
                anchored(style::TICK, HPos::Center, VPos::Top),
            ))?;
        }
    }
    root.draw(&Text::new(
        map.col_title.clone(),
        p(left + cell_w * nc / 2.0, top + bar_h + l.col_names),
        anchored(style::AXIS, HPos::Center, VPos::Top),
    ))?;
    root.draw(&Text::new(
        map.row_title.clone(),
        p(left - PAD, top - PAD / 2.0),
        anchored(style::AXIS, HPos::Right, VPos::Bottom),
    ))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(values: Vec<Vec<Option<f64>>>, diverging: bool) -> Heatmap {
        Heatmap {
            title: "t".into(),
            row_title: "rule".into(),
            col_title: "attack".into(),
            value_title: "loss".into(),
            rows: (0..values.len()).map(|r| format!("r{r}")).collect(),
            cols: (0..values[0].len()).map(|c| format!("c{c}")).collect(),
            values,
            diverging,
            labels: Vec::new(),
            shared_scale: None,
        }
    }

    #[test]
    fn one_outlier_is_clipped_and_the_rest_keep_the_colour_range() {
        // 39 losses between 2.1 and 2.5 and one of 8.77, as in the e4 heatmap the issue saw.
        let mut row: Vec<Option<f64>> = (0..39).map(|i| Some(2.1 + 0.01 * i as f64)).collect();
        row.push(Some(8.77));
        let m = map(vec![row], false);
        let s = m.scale();
        assert!(s.clipped);
        assert!((s.hi - 2.47).abs() < 1e-9, "{s:?}");
        // The lowest and the clipped top span the whole scale; the outlier sits at the top.
        assert_eq!(m.position(s, 2.1), 0.0);
        assert_eq!(m.position(s, 2.47), 1.0);
        assert_eq!(m.position(s, 8.77), 1.0);
        // A mid value is mid-scale, not washed out near white.
        assert!(m.position(s, 2.3) > 0.4, "{}", m.position(s, 2.3));
    }

    #[test]
    fn a_diverging_scale_is_symmetric_and_nothing_clips_without_outliers() {
        let m = map(vec![vec![Some(-1.0), Some(0.5), Some(1.0), None]], true);
        let s = m.scale();
        assert_eq!((s.lo, s.hi, s.clipped), (-1.0, 1.0, false));
        assert_eq!(m.position(s, -1.0), -1.0);
        assert_eq!(m.value_at(s, 0.5), 0.5);
    }

    #[test]
    fn long_column_names_break_at_a_hyphen() {
        assert_eq!(col_lines("none", CELL_W), vec!["none"]);
        assert_eq!(
            col_lines("inflate-samples", CELL_W),
            vec!["inflate-", "samples"]
        );
        assert_eq!(
            col_lines("optimal-alie-x", CELL_W),
            vec!["optimal-", "alie-x"]
        );
        // In a cell wide enough for it, a name stays on one line.
        assert_eq!(col_lines("sign-flip", 200.0), vec!["sign-flip"]);
    }

    #[test]
    fn a_map_of_the_e4_grid_fits_the_paper_width_so_its_text_prints_at_full_size() {
        // e4's 9 rules x 13 attacks, values like its 300 s losses (one outlier): laid out with
        // the names across, the map was 1537 px wide, so printed at 7 in its 9 pt text came
        // out at 5.3 pt.
        let rules = [
            "fedavg",
            "paper",
            "krum",
            "multi-krum",
            "median",
            "trimmed-mean",
            "geomed",
            "centered-clipping",
            "bulyan",
        ];
        let attacks = [
            "none",
            "faulty",
            "malicious",
            "smart",
            "sign-flip",
            "gaussian",
            "alie",
            "ipm",
            "min-max",
            "mimic",
            "inflate-samples",
            "poison-data",
            "collude",
        ];
        let mut m = map(
            (0..rules.len())
                .map(|r| {
                    (0..attacks.len())
                        .map(|c| Some(2.17 + 0.01 * ((r * 7 + c) % 20) as f64))
                        .collect()
                })
                .collect(),
            false,
        );
        m.values[1][10] = Some(8.77);
        m.title = "e4-robustness: final held-out loss, 3 Byzantine of 15".into();
        m.value_title = "final held-out loss, mean over runs (log scale)".into();
        m.rows = rules.iter().map(|r| r.to_string()).collect();
        m.cols = attacks.iter().map(|a| a.to_string()).collect();
        let (w, _) = m.canvas();
        let l = m.layout();
        assert!(l.upright);
        assert!(
            f64::from(w) <= style::LAYOUT_WIDTH_PX,
            "{w} px wide: printed at {} in its text shrinks to {:.1} pt",
            style::PRINT_WIDTH_IN,
            9.0 * style::LAYOUT_WIDTH_PX / f64::from(w)
        );
        // Every number still fits its cell, and the subtitle fits the canvas.
        assert!(style::text_width(style::CELL, "8.77") + 2.0 * NUMBER_PAD <= l.cell_w + 1e-9);
        assert!(l.subtitle.len() >= 2, "{:?}", l.subtitle);
        for line in &l.subtitle {
            assert!(style::text_width(style::CELL, line) <= f64::from(w) - 2.0 * MARGIN + 1e-9);
        }
        // A map that fits with its names across keeps them across.
        let small = map(vec![vec![Some(1.0); 3]; 2], false);
        assert!(!small.layout().upright);
    }

    #[test]
    fn wrapping_breaks_at_spaces_within_the_width() {
        let width = style::text_width(style::CELL, "colour: final held-out");
        let lines = wrap(style::CELL, "colour: final held-out loss, mean", width);
        assert_eq!(lines, vec!["colour: final held-out", "loss, mean"]);
        assert_eq!(wrap(style::CELL, "one", 1.0), vec!["one"]);
    }

    #[test]
    fn the_canvas_holds_the_grid_and_no_blank_margin() {
        let m = map(vec![vec![Some(1.0); 13]; 9], false);
        let (w, h) = m.canvas();
        let l = m.layout();
        let grid_h = CELL_H * 9.0;
        // Below the grid only the column names, the axis title and the margin.
        assert!(
            f64::from(h) - (MARGIN + l.title_h + grid_h)
                <= l.col_names + l.axis_title_h + MARGIN + 1.0
        );
        assert!(f64::from(w) >= l.row_names + l.cell_w * 13.0);
    }
}
