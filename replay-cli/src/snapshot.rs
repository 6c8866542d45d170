//! Drawing a picture of the world (arena, obstacles, robots, radio links) as SVG or PNG.

use std::path::Path;

use swarmfl_core::world::World;

/// How one robot is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RobotMark {
    /// An honest robot.
    Honest,
    /// A Byzantine robot.
    #[allow(dead_code)]
    Byzantine,
}

/// Draws `world` with the robots marked as given into `out` (`.svg` or `.png`).
pub fn draw(world: &World, marks: &[RobotMark], title: &str, out: &Path) -> anyhow::Result<()> {
    let _ = (world, marks, title, out);
    anyhow::bail!("snapshots are not drawn yet")
}
