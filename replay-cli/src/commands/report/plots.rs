//! Drawing a report's line and error-bar figures with plotters, as SVG and PNG.
//!
//! Text (titles, axis labels, legends) uses the system's sans-serif font through plotters'
//! `ttf` feature. If no font can be loaded, each figure is drawn again without any text rather
//! than failing, and the report notes it.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::stats::Stat;

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

/// One labelled series of (x, statistic) points.
pub(super) struct Series {
    pub(super) label: String,
    pub(super) points: Vec<(f64, Stat)>,
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
pub(super) enum Kind {
    /// Lines over time with confidence bands; log-scale y when `log_y`.
    Time { log_y: bool },
    /// Points with error bars versus the grid value.
    Versus,
}

pub(super) struct Plot<'a> {
    pub(super) title: String,
    pub(super) x_label: &'a str,
    pub(super) y_label: &'a str,
    pub(super) kind: Kind,
    pub(super) series: Vec<Series>,
    /// The quantity cannot be negative (a size, a loss): the axis and the intervals stop at 0.
    pub(super) nonnegative: bool,
}

/// Draws `plot` as `stem.svg` and `stem.png`; returns whether the text could be drawn.
pub(super) fn draw(plot: &Plot, out: &Path, stem: &str) -> anyhow::Result<bool> {
    let svg = out.join(format!("{stem}.svg"));
    let png = out.join(format!("{stem}.png"));
    let mut with_text = true;
    for pass in 0..2 {
        let text = pass == 0;
        let result = (|| -> Result<(), String> {
            let root = SVGBackend::new(&svg, (900, 560)).into_drawing_area();
            draw_on(&root, plot, text).map_err(|e| e.to_string())?;
            root.present().map_err(|e| e.to_string())?;
            crate::png::draw_png(&png, (900, 560), |root| {
                draw_on(root, plot, text).map_err(|e| e.to_string())
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
    let (x0, x1) = match plot.kind {
        Kind::Versus => (x0 - 0.5, x1 + 0.5),
        Kind::Time { .. } => (x0, x1),
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
                let (u, v) = ((x - x0) / (x1 - x0), scale_y(y));
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

type DrawResult<DB> = Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

fn bounds(plot: &Plot) -> (f64, f64, f64, f64) {
    let mut xs = (f64::INFINITY, f64::NEG_INFINITY);
    let mut ys = (f64::INFINITY, f64::NEG_INFINITY);
    let positive = matches!(plot.kind, Kind::Time { log_y: true });
    for s in &plot.series {
        for (x, st) in &s.points {
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
        xs = (0.0, 1.0);
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

/// Configures and draws the mesh: axis descriptions with text, no tick labels without.
macro_rules! draw_mesh {
    ($chart:expr, $plot:expr, $text:expr) => {{
        let mut mesh = $chart.configure_mesh();
        mesh.light_line_style(WHITE.mix(0.0));
        if $text {
            // Times in whole seconds, robot counts as integers.
            mesh.x_desc($plot.x_label)
                .y_desc($plot.y_label)
                .x_label_formatter(&|x: &f64| format!("{x:.0}"))
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
) -> DrawResult<DB> {
    root.fill(&WHITE)?;
    let (x0, x1, y0, y1) = bounds(plot);
    let mut builder = ChartBuilder::on(root);
    builder.margin(16);
    if text {
        builder
            .caption(&plot.title, ("sans-serif", 22))
            .x_label_area_size(40)
            .y_label_area_size(70);
    } else {
        builder.x_label_area_size(10).y_label_area_size(10);
    }
    match plot.kind {
        Kind::Time { log_y: true } => {
            let mut chart = builder.build_cartesian_2d(
                x0..x1,
                (y0..y1).log_scale().with_key_points(log_ticks(y0, y1)),
            )?;
            draw_mesh!(chart, plot, text);
            draw_series(&mut chart, plot, text, y0)?;
        }
        Kind::Time { log_y: false } | Kind::Versus => {
            let (x0, x1) = match plot.kind {
                Kind::Versus => (x0 - 0.5, x1 + 0.5),
                _ => (x0, x1),
            };
            let mut chart = builder.build_cartesian_2d(x0..x1, y0..y1)?;
            draw_mesh!(chart, plot, text);
            draw_series(&mut chart, plot, text, y0)?;
        }
    }
    Ok(())
}

fn draw_series<'a, DB, X, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    plot: &Plot,
    text: bool,
    y_floor: f64,
) -> DrawResult<DB>
where
    DB: DrawingBackend + 'a,
    X: plotters::coord::ranged1d::Ranged<ValueType = f64>,
    Y: plotters::coord::ranged1d::Ranged<ValueType = f64>,
{
    let log_y = matches!(plot.kind, Kind::Time { log_y: true });
    for (i, s) in plot.series.iter().enumerate() {
        let colour = COLOURS[i % COLOURS.len()];
        if s.points.is_empty() {
            continue;
        }
        match plot.kind {
            Kind::Time { .. } => {
                let lo = |st: &Stat| {
                    let v = st.mean - st.ci.unwrap_or(0.0);
                    if (log_y || plot.nonnegative) && v <= y_floor {
                        y_floor
                    } else {
                        v
                    }
                };
                let hi = |st: &Stat| st.mean + st.ci.unwrap_or(0.0);
                if plot.series.len() > 4 {
                    // Eight filled bands overlap into one grey wash: with many series each
                    // interval is drawn as two thin lines of its colour instead.
                    for bound in [&hi as &dyn Fn(&Stat) -> f64, &lo] {
                        chart.draw_series(LineSeries::new(
                            s.points.iter().map(|(t, st)| (*t, bound(st))),
                            colour.mix(0.45).stroke_width(1),
                        ))?;
                    }
                } else {
                    let band: Vec<(f64, f64)> = s
                        .points
                        .iter()
                        .map(|(t, st)| (*t, hi(st)))
                        .chain(s.points.iter().rev().map(|(t, st)| (*t, lo(st))))
                        .collect();
                    chart.draw_series(std::iter::once(Polygon::new(band, colour.mix(0.18))))?;
                }
                let line = chart.draw_series(LineSeries::new(
                    s.points.iter().map(|(t, st)| (*t, st.mean)),
                    colour.stroke_width(2),
                ))?;
                if text {
                    line.label(s.label.clone()).legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                    });
                }
            }
            Kind::Versus => {
                let offset = (i as f64 - 0.5) * 0.08;
                for (x, st) in &s.points {
                    if let Some(ci) = st.ci {
                        chart.draw_series(std::iter::once(PathElement::new(
                            vec![(x + offset, st.mean - ci), (x + offset, st.mean + ci)],
                            colour.stroke_width(2),
                        )))?;
                    }
                }
                chart.draw_series(LineSeries::new(
                    s.points.iter().map(|(x, st)| (x + offset, st.mean)),
                    colour.mix(0.5).stroke_width(1),
                ))?;
                let dots = chart.draw_series(
                    s.points
                        .iter()
                        .map(|(x, st)| Circle::new((x + offset, st.mean), 4, colour.filled())),
                )?;
                if text {
                    dots.label(s.label.clone())
                        .legend(move |(x, y)| Circle::new((x + 10, y), 4, colour.filled()));
                }
            }
        }
    }
    if text {
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.4))
            .position(legend_corner(plot, log_y))
            .draw()?;
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
        };
        let (_, _, y0, _) = bounds(&plot);
        assert_eq!(y0, 0.0);
    }
}
