//! The report figures' paper style: one layout in logical pixels, drawn at two scales.
//!
//! A figure is laid out for a 900 px (7 inch, a two-column paper's full width) canvas: text
//! from 15 to 20 px is 9 to 11 pt printed at that width. The SVG is drawn at scale 1 (vector:
//! it prints at any size); the PNG at scale 2 (1800 px, about 260 dpi at 7 inches), so a PNG
//! in a paper or on a slide is as sharp as the SVG. Every size below is logical and goes
//! through [`Style::px`].

use plotters::style::{FontDesc, IntoFont};

/// The title.
pub(super) const TITLE: f64 = 20.0;
/// Axis titles.
pub(super) const AXIS: f64 = 17.0;
/// Tick labels, legend entries, heatmap row and column names.
pub(super) const TICK: f64 = 15.0;
/// Numbers written inside heatmap cells.
pub(super) const CELL: f64 = 13.0;

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

    /// The sans-serif font at a logical size.
    pub(super) fn font(self, logical: f64) -> FontDesc<'static> {
        ("sans-serif", logical * self.scale).into_font()
    }
}
