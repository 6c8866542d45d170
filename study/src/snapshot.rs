//! Drawing a picture of the world (arena, obstacles, robots, radio links) as SVG or PNG, like
//! Fig. 1 of the paper: walls in black, obstacles in grey, robots as green disks (Byzantine
//! ones red) with a heading line, range-and-bearing links as cyan lines, and each robot's
//! proximity rays as short light-blue lines (as long as the free distance they measure).
//! Each robot carries its id; axes in metres, a 1 m scale bar and a legend explain the
//! picture. The legend and the scale bar sit in a panel right of the arena, so they cover no
//! robot, label or wall; the title names the run (preset, seed, the time shown). A run with behaviours other than the avoidance walk (`world.behaviour`) colours each
//! robot by its behaviour instead (avoidance green, flocking blue, foraging orange; Byzantine
//! robots then carry a red ring), draws the foraging nest and food sources, and marks a forager
//! carrying an item (a yellow dot) or resting (a white dot). Text is drawn with the system's sans-serif font (plotters `ttf`); if no font can
//! be loaded, the picture is drawn without text rather than failing.

use std::path::Path;

use anyhow::Context;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use swarmfl_core::config::Behaviour;
use swarmfl_core::replay;
use swarmfl_core::world::{foraging_flowfl, Forager, Obstacle, World};
use swarmfl_core::SimTime;

use crate::progress::{warn_if_truncated, Watch};

/// How one robot is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RobotMark {
    /// An honest robot.
    Honest,
    /// A Byzantine robot.
    Byzantine,
}

/// The picture: the arena's square chart, and the panel of legend and scale bar right of it
/// (wide enough for the legend's longest entry at [`LEGEND_PT`]).
const SIZE_PX: (u32, u32) = (1350, 900);
/// Width of the arena's chart (axes included); the panel takes the rest.
const ARENA_PX: u32 = 900;
/// The picture is meant to print 7 inches wide (a two-column page's full width, like the
/// report's figures): pixels per printed point (1/72 inch) at that width.
const PX_PER_PT: f64 = SIZE_PX.0 as f64 / (7.0 * 72.0);
/// Printed text sizes, in points: no text under 9 pt.
const TITLE_PT: f64 = 11.0;
const AXIS_PT: f64 = 10.0;
const TICK_PT: f64 = 9.25;
const LEGEND_PT: f64 = 9.25;
const ID_PT: f64 = 9.0;

/// A text size's em in pixels.
fn em(pt: f64) -> f64 {
    pt * PX_PER_PT
}

/// The sans-serif font whose em prints at `pt` points. plotters takes a "size" of 1.24 em
/// (it writes size / 1.24 into an SVG's `font-size` and draws that em into a PNG).
fn font(pt: f64) -> FontDesc<'static> {
    ("sans-serif", em(pt) * 1.24).into_font()
}
const LINK: RGBColor = RGBColor(0, 190, 210);
const RAY: RGBColor = RGBColor(120, 200, 255);
const OBSTACLE: RGBColor = RGBColor(150, 150, 150);
const HONEST: RGBColor = RGBColor(40, 170, 60);
const BYZANTINE: RGBColor = RGBColor(220, 30, 30);
const FLOCKING: RGBColor = RGBColor(40, 100, 220);
const FORAGING: RGBColor = RGBColor(230, 130, 0);
const NEST: RGBColor = RGBColor(250, 215, 160);
const FOOD: RGBColor = RGBColor(120, 80, 20);
const ITEM: RGBColor = RGBColor(255, 225, 0);

/// The colour of a behaviour's robots (avoidance keeps the honest robots' green).
pub fn behaviour_colour(b: Behaviour) -> RGBColor {
    match b {
        Behaviour::Flocking => FLOCKING,
        Behaviour::Foraging => FORAGING,
        Behaviour::Avoidance | Behaviour::Mixed => HONEST,
    }
}

/// A rectangle of the picture in pixels: left, top, right, bottom.
pub type PixelRect = (i32, i32, i32, i32);

/// Where a snapshot put its parts, so a test can see that nothing covers the arena.
#[derive(Clone, Debug, Default)]
pub struct Placed {
    /// The arena's plotting area (walls, robots and their ids are inside it).
    pub arena: PixelRect,
    /// The legend's box and the scale bar with its label (empty when drawn without text).
    pub overlays: Vec<(&'static str, PixelRect)>,
}

/// Draws `world` with the robots marked as given (missing marks are honest) into `out`
/// (`.svg` or `.png`, by extension).
pub fn draw(world: &World, marks: &[RobotMark], title: &str, out: &Path) -> anyhow::Result<Placed> {
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    if !matches!(ext.as_deref(), Some("svg" | "png")) {
        anyhow::bail!(
            "cannot draw {}: the file name must end in .svg or .png",
            out.display()
        );
    }
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| {
            format!(
                "cannot create the folder {} for {}",
                dir.display(),
                out.display()
            )
        })?;
    }
    let result = match ext.as_deref() {
        Some("svg") => {
            let root = SVGBackend::new(out, SIZE_PX).into_drawing_area();
            draw_on(&root, world, marks, Some(title))
                .or_else(|_| draw_on(&root, world, marks, None))
        }
        Some("png") => {
            let mut placed = Placed::default();
            crate::png::draw_png(out, SIZE_PX, |root| {
                placed = draw_on(root, world, marks, Some(title))
                    .or_else(|_| draw_on(root, world, marks, None))
                    .map_err(|e| format!("{e:#}"))?;
                Ok(())
            })
            .map_err(|e| anyhow::anyhow!(e))
            .map(|()| placed)
        }
        _ => unreachable!("the extension was checked above"),
    };
    let placed = result.with_context(|| format!("drawing the snapshot into {}", out.display()))?;
    debug_assert!(
        placed.overlays.iter().all(|(_, r)| apart(*r, placed.arena)),
        "the legend or the scale bar covers the arena: {placed:?}"
    );
    Ok(placed)
}

/// Two rectangles share no pixel.
fn apart(a: PixelRect, b: PixelRect) -> bool {
    a.0 >= b.2 || a.2 <= b.0 || a.1 >= b.3 || a.3 <= b.1
}

/// The chart a snapshot is drawn on: metres on both axes.
type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Draws the picture on `root`, with text (title, axes, ids, scale bar, legend) when `title`
/// is given. Layers in order: proximity rays, radio links, obstacles, walls, robots, text;
/// the legend and the scale bar in the panel right of the arena.
fn draw_on<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    world: &World,
    marks: &[RobotMark],
    title: Option<&str>,
) -> anyhow::Result<Placed>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(|e| anyhow::anyhow!("{e}"))?;
    let h = world.arena().half_side_m;
    let body = match title {
        Some(title) => root
            .titled(title, font(TITLE_PT))
            .map_err(|e| anyhow::anyhow!("{e}"))?,
        None => root.clone(),
    };
    let (left, panel) = body.split_horizontally(ARENA_PX);
    let mut builder = ChartBuilder::on(&left);
    builder.margin(20);
    if title.is_some() {
        // A line of tick labels and the axis title below; four-character tick labels
        // ("-1.5") and the rotated axis title left.
        let line = |pt: f64| (em(pt) * 1.25).ceil() as u32;
        builder
            .x_label_area_size(line(TICK_PT) + line(AXIS_PT) + 10)
            .y_label_area_size((em(TICK_PT) * 2.4).ceil() as u32 + line(AXIS_PT) + 12);
    }
    let mut chart = builder
        .build_cartesian_2d(-h..h, -h..h)
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    if title.is_some() {
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("x (m)")
            .y_desc("y (m)")
            .label_style(font(TICK_PT))
            .axis_desc_style(font(AXIS_PT))
            .x_label_formatter(&|v| format!("{v:.1}"))
            .y_label_formatter(&|v| format!("{v:.1}"))
            .draw()
            .map_err(|e| anyhow::anyhow!("{e}"))?;
    }
    let (xr, yr) = chart.plotting_area().get_pixel_range();
    let px_per_m = f64::from(xr.end - xr.start) / (2.0 * h);
    let mut placed = Placed {
        arena: (xr.start, yr.start, xr.end, yr.end),
        overlays: Vec::new(),
    };
    draw_rays(&mut chart, world)?;
    draw_links(&mut chart, world)?;
    draw_obstacles(&mut chart, world, px_per_m)?;
    draw_foraging_arena(&mut chart, world, px_per_m)?;
    // Walls.
    chart
        .draw_series(std::iter::once(Rectangle::new(
            [(-h, -h), (h, h)],
            BLACK.stroke_width(4),
        )))
        .map_err(err::<DB>)?;
    draw_robots(&mut chart, world, marks, px_per_m)?;
    if title.is_some() {
        draw_ids(&mut chart, world)?;
        placed.overlays = draw_panel(&panel, world, marks, px_per_m)?;
    }
    root.present().map_err(|e| anyhow::anyhow!("{e}"))?;
    Ok(placed)
}

/// A plotters error as an `anyhow` one.
fn err<DB: DrawingBackend>(e: DrawingAreaErrorKind<DB::ErrorType>) -> anyhow::Error
where
    DB::ErrorType: 'static,
{
    anyhow::anyhow!("{e}")
}

/// A length in metres as whole pixels (at least 1).
fn px(m: f64, px_per_m: f64) -> i32 {
    ((m * px_per_m).round() as i32).max(1)
}

/// Every robot's proximity rays, as long as the free space each sensor reads.
fn draw_rays<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    world: &World,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let r = world.robot_radius_m();
    let range = world.proximity_range_m();
    let mut readings = vec![0.0; world.proximity_sensors()];
    let n_sensors = readings.len();
    for (i, p) in world.poses().iter().enumerate() {
        world.proximity(i as u32, &mut readings);
        for (k, reading) in readings.iter().enumerate() {
            let a = p.theta + 2.0 * std::f64::consts::PI * k as f64 / n_sensors as f64;
            let (s, c) = (a.sin(), a.cos());
            let len = (1.0 - reading) * range;
            let from = (p.x + r * c, p.y + r * s);
            let to = (from.0 + len * c, from.1 + len * s);
            chart
                .draw_series(std::iter::once(PathElement::new(vec![from, to], RAY)))
                .map_err(err::<DB>)?;
        }
    }
    Ok(())
}

/// The radio links between robots in range.
fn draw_links<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    world: &World,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    for (i, j) in world.links() {
        let (a, b) = (world.poses()[i as usize], world.poses()[j as usize]);
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(a.x, a.y), (b.x, b.y)],
                LINK.stroke_width(1),
            )))
            .map_err(err::<DB>)?;
    }
    Ok(())
}

/// The cylinders and boxes of the arena.
fn draw_obstacles<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    world: &World,
    px_per_m: f64,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    for o in &world.arena().obstacles {
        match *o {
            Obstacle::Cylinder { x, y, radius_m } => {
                chart
                    .draw_series(std::iter::once(Circle::new(
                        (x, y),
                        px(radius_m, px_per_m),
                        OBSTACLE.filled(),
                    )))
                    .map_err(err::<DB>)?;
            }
            Obstacle::Box {
                x,
                y,
                half_side_m: e,
            } => {
                chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [(x - e, y - e), (x + e, y + e)],
                        OBSTACLE.filled(),
                    )))
                    .map_err(err::<DB>)?;
            }
        }
    }
    Ok(())
}

/// The foraging nest (a pale disk with an outline) and the food sources (brown disks).
fn draw_foraging_arena<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    world: &World,
    px_per_m: f64,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let Some(b) = world.behaviours() else {
        return Ok(());
    };
    if let Some(nest) = b.nest {
        for style in [NEST.filled(), FORAGING.stroke_width(2)] {
            chart
                .draw_series(std::iter::once(Circle::new(
                    (nest.x, nest.y),
                    px(nest.radius_m, px_per_m),
                    style,
                )))
                .map_err(err::<DB>)?;
        }
    }
    for f in &b.food {
        chart
            .draw_series(std::iter::once(Circle::new(
                (f.x, f.y),
                px(b.food_radius_m, px_per_m),
                FOOD.filled(),
            )))
            .map_err(err::<DB>)?;
    }
    if let Some(f) = &b.flowfl {
        // Flow-FL's nest is the strip west of its edge; its items lie on the floor until taken.
        let h = world.arena().half_side_m;
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(-h, -h), (foraging_flowfl::NEST_EDGE_X_M, h)],
                NEST.filled(),
            )))
            .map_err(err::<DB>)?;
        for &(x, y) in f.items.iter().flatten() {
            chart
                .draw_series(std::iter::once(Circle::new(
                    (x, y),
                    px(b.food_radius_m, px_per_m),
                    FOOD.filled(),
                )))
                .map_err(err::<DB>)?;
        }
    }
    Ok(())
}

/// The robots as disks in the colour of their mark (of their behaviour when the run has
/// behaviours, Byzantine ones ringed red), with heading lines and a forager's item.
fn draw_robots<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    world: &World,
    marks: &[RobotMark],
    px_per_m: f64,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let r = world.robot_radius_m();
    let behaviours = world.behaviours();
    for (i, p) in world.poses().iter().enumerate() {
        let byzantine = marks.get(i) == Some(&RobotMark::Byzantine);
        let color = match behaviours {
            Some(b) => behaviour_colour(b.of[i]),
            None if byzantine => BYZANTINE,
            None => HONEST,
        };
        chart
            .draw_series(std::iter::once(Circle::new(
                (p.x, p.y),
                px(r, px_per_m),
                color.filled(),
            )))
            .map_err(err::<DB>)?;
        if byzantine && behaviours.is_some() {
            chart
                .draw_series(std::iter::once(Circle::new(
                    (p.x, p.y),
                    px(r, px_per_m) + 2,
                    BYZANTINE.stroke_width(3),
                )))
                .map_err(err::<DB>)?;
        }
        // Flow-FL's foragers also return without an item (a fruitless trip): theirs is marked.
        let item = match behaviours.map(|b| (b.of[i], b.foragers[i], b.flowfl.as_ref())) {
            Some((Behaviour::Foraging, _, Some(f))) if f.robots[i].item.is_some() => Some(ITEM),
            Some((Behaviour::Foraging, Forager::Return, None)) => Some(ITEM),
            Some((Behaviour::Foraging, Forager::Rest { .. }, _)) => Some(WHITE),
            _ => None,
        };
        if let Some(item) = item {
            chart
                .draw_series(std::iter::once(Circle::new(
                    (p.x, p.y),
                    (px(r, px_per_m) / 2).max(2),
                    item.filled(),
                )))
                .map_err(err::<DB>)?;
        }
        let tip = (p.x + 2.2 * r * p.theta.cos(), p.y + 2.2 * r * p.theta.sin());
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(p.x, p.y), tip],
                BLACK.stroke_width(2),
            )))
            .map_err(err::<DB>)?;
    }
    Ok(())
}

/// Every robot's id, beside its body.
fn draw_ids<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    world: &World,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let r = world.robot_radius_m();
    for (i, p) in world.poses().iter().enumerate() {
        chart
            .draw_series(std::iter::once(Text::new(
                i.to_string(),
                (p.x + 1.3 * r, p.y + 1.3 * r),
                font(ID_PT).color(&BLACK),
            )))
            .map_err(err::<DB>)?;
    }
    Ok(())
}

/// The legend entries: one per kind of mark (per behaviour present, when there are any).
fn legend_entries(world: &World, marks: &[RobotMark]) -> Vec<(&'static str, ShapeStyle)> {
    let mut entries: Vec<(&str, ShapeStyle)> = Vec::new();
    match world.behaviours() {
        None => {
            entries.push(("honest robot (id)", HONEST.filled()));
            entries.push(("Byzantine robot", BYZANTINE.filled()));
        }
        Some(b) => {
            for (behaviour, label) in [
                (Behaviour::Avoidance, "avoidance robot (id)"),
                (Behaviour::Flocking, "flocking robot"),
                (Behaviour::Foraging, "foraging robot"),
            ] {
                if b.of.contains(&behaviour) {
                    entries.push((label, behaviour_colour(behaviour).filled()));
                }
            }
            if marks.contains(&RobotMark::Byzantine) {
                entries.push(("Byzantine robot (red ring)", BYZANTINE.stroke_width(3)));
            }
            if b.nest.is_some() || b.flowfl.is_some() {
                entries.push(("carrying food", ITEM.filled()));
                entries.push(("resting (white dot)", WHITE.filled()));
                entries.push(("nest", NEST.filled()));
                entries.push(("food source", FOOD.filled()));
            }
        }
    }
    entries.push(("radio link", LINK.stroke_width(2)));
    entries.push(("obstacle", OBSTACLE.filled()));
    entries.push(("proximity ray", RAY.stroke_width(1)));
    entries
}

/// The panel right of the arena: the legend in a box, then a scale bar of 1 m (or the largest
/// power of ten that fits) at the arena's scale. Returns where each was drawn.
fn draw_panel<DB: DrawingBackend>(
    panel: &DrawingArea<DB, Shift>,
    world: &World,
    marks: &[RobotMark],
    px_per_m: f64,
) -> anyhow::Result<Vec<(&'static str, PixelRect)>>
where
    DB::ErrorType: 'static,
{
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow::anyhow!("{e}");
    // The panel's own coordinates start at its top left corner; `placed` is in the picture's.
    let (dx, dy) = panel.get_base_pixel();
    let font = font(LEGEND_PT).color(&BLACK);
    let entries = legend_entries(world, marks);
    // Rows a line and a bit apart; a swatch of 0.75 em beside each label.
    let e_px = em(LEGEND_PT);
    let row = (e_px * 1.4).round() as i32;
    let swatch = (e_px * 0.75).round() as i32;
    let (x0, y0) = (10, 60);
    let text_x = x0 + 10 + swatch + 10;
    let bottom = y0 + 12 + row * entries.len() as i32;
    let (width, _) = panel.dim_in_pixel();
    let right = width as i32 - 10;
    panel
        .draw(&Rectangle::new([(x0, y0), (right, bottom)], BLACK))
        .map_err(e)?;
    let mut widest = 0;
    for (k, (label, style)) in entries.into_iter().enumerate() {
        let y = y0 + 12 + row * k as i32;
        let top = y + (row - swatch) / 2 - 2;
        panel
            .draw(&Rectangle::new(
                [(x0 + 10, top), (x0 + 10 + swatch, top + swatch)],
                style,
            ))
            .map_err(e)?;
        widest = widest.max(text_width(&font, label));
        panel
            .draw(&Text::new(label, (text_x, y), font.clone()))
            .map_err(e)?;
    }
    let h = world.arena().half_side_m;
    let mut bar_m = 1.0;
    while bar_m > h {
        bar_m /= 10.0;
    }
    let bar_px = px(bar_m, px_per_m);
    let bar_label = format!("{bar_m} m (scale bar)");
    let label_w = text_width(&font, &bar_label);
    let (bx, by) = (x0 + 10, bottom + 2 * row + 10);
    panel
        .draw(&Text::new(bar_label, (bx, by - row), font.clone()))
        .map_err(e)?;
    panel
        .draw(&PathElement::new(
            vec![(bx, by), (bx + bar_px, by)],
            BLACK.stroke_width(3),
        ))
        .map_err(e)?;
    Ok(vec![
        (
            "legend",
            (
                dx + x0,
                dy + y0,
                dx + right.max(text_x + widest),
                dy + bottom,
            ),
        ),
        (
            "scale bar",
            (
                dx + bx,
                dy + by - row,
                dx + bx + bar_px.max(label_w),
                dy + by + 2,
            ),
        ),
    ])
}

/// The width of `text` in pixels in `style`'s font (0 when no font can be loaded: the picture
/// is then drawn without text).
fn text_width(style: &TextStyle, text: &str) -> i32 {
    style
        .font
        .box_size(text)
        .map_or(0, |(w, _)| i32::try_from(w).unwrap_or(i32::MAX))
}

/// Draws the world of the log at `log` at simulated `time` (seconds) or right after `block` of
/// its final canonical chain (exactly one of them) into `out` (SVG or PNG by its extension);
/// returns the picture's title. A truncated log is warned of on `watch`.
pub fn snapshot(
    log: &Path,
    time: Option<f64>,
    block: Option<u64>,
    out: &Path,
    watch: &dyn Watch,
) -> anyhow::Result<String> {
    let (world, config, seed, title) = match (time, block) {
        (_, Some(height)) => {
            let index = swarmfl_core::inspect::index_run(log, Some(height))?;
            warn_if_truncated(watch, &index);
            let (state, _) = index
                .at_block
                .ok_or_else(|| anyhow::anyhow!("block {height} was not captured"))?;
            let title = format!(
                "preset {}, seed {}: t = {}, right after block {height}",
                index.config.preset,
                index.seed,
                state.world.time()
            );
            (state.world, index.config, index.seed, title)
        }
        (Some(time), None) => {
            if !(time.is_finite() && time >= 0.0) {
                anyhow::bail!("--time must be a non-negative number of seconds, got {time}");
            }
            // The world alone: a picture needs no ledger or contract, so a log whose plug-in
            // rule this process cannot run is drawn from its records.
            let (world, config, seed) = replay::world_at_time(log, SimTime::from_secs(time))?;
            // The fold stops at the first tick at or after the time asked; a world that never
            // got there is the run's end, and a picture of it under another time would lie.
            if world.time() < SimTime::from_secs(time) {
                anyhow::bail!(
                    "--time {time} is past the end of {} (its last tick is at t = {}): give a \
                     time from 0 to {}, or --block HEIGHT for a block of its final chain",
                    log.display(),
                    world.time(),
                    world.time().secs()
                );
            }
            let title = format!(
                "preset {}, seed {seed}: t = {}",
                config.preset,
                world.time()
            );
            (world, config, seed, title)
        }
        (None, None) => anyhow::bail!("give --time SECONDS or --block HEIGHT"),
    };
    let marks: Vec<RobotMark> = swarmfl_core::byzantine::byzantine_robots(&config, seed)
        .into_iter()
        .map(|b| {
            if b {
                RobotMark::Byzantine
            } else {
                RobotMark::Honest
            }
        })
        .collect();
    draw(&world, &marks, &title, out)?;
    Ok(title)
}

#[cfg(test)]
mod tests {
    use super::*;
    use swarmfl_core::config::Preset;
    use swarmfl_core::world::Controllers;

    #[test]
    fn a_paper_world_after_600_s_draws_as_png_and_svg() {
        let config = Preset::Paper.config();
        let mut world = World::new(&config, 1).unwrap();
        let mut controllers = Controllers::new(&config, 1);
        for _ in 0..6000 {
            let event = controllers.decide(&world);
            world.apply(&event);
        }
        let mut marks = vec![RobotMark::Honest; 15];
        marks[3] = RobotMark::Byzantine;
        let dir = std::env::temp_dir();
        for name in ["swarmfl-snapshot-600s.png", "swarmfl-snapshot-600s.svg"] {
            let out = dir.join(name);
            let placed = draw(&world, &marks, "paper preset, seed 1, t = 600 s", &out).unwrap();
            let size = std::fs::metadata(&out).unwrap().len();
            assert!(size > 5_000, "{name}: {size} bytes");
            // The legend and the scale bar are drawn, each clear of the arena: they cover no
            // robot, id or wall (robots and ids are inside the arena's plotting area).
            let names: Vec<&str> = placed.overlays.iter().map(|(n, _)| *n).collect();
            assert_eq!(names, ["legend", "scale bar"], "{name}");
            let (l, t, r, b) = placed.arena;
            assert!(
                r - l > 700 && b - t > 700,
                "{name}: arena {:?}",
                placed.arena
            );
            for (what, (l2, t2, r2, b2)) in &placed.overlays {
                // Inside the picture (the legend's text included), clear of the arena.
                assert!(
                    *r2 <= SIZE_PX.0 as i32 && *b2 <= SIZE_PX.1 as i32,
                    "{name}: the {what} {:?} runs off the picture",
                    (l2, t2, r2, b2)
                );
                let apart = *l2 >= r || *r2 <= l || *t2 >= b || *b2 <= t;
                assert!(
                    apart,
                    "{name}: the {what} {:?} overlaps the arena {:?}",
                    (l2, t2, r2, b2),
                    placed.arena
                );
            }
        }
        // plotters writes each text's content on a line of its own.
        let svg = std::fs::read_to_string(dir.join("swarmfl-snapshot-600s.svg"))
            .unwrap()
            .replace('\n', "");
        // Printed 7 inches wide, no text is under 9 pt: plotters writes each font's em into
        // `font-size`.
        let width: f64 = svg
            .split("width=\"")
            .nth(1)
            .and_then(|t| t.split('"').next()?.parse().ok())
            .expect("the SVG's width");
        let px_per_pt = width / (7.0 * 72.0);
        let ems: Vec<f64> = svg
            .split("font-size=\"")
            .skip(1)
            .filter_map(|t| t.split('"').next()?.trim_end_matches("px").parse().ok())
            .collect();
        assert!(ems.len() > 15, "ids, ticks, legend: {ems:?}");
        let smallest = ems.iter().copied().fold(f64::INFINITY, f64::min);
        assert!(
            smallest / px_per_pt >= 9.0 - 1e-6,
            "smallest em {smallest:.2} px prints at {:.2} pt at 7 in (under 9 pt)",
            smallest / px_per_pt
        );
        assert!(svg.contains("t = 600 s"), "the title is drawn");
        for text in [
            ">3<",
            ">14<",
            "Byzantine robot",
            "radio link",
            "1 m",
            "x (m)",
        ] {
            assert!(
                svg.contains(text),
                "ids, legend and scale are drawn: {text}"
            );
        }
        assert!(draw(&world, &marks, "x", &dir.join("snapshot.gif")).is_err());
        // A missing output folder is created, never reported as a debug message.
        let nested = dir.join(format!("swarmfl-snapshot-{}/a/b.png", std::process::id()));
        draw(&world, &marks, "nested", &nested).unwrap();
        assert!(nested.exists());
        std::fs::remove_dir_all(nested.parent().unwrap().parent().unwrap()).unwrap();
    }

    #[test]
    fn a_mixed_world_draws_each_behaviour_and_the_foraging_arena() {
        let config = swarmfl_core::config::Config::resolve(
            Some("smoke"),
            None,
            &["world.behaviour=mixed".into()],
        )
        .unwrap();
        let mut world = World::new(&config, 1).unwrap();
        let mut controllers = Controllers::new(&config, 1);
        for _ in 0..600 {
            let event = controllers.decide(&world);
            world.apply(&event);
        }
        let out = std::env::temp_dir().join(format!("swarmfl-mixed-{}.svg", std::process::id()));
        let placed = draw(&world, &[RobotMark::Byzantine], "mixed", &out).unwrap();
        // The longest legend entries ("Byzantine robot (red ring)") fit the panel.
        for (what, rect) in &placed.overlays {
            assert!(
                rect.2 <= SIZE_PX.0 as i32,
                "the {what} {rect:?} runs off the picture"
            );
        }
        let svg = std::fs::read_to_string(&out).unwrap().replace('\n', "");
        std::fs::remove_file(&out).unwrap();
        for text in [
            "avoidance robot",
            "flocking robot",
            "foraging robot",
            "Byzantine robot (red ring)",
            ">nest<",
            "food source",
        ] {
            assert!(svg.contains(text), "legend entry {text}");
        }
        // Each behaviour's colour fills some robot; the nest's fill is drawn.
        for colour in [HONEST, FLOCKING, FORAGING, NEST, FOOD] {
            let RGBColor(r, g, b) = colour;
            let hex = format!("#{r:02X}{g:02X}{b:02X}");
            assert!(svg.contains(&hex), "{hex} drawn");
        }
    }
}
