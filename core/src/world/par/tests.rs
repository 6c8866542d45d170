//! The parallel world gives the sequential world's bits, on every number of threads.

use rayon::ThreadPoolBuilder;

use super::super::physics::{self, Body, RobotGrid};
use super::super::{Arena, Controllers, Pose, WheelCommand, World};
use super::{Workers, PARALLEL_MIN_ROBOTS};
use crate::config::{Config, Preset};
use crate::rng::{self, Purpose};

/// `robots` robots at four times the paper's density (so robots meet and block each other
/// often), with obstacles, and a short held-out set.
fn crowded(robots: u32, slide: bool) -> Config {
    let mut c = Preset::Paper.config();
    let scale = f64::from(robots) / 15.0;
    c.world.robots = robots;
    c.world.arena_side_m = 2.5 * scale.sqrt();
    c.world.cylinders = (2.0 * scale).round() as u32;
    c.world.boxes = (2.0 * scale).round() as u32;
    c.world.slide_on_contact = slide;
    c.data.heldout_samples = 20;
    c.run.duration_s = 60.0;
    c.contract.penalised_ranks = 0;
    c
}

/// The world's digest after every tick and the events, with the world and the controllers on
/// `workers`.
fn trace(config: &Config, ticks: u64, workers: Workers<'_>) -> (Vec<String>, World) {
    let mut world = World::new(config, 3).unwrap();
    let mut controllers = Controllers::new(config, 3);
    let mut digests = Vec::new();
    for _ in 0..ticks {
        let event = controllers.decide_on(&world, workers);
        world.apply_on(&event, workers);
        digests.push(format!(
            "{} {}",
            world.digest().to_hex(),
            blake3::hash(&rmp_serde::to_vec(&event).unwrap())
        ));
    }
    (digests, world)
}

#[test]
fn a_large_world_has_the_same_bits_on_one_two_and_three_threads() {
    for slide in [false, true] {
        let config = crowded(PARALLEL_MIN_ROBOTS as u32 * 2, slide);
        let (one, world) = trace(&config, 400, Workers::SEQUENTIAL);
        let stats = world.stats();
        assert!(stats.blocked_moves > 100, "robots meet: {stats:?}");
        assert!(stats.samples_collected > 0, "robots record: {stats:?}");
        assert_eq!(stats.collisions, 0);
        for threads in [2, 3] {
            let pool = ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let workers = Workers::on(&pool);
            assert!(workers.for_robots(world.poses().len()).is_some());
            let (many, _) = trace(&config, 400, workers);
            let first = one.iter().zip(&many).position(|(a, b)| a != b);
            assert_eq!(
                first, None,
                "slide {slide}, {threads} threads: first tick that differs"
            );
        }
    }
}

/// Robots in a tight crowd, where many moves depend on the robots moved before them.
fn crowd(n: usize, rng_seed: u64) -> (Arena, Vec<Pose>, Vec<WheelCommand>) {
    let arena = Arena::with_obstacles(1.2, Vec::new(), 0.5);
    let mut rng = rng::stream(rng_seed, Purpose::Placement, 0);
    let r = 0.035;
    let mut poses: Vec<Pose> = Vec::new();
    while poses.len() < n {
        let (x, y) = (rng.range(-1.1, 1.1), rng.range(-1.1, 1.1));
        if poses
            .iter()
            .all(|q| (q.x - x) * (q.x - x) + (q.y - y) * (q.y - y) >= 4.0 * r * r)
        {
            let theta = rng.range(-std::f64::consts::PI, std::f64::consts::PI);
            poses.push(Pose { x, y, theta });
        }
    }
    let commands = (0..n)
        .map(|_| {
            let (l, r) = (rng.range(-0.02, 0.4), rng.range(-0.02, 0.4));
            WheelCommand::from_mps(l, r)
        })
        .collect();
    (arena, poses, commands)
}

#[test]
fn the_parallel_physics_moves_a_crowd_in_robot_order() {
    // Fast robots packed tight: a robot's move often depends on whether a robot before it
    // has already left the spot (a step that computed every robot against the old places, or
    // merged them in another order, would differ).
    let body = Body {
        radius_m: 0.035,
        wheel_base_m: 0.053,
        dt_s: 0.1,
    };
    let pool = ThreadPoolBuilder::new().num_threads(2).build().unwrap();
    let mut depends = 0;
    for seed in 0..20 {
        for slide in [false, true] {
            let (arena, poses, commands) = crowd(300, seed);
            let run = |parallel: bool| {
                let mut poses = poses.clone();
                let mut grid = RobotGrid::default();
                grid.rebuild(&arena.grid, &poses);
                let refused = if parallel {
                    physics::step_parallel(
                        &pool, &arena, &mut grid, &mut poses, &body, &commands, slide, None,
                    )
                } else {
                    physics::step(&arena, &mut grid, &mut poses, &body, &commands, slide)
                };
                (poses, refused)
            };
            let (sequential, parallel) = (run(false), run(true));
            assert_eq!(sequential.0.len(), parallel.0.len());
            for (i, (a, b)) in sequential.0.iter().zip(&parallel.0).enumerate() {
                assert_eq!(
                    (a.x.to_bits(), a.y.to_bits(), a.theta.to_bits()),
                    (b.x.to_bits(), b.y.to_bits(), b.theta.to_bits()),
                    "seed {seed}, slide {slide}: robot {i}"
                );
            }
            assert_eq!(sequential.1, parallel.1);
            // How often the order mattered: the step with the robots in reverse order differs.
            let mut reversed_poses: Vec<Pose> = poses.iter().rev().copied().collect();
            let reversed_commands: Vec<WheelCommand> = commands.iter().rev().copied().collect();
            let mut grid = RobotGrid::default();
            grid.rebuild(&arena.grid, &reversed_poses);
            physics::step(
                &arena,
                &mut grid,
                &mut reversed_poses,
                &body,
                &reversed_commands,
                slide,
            );
            reversed_poses.reverse();
            depends += usize::from(reversed_poses != sequential.0);
        }
    }
    assert!(
        depends >= 20,
        "the crowd's moves depend on the order: {depends} of 40"
    );
}
