//! Drawing a report's line and error-bar figures with plotters, as SVG and PNG.
//!
//! Text (titles, axis labels, legends) uses the system's sans-serif font through plotters'
//! `ttf` feature. If no font can be loaded, each figure is drawn again without any text rather
//! than failing, and the report notes it.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::stats::Stat;
use super::style::{self, Style};

/// One drawn figure: its file stem (`.svg` and `.png` exist) and caption, under an experiment.
#[derive(Clone, Debug)]
pub struct Figure {
    /// The experiment the figure belongs to.
    pub experiment: String,
    /// File stem inside the report directory.
    pub stem: String,
    /// What it shows.
    pub caption: String,
}

/// A figure to draw: its file stem, its caption and its plot.
pub(crate) type Planned<'a> = (String, String, Plot<'a>);

/// Draws each of `planned` that has a point into `out` as a figure of `experiment`, adding it
/// to `figures`, and its stem to `textless` when it was drawn without text (no font).
pub(crate) fn draw_planned<'a>(
    planned: impl IntoIterator<Item = Planned<'a>>,
    experiment: &str,
    out: &Path,
    figures: &mut Vec<Figure>,
    textless: &mut Vec<String>,
) -> anyhow::Result<()> {
    for (stem, caption, plot) in planned {
        if plot.series.iter().all(|s| s.points.is_empty()) {
            continue;
        }
        if !draw(&plot, out, &stem)? {
            textless.push(stem.clone());
        }
        figures.push(Figure {
            experiment: experiment.to_string(),
            stem,
            caption,
        });
    }
    Ok(())
}

/// The note that the figures `textless` were drawn without text, if there are any.
pub(crate) fn note_textless(textless: &[String], notes: &mut Vec<String>) {
    if !textless.is_empty() {
        notes.push(format!(
            "no font could be loaded: {} drawn without titles, labels or legends",
            textless.join(", ")
        ));
    }
}

/// One labelled series of (x, statistic) points.
pub(crate) struct Series {
    pub(crate) label: String,
    pub(crate) points: Vec<(f64, Stat)>,
}

/// Distinct colours, in series order.
const COLOURS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

/// What kind of plot.
#[derive(Clone, Copy)]
pub(crate) enum Kind {
    /// Lines over time with confidence bands; log-scale y when `log_y`.
    Time { log_y: bool },
    /// Points with error bars versus the grid value.
    Versus,
    /// Points with error bars versus a positive grid value that spans decades (a swarm's
    /// size), on a log x axis with a key point at every value; log-scale y when `log_y`.
    Scaling { log_y: bool },
}

impl Kind {
    /// Whether the y axis is logarithmic.
    fn log_y(self) -> bool {
        matches!(
            self,
            Kind::Time { log_y: true } | Kind::Scaling { log_y: true }
        )
    }
}

pub(crate) struct Plot<'a> {
    pub(crate) title: String,
    pub(crate) x_label: &'a str,
    pub(crate) y_label: &'a str,
    pub(crate) kind: Kind,
    pub(crate) series: Vec<Series>,
    /// The quantity cannot be negative (a size, a loss): the axis and the intervals stop at 0.
    pub(crate) nonnegative: bool,
    /// A [`Kind::Versus`] plot's x key points and their labels (a grid's values, text or
    /// numbers), its series then centred around each; empty: whole-number ticks where
    /// plotters puts them.
    pub(crate) x_ticks: Vec<(f64, String)>,
}

/// The logical canvas (see [`super::style`]): the SVG is this size, the PNG twice it.
const CANVAS: (u32, u32) = (900, 560);

/// Draws `plot` as `stem.svg` and `stem.png`; returns whether the text could be drawn.
pub(crate) fn draw(plot: &Plot, out: &Path, stem: &str) -> anyhow::Result<bool> {
    let svg = out.join(format!("{stem}.svg"));
    let png = out.join(format!("{stem}.png"));
    let mut with_text = true;
    for pass in 0..2 {
        let text = pass == 0;
        let result = (|| -> Result<(), String> {
            let root = SVGBackend::new(&svg, Style::SVG.size(CANVAS)).into_drawing_area();
            draw_on(&root, plot, text, Style::SVG).map_err(|e| e.to_string())?;
            root.present().map_err(|e| e.to_string())?;
            crate::png::draw_png(&png, Style::PNG.size(CANVAS), |root| {
                draw_on(root, plot, text, Style::PNG).map_err(|e| e.to_string())
            })
        })();
        match result {
            Ok(()) => return Ok(with_text),
            Err(e) if text => {
                with_text = false;
                let _ = e;
            }
            Err(e) => anyhow::bail!("cannot draw {stem}: {e}"),
        }
    }
    Ok(with_text)
}

/// The corner of the plot area with the fewest data points (means and interval ends) under
/// where the legend goes, preferring upper right, upper left, lower right, lower left.
fn legend_corner(plot: &Plot, log_y: bool) -> SeriesLabelPosition {
    let (x0, x1, y0, y1) = bounds(plot);
    let (x0, x1) = x_range(plot.kind, x0, x1);
    let scale_x = |x: f64| match plot.kind {
        Kind::Scaling { .. } => (x.ln() - x0.ln()) / (x1.ln() - x0.ln()),
        _ => (x - x0) / (x1 - x0),
    };
    let scale_y = |y: f64| {
        if log_y {
            (y.max(y0).ln() - y0.ln()) / (y1.ln() - y0.ln())
        } else {
            (y - y0) / (y1 - y0)
        }
    };
    let mut counts = [0usize; 4];
    for s in &plot.series {
        for (x, st) in &s.points {
            let ci = st.ci.unwrap_or(0.0);
            for y in [st.mean, st.mean - ci, st.mean + ci] {
                if !y.is_finite() {
                    continue;
                }
                let (u, v) = (scale_x(*x), scale_y(y));
                let (left, right, top, bottom) = (u < 0.35, u > 0.65, v > 0.7, v < 0.3);
                for (i, hit) in [right && top, left && top, right && bottom, left && bottom]
                    .into_iter()
                    .enumerate()
                {
                    counts[i] += usize::from(hit);
                }
            }
        }
    }
    let best = (0..4).min_by_key(|&i| (counts[i], i)).unwrap_or(0);
    [
        SeriesLabelPosition::UpperRight,
        SeriesLabelPosition::UpperLeft,
        SeriesLabelPosition::LowerRight,
        SeriesLabelPosition::LowerLeft,
    ][best]
        .clone()
}

/// The x axis' range around the data's `[x0, x1]`: a point plot keeps half a grid step
/// beside its outer points, a log axis a quarter of its factor; a time axis is the data's.
fn x_range(kind: Kind, x0: f64, x1: f64) -> (f64, f64) {
    match kind {
        Kind::Versus => (x0 - 0.5, x1 + 0.5),
        Kind::Scaling { .. } => (x0 / 1.25, x1 * 1.25),
        Kind::Time { .. } => (x0, x1),
    }
}

/// The key points of a [`Kind::Scaling`] x axis: every x value of the plot, ascending.
fn grid_ticks(plot: &Plot) -> Vec<f64> {
    let mut xs: Vec<f64> = plot
        .series
        .iter()
        .flat_map(|s| s.points.iter().map(|(x, _)| *x))
        .filter(|x| x.is_finite() && *x > 0.0)
        .collect();
    xs.sort_by(f64::total_cmp);
    xs.dedup();
    xs
}

/// A linear axis whose key points are given (a grid's values): plotters' `with_key_points`
/// on a float range has no default formatting, which the mesh needs.
struct KeyedAxis {
    range: plotters::coord::types::RangedCoordf64,
    keys: Vec<f64>,
}

impl Ranged for KeyedAxis {
    type FormatOption = plotters::coord::ranged1d::DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.range.map(value, limit)
    }

    fn key_points<Hint: plotters::coord::ranged1d::KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            Vec::new()
        } else {
            self.keys.clone()
        }
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.range.range()
    }
}

type DrawResult<DB> = Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

fn bounds(plot: &Plot) -> (f64, f64, f64, f64) {
    let mut xs = (f64::INFINITY, f64::NEG_INFINITY);
    let mut ys = (f64::INFINITY, f64::NEG_INFINITY);
    let positive = plot.kind.log_y();
    let positive_x = matches!(plot.kind, Kind::Scaling { .. });
    for s in &plot.series {
        for (x, st) in &s.points {
            if positive_x && *x <= 0.0 {
                continue;
            }
            xs = (xs.0.min(*x), xs.1.max(*x));
            let ci = st.ci.unwrap_or(0.0);
            for y in [st.mean - ci, st.mean + ci, st.mean] {
                if y.is_finite() && (!positive || y > 0.0) {
                    ys = (ys.0.min(y), ys.1.max(y));
                }
            }
        }
    }
    if !xs.0.is_finite() {
        xs = if positive_x { (1.0, 10.0) } else { (0.0, 1.0) };
    }
    if !ys.0.is_finite() {
        ys = (if positive { 1e-3 } else { 0.0 }, 1.0);
    }
    if xs.1 <= xs.0 {
        xs = (xs.0 - 0.5, xs.1 + 0.5);
    }
    if positive {
        (xs.0, xs.1, ys.0 / 1.2, ys.1 * 1.2)
    } else {
        let pad = ((ys.1 - ys.0) * 0.08).max(1e-9);
        let lo = ys.0 - pad;
        (
            xs.0,
            xs.1,
            if plot.nonnegative { lo.max(0.0) } else { lo },
            ys.1 + pad,
        )
    }
}

/// A tick label: up to 3 significant digits, never `-0` (a rounding of a tiny negative).
fn tick(v: f64) -> String {
    if v == 0.0 || v.abs() < 1e-12 {
        return "0".to_string();
    }
    let digits = (2 - v.abs().log10().floor() as i32).max(0) as usize;
    let mut text = format!("{v:.digits$}");
    if text.contains('.') {
        text = text.trim_end_matches('0').trim_end_matches('.').to_string();
    }
    if text
        .trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        "0".to_string()
    } else {
        text
    }
}

/// An x tick label: the plot's own label at one of its [`Plot::x_ticks`], else the value as
/// a whole number (a time in seconds, a count).
fn x_tick(plot: &Plot, x: f64) -> String {
    plot.x_ticks
        .iter()
        .find(|(at, _)| (at - x).abs() < 1e-9)
        .map_or_else(|| format!("{x:.0}"), |(_, label)| label.clone())
}

/// The key points of a log axis over [lo, hi]: 1, 2 and 5 times each power of ten inside (or
/// more steps when the range spans less than a decade), so values below 1 are labelled too.
fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let mut out = Vec::new();
    let (e0, e1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let steps: &[f64] = if e1 - e0 <= 1 {
        &[1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0]
    } else {
        &[1.0, 2.0, 5.0]
    };
    for e in e0..=e1 {
        for m in steps {
            let v = m * 10f64.powi(e);
            if v >= lo && v <= hi {
                out.push(v);
            }
        }
    }
    out
}

/// Configures and draws the mesh: axis titles and tick labels in the paper style with text,
/// no tick labels without.
macro_rules! draw_mesh {
    ($chart:expr, $plot:expr, $text:expr, $st:expr) => {{
        let x_labels = |x: &f64| x_tick($plot, *x);
        let mut mesh = $chart.configure_mesh();
        mesh.light_line_style(WHITE.mix(0.0))
            .bold_line_style(BLACK.mix(0.08).stroke_width($st.upx(1.0)))
            .axis_style(BLACK.mix(0.6).stroke_width($st.upx(1.0)));
        if $text {
            // Times in whole seconds, robot counts as integers.
            mesh.x_desc($plot.x_label)
                .y_desc($plot.y_label)
                .axis_desc_style($st.font(style::AXIS))
                .label_style($st.font(style::TICK))
                .x_label_formatter(&x_labels)
                .y_label_formatter(&|y: &f64| tick(*y));
        } else {
            mesh.x_labels(0).y_labels(0);
        }
        mesh.draw()?;
    }};
}

fn draw_on<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    plot: &Plot,
    text: bool,
    st: Style,
) -> DrawResult<DB> {
    root.fill(&WHITE)?;
    let (x0, x1, y0, y1) = bounds(plot);
    let mut builder = ChartBuilder::on(root);
    builder.margin(st.upx(14.0));
    if text {
        builder
            .caption(&plot.title, st.font(style::TITLE))
            // Room for a line of tick labels and the axis title at the paper style's ems
            // (about 1.25 em a line, plus gaps); left, for five-character tick labels.
            .x_label_area_size(st.upx(style::TICK * 1.25 + style::AXIS * 1.25 + 10.0))
            .y_label_area_size(st.upx(style::TICK * 3.0 + style::AXIS * 1.25 + 12.0))
            // Half of the last x tick label ("5000") reaches past the plot's right edge.
            .margin_right(st.upx(style::TICK * 1.6));
    } else {
        builder
            .x_label_area_size(st.upx(10.0))
            .y_label_area_size(st.upx(10.0));
    }
    match plot.kind {
        Kind::Time { log_y: true } => {
            let mut chart = builder.build_cartesian_2d(
                x0..x1,
                (y0..y1).log_scale().with_key_points(log_ticks(y0, y1)),
            )?;
            draw_mesh!(chart, plot, text, st);
            draw_series(&mut chart, plot, text, y0, st)?;
        }
        Kind::Versus if !plot.x_ticks.is_empty() => {
            let (x0, x1) = x_range(plot.kind, x0, x1);
            let x_axis = KeyedAxis {
                range: (x0..x1).into(),
                keys: plot.x_ticks.iter().map(|(x, _)| *x).collect(),
            };
            let mut chart = builder.build_cartesian_2d(x_axis, y0..y1)?;
            draw_mesh!(chart, plot, text, st);
            draw_series(&mut chart, plot, text, y0, st)?;
        }
        Kind::Time { log_y: false } | Kind::Versus => {
            let (x0, x1) = x_range(plot.kind, x0, x1);
            let mut chart = builder.build_cartesian_2d(x0..x1, y0..y1)?;
            draw_mesh!(chart, plot, text, st);
            draw_series(&mut chart, plot, text, y0, st)?;
        }
        Kind::Scaling { log_y } => {
            let (x0, x1) = x_range(plot.kind, x0, x1);
            let x_axis = (x0..x1).log_scale().with_key_points(grid_ticks(plot));
            if log_y {
                let y_axis = (y0..y1).log_scale().with_key_points(log_ticks(y0, y1));
                let mut chart = builder.build_cartesian_2d(x_axis, y_axis)?;
                draw_mesh!(chart, plot, text, st);
                draw_series(&mut chart, plot, text, y0, st)?;
            } else {
                let mut chart = builder.build_cartesian_2d(x_axis, y0..y1)?;
                draw_mesh!(chart, plot, text, st);
                draw_series(&mut chart, plot, text, y0, st)?;
            }
        }
    }
    Ok(())
}

/// The filled band's opacity: one band reads at 0.2; with many series they overlap, so each
/// is fainter and the overlap stays readable.
fn band_alpha(series: usize) -> f64 {
    if series > 4 {
        0.10
    } else {
        0.20
    }
}

/// Draws every series of `plot` (and with `text`, the legend) on `chart`.
fn draw_series<'a, DB, X, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    plot: &Plot,
    text: bool,
    y_floor: f64,
    st: Style,
) -> DrawResult<DB>
where
    DB: DrawingBackend + 'a,
    X: plotters::coord::ranged1d::Ranged<ValueType = f64>,
    Y: plotters::coord::ranged1d::Ranged<ValueType = f64>,
{
    let log_y = plot.kind.log_y();
    for (i, s) in plot.series.iter().enumerate() {
        if s.points.is_empty() {
            continue;
        }
        match plot.kind {
            Kind::Time { .. } => draw_over_time(chart, plot, i, text, y_floor, st)?,
            Kind::Versus | Kind::Scaling { .. } => draw_points(chart, plot, i, text, y_floor, st)?,
        }
    }
    if text {
        chart
            .configure_series_labels()
            .label_font(st.font(style::TICK))
            .margin(st.upx(8.0))
            .legend_area_size(st.upx(30.0))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.4))
            .position(legend_corner(plot, log_y))
            .draw()?;
    }
    Ok(())
}

/// Series `i` of a plot over time: its mean as a line in its 95 % band (a lone point as a
/// marker with an error bar), and with `text` its legend entry.
fn draw_over_time<'a, DB, X, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    plot: &Plot,
    i: usize,
    text: bool,
    y_floor: f64,
    st: Style,
) -> DrawResult<DB>
where
    DB: DrawingBackend + 'a,
    X: plotters::coord::ranged1d::Ranged<ValueType = f64>,
    Y: plotters::coord::ranged1d::Ranged<ValueType = f64>,
{
    let (s, colour) = (&plot.series[i], COLOURS[i % COLOURS.len()]);
    let log_y = plot.kind.log_y();
    let line_w = st.upx(2.0);
    let dot = st.px(4.0);
    let lo = |st: &Stat| {
        let v = st.mean - st.ci.unwrap_or(0.0);
        if (log_y || plot.nonnegative) && v <= y_floor {
            y_floor
        } else {
            v
        }
    };
    let hi = |st: &Stat| st.mean + st.ci.unwrap_or(0.0);
    let band: Vec<(f64, f64)> = s
        .points
        .iter()
        .map(|(t, st)| (*t, hi(st)))
        .chain(s.points.iter().rev().map(|(t, st)| (*t, lo(st))))
        .collect();
    chart.draw_series(std::iter::once(Polygon::new(
        band,
        colour.mix(band_alpha(plot.series.len())),
    )))?;
    let line = chart.draw_series(LineSeries::new(
        s.points.iter().map(|(t, st)| (*t, st.mean)),
        colour.stroke_width(line_w),
    ))?;
    if text {
        line.label(s.label.clone()).legend(move |(x, y)| {
            PathElement::new(
                vec![(x, y), (x + 2 * dot * 3, y)],
                colour.stroke_width(line_w),
            )
        });
    }
    // A line of one point draws nothing and a band of one point is a sliver:
    // such a point gets a marker and an error bar, so a series the legend lists
    // is always in the plot.
    if let [(t, one)] = s.points.as_slice() {
        if !one.mean.is_finite() {
            return Ok(());
        }
        chart.draw_series(std::iter::once(PathElement::new(
            vec![(*t, lo(one)), (*t, hi(one))],
            colour.stroke_width(line_w),
        )))?;
        chart.draw_series(std::iter::once(Circle::new(
            (*t, one.mean),
            dot,
            colour.filled(),
        )))?;
    }
    Ok(())
}

/// Series `i` of a plot against a parameter: a marker with an error bar at each value, joined
/// by a faint line, shifted beside the other series; with `text` its legend entry.
fn draw_points<'a, DB, X, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    plot: &Plot,
    i: usize,
    text: bool,
    y_floor: f64,
    st: Style,
) -> DrawResult<DB>
where
    DB: DrawingBackend + 'a,
    X: plotters::coord::ranged1d::Ranged<ValueType = f64>,
    Y: plotters::coord::ranged1d::Ranged<ValueType = f64>,
{
    let (s, colour) = (&plot.series[i], COLOURS[i % COLOURS.len()]);
    let log_y = plot.kind.log_y();
    let line_w = st.upx(2.0);
    let dot = st.px(4.0);
    // Series side by side, so that their error bars do not hide each other: by a
    // step of the grid, or on a log axis by a factor.
    let centre = if plot.x_ticks.is_empty() {
        0.5
    } else {
        (plot.series.len() as f64 - 1.0) / 2.0
    };
    let shift = |x: f64| match plot.kind {
        Kind::Scaling { .. } => x * (1.0 + (i as f64 - 0.5) * 0.04),
        _ => x + (i as f64 - centre) * 0.08,
    };
    // A log axis shows no value at or below 0: such a point is left out and an
    // interval's lower end stops at the axis.
    let shown: Vec<(f64, Stat)> = s
        .points
        .iter()
        .filter(|(x, st)| match plot.kind {
            Kind::Scaling { .. } => *x > 0.0 && (!log_y || st.mean > 0.0),
            _ => true,
        })
        .map(|(x, st)| (shift(*x), *st))
        .collect();
    let low = |v: f64| {
        if matches!(plot.kind, Kind::Scaling { .. }) && (log_y || plot.nonnegative) {
            v.max(y_floor)
        } else {
            v
        }
    };
    for (x, st) in &shown {
        if let Some(ci) = st.ci {
            chart.draw_series(std::iter::once(PathElement::new(
                vec![(*x, low(st.mean - ci)), (*x, st.mean + ci)],
                colour.stroke_width(line_w),
            )))?;
        }
    }
    chart.draw_series(LineSeries::new(
        shown.iter().map(|(x, st)| (*x, st.mean)),
        colour.mix(0.5).stroke_width(st.upx(1.0)),
    ))?;
    let dots = chart.draw_series(
        shown
            .iter()
            .map(|(x, st)| Circle::new((*x, st.mean), dot, colour.filled())),
    )?;
    if text {
        dots.label(s.label.clone())
            .legend(move |(x, y)| Circle::new((x + 2 * dot, y), dot, colour.filled()));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stat(mean: f64, ci: f64) -> Stat {
        Stat {
            n: 3,
            mean,
            ci: Some(ci),
        }
    }

    #[test]
    fn ticks_are_tidy_and_log_axes_are_labelled_below_one() {
        assert_eq!(tick(-0.0), "0");
        assert_eq!(tick(-1e-15), "0");
        assert_eq!(tick(0.25), "0.25");
        assert_eq!(tick(1500.0), "1500");
        assert_eq!(tick(-2.5), "-2.5");
        let t = log_ticks(0.02, 0.3);
        for v in [0.02, 0.05, 0.1, 0.2] {
            assert!(t.iter().any(|x| (x - v).abs() < 1e-12), "{v} in {t:?}");
        }
        assert!(
            log_ticks(0.11, 0.35).len() >= 3,
            "{:?}",
            log_ticks(0.11, 0.35)
        );
    }

    /// The pixels of `png` (RGB, 8 bit) within 40 of `colour` in every channel.
    fn pixels_near(png: &Path, colour: RGBColor) -> usize {
        let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(png).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).unwrap();
        buf[..info.buffer_size()]
            .chunks(3)
            .filter(|p| {
                p[0].abs_diff(colour.0) < 40
                    && p[1].abs_diff(colour.1) < 40
                    && p[2].abs_diff(colour.2) < 40
            })
            .count()
    }

    #[test]
    fn a_series_of_one_point_is_drawn_with_a_marker() {
        let dir = std::env::temp_dir().join(format!("swarmfl-one-point-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let plot = |points: Vec<(f64, Stat)>| Plot {
            title: "one point".into(),
            x_label: "t",
            y_label: "loss",
            kind: Kind::Time { log_y: true },
            series: vec![
                Series {
                    label: "many".into(),
                    points: vec![(0.0, stat(1.0, 0.1)), (200.0, stat(0.5, 0.1))],
                },
                Series {
                    label: "one".into(),
                    points,
                },
            ],
            nonnegative: true,
            x_ticks: Vec::new(),
        };
        // The same legend in both (a series of one point); only its value differs: a number,
        // or NaN, which draws nothing. The difference is the marker and its error bar.
        draw(&plot(vec![(200.0, stat(0.8, 0.05))]), &dir, "with").unwrap();
        draw(&plot(vec![(200.0, stat(f64::NAN, 0.05))]), &dir, "without").unwrap();
        let with = pixels_near(&dir.join("with.png"), COLOURS[1]);
        let without = pixels_near(&dir.join("without.png"), COLOURS[1]);
        assert!(
            with > without + 100,
            "{with} vs {without} pixels of the series' colour"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_scaling_plot_has_log_axes_keyed_at_its_grid() {
        let plot = Plot {
            title: "wall".into(),
            x_label: "robots",
            y_label: "s",
            kind: Kind::Scaling { log_y: true },
            series: vec![
                Series {
                    label: "a".into(),
                    points: vec![(60.0, stat(3.0, 5.0)), (15.0, stat(1.0, 0.1))],
                },
                Series {
                    label: "b".into(),
                    points: vec![(1000.0, stat(80.0, 1.0)), (0.0, stat(2.0, 0.1))],
                },
            ],
            nonnegative: true,
            x_ticks: Vec::new(),
        };
        // A log axis has no 0: that point is left out of the ticks and the bounds.
        assert_eq!(grid_ticks(&plot), [15.0, 60.0, 1000.0]);
        let (x0, x1, y0, y1) = bounds(&plot);
        assert_eq!((x0, x1), (15.0, 1000.0));
        assert_eq!(x_range(plot.kind, x0, x1), (12.0, 1250.0));
        // The y axis spans the positive values only (3 - 5 < 0 is not one), with a margin.
        assert!(
            (y0 - 0.9 / 1.2).abs() < 1e-12 && (y1 - 81.0 * 1.2).abs() < 1e-9,
            "{y0} {y1}"
        );
        let dir = std::env::temp_dir().join(format!("swarmfl-scaling-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        assert!(draw(&plot, &dir, "scaling").unwrap(), "drawn with text");
        let svg = std::fs::read_to_string(dir.join("scaling.svg")).unwrap();
        // plotters writes a text's content on a line of its own.
        for label in ["15", "60", "1000"] {
            assert!(
                svg.contains(&format!(">\n{label}\n</text>")),
                "x tick {label} in the SVG"
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_size_axis_never_goes_below_zero() {
        let plot = Plot {
            title: "chain".into(),
            x_label: "t",
            y_label: "MB",
            kind: Kind::Time { log_y: false },
            series: vec![Series {
                label: "a".into(),
                points: vec![(0.0, stat(0.0, 0.4)), (100.0, stat(1.0, 0.2))],
            }],
            nonnegative: true,
            x_ticks: Vec::new(),
        };
        let (_, _, y0, _) = bounds(&plot);
        assert_eq!(y0, 0.0);
    }
}
