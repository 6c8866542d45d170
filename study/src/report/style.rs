//! The report figures' paper style: one layout in logical pixels, drawn at two scales.
//!
//! A figure is laid out for a 900 px (7 inch, a two-column paper's full width) canvas, so a
//! printed point is 900 / 504 = 1.79 logical px. Every text size below is a font's em in
//! logical px, set from the printed size it must have: tick labels, legends, names and cell
//! numbers 9 pt or more, axis titles 10 pt, the title 11 pt. A heatmap of many columns narrows
//! its cells and writes its column names upwards to stay within 900 px (`heatmap.rs`); a figure
//! that is still wider keeps the same scale: its text has these printed sizes when it is printed
//! at 7 in per 900 px. The SVG is drawn at scale 1 (vector: it prints at any size); the PNG at
//! scale 2 (1800 px, about 260 dpi at 7 inches), so a PNG in a paper or on a slide is as sharp
//! as the SVG. Every size below is logical and goes through [`Style::px`].

use plotters::style::{FontDesc, IntoFont};

/// The layout's width printed, in inches: a two-column page's full width.
pub(super) const PRINT_WIDTH_IN: f64 = 7.0;
/// The layout's width in logical px.
pub(super) const LAYOUT_WIDTH_PX: f64 = 900.0;
/// Logical px per printed point (1/72 inch) at [`PRINT_WIDTH_IN`].
pub(super) const PX_PER_PT: f64 = LAYOUT_WIDTH_PX / (PRINT_WIDTH_IN * 72.0);

/// The title's em: 11 pt.
pub(super) const TITLE: f64 = 11.0 * PX_PER_PT;
/// Axis titles' em: 10 pt.
pub(super) const AXIS: f64 = 10.0 * PX_PER_PT;
/// The em of tick labels, legend entries, heatmap row and column names: 9.25 pt.
pub(super) const TICK: f64 = 9.25 * PX_PER_PT;
/// The em of numbers written inside heatmap cells and on its colour bar: 9 pt, the least.
pub(super) const CELL: f64 = 9.0 * PX_PER_PT;

/// plotters takes a font "size" of 1.24 em: it draws (and writes into an SVG's `font-size`)
/// an em of size / 1.24. [`Style::font`] takes the em, so the printed size is what is asked.
const SIZE_PER_EM: f64 = 1.24;

/// The scale a figure is drawn at.
#[derive(Clone, Copy, Debug)]
pub(super) struct Style {
    scale: f64,
}

impl Style {
    /// The SVG's (vector) scale.
    pub(super) const SVG: Style = Style { scale: 1.0 };
    /// The PNG's: twice the logical size.
    pub(super) const PNG: Style = Style { scale: 2.0 };

    /// A logical length in this scale's pixels.
    pub(super) fn px(self, logical: f64) -> i32 {
        (logical * self.scale).round() as i32
    }

    /// [`Style::px`] for the APIs that take unsigned sizes.
    pub(super) fn upx(self, logical: f64) -> u32 {
        self.px(logical).max(0) as u32
    }

    /// A canvas of `logical` size in this scale's pixels.
    pub(super) fn size(self, logical: (u32, u32)) -> (u32, u32) {
        (
            self.upx(f64::from(logical.0)),
            self.upx(f64::from(logical.1)),
        )
    }

    /// The sans-serif font whose em is `em` logical px.
    pub(super) fn font(self, em: f64) -> FontDesc<'static> {
        ("sans-serif", em * SIZE_PER_EM * self.scale).into_font()
    }
}

/// The width of `text` in logical px at an em of `em`: measured with the font, or, when no
/// font can be loaded (the figure is then drawn without text), 0.6 em a character.
pub(super) fn text_width(em: f64, text: &str) -> f64 {
    match Style::SVG.font(em).box_size(text) {
        Ok((w, _)) => f64::from(w),
        Err(_) => 0.6 * em * text.chars().count() as f64,
    }
}
