//! `AccelRayCast` against Bevy's `MeshRayCast`, timed in alternation on the
//! same world (the `picking` bench's, 10^4 and 10^5 entities), and the ratio taken round by
//! round.
//!
//! Why a second picking bench: at 10^5 entities a ray of ours is bound by memory latency, and
//! the other tenants of a shared machine move it by 2x between runs minutes apart, while
//! `MeshRayCast` streams its boxes and moves by about 10%. Criterion times one contender after
//! the other, so its ratio mixes two phases of the machine. Here each round times every ray of
//! ours once, then a slice of the rays with `MeshRayCast`, so both figures of a round come from
//! the same few hundred milliseconds; the median over the rounds is the figure to quote.
//!
//! `cargo bench --profile dev --bench picking_ratio` (`-- 100000` for one size). Two more
//! arguments show how much of our time is the caches: `between=nothing` runs our passes
//! back to back (each pass then finds the previous one's lines cached, as in the criterion
//! bench, which repeats the same 1,024 rays), `between=flush` reads 64 MiB between passes
//! instead of casting Bevy's rays; the ratio column is meaningful only without them. With
//! `dynamic` the entities are dynamic and at rest, and rays walk the plugin's snapshot of the
//! still dynamic tree instead of the static tree. With `moving=P` the entities are dynamic and
//! P per mille of them take a small step before every round (one `App::update`, which refits
//! the snapshot); add `nosnapshot` to walk the binary dynamic tree instead, as rays did in
//! every frame with motion before the snapshot was kept through it. Candidates find their
//! meshes through the slot mesh table; `table=never` reads them from the ECS instead.

use accel_testkit::Rng;
use bevy::ecs::system::SystemState;
use bevy::picking::mesh_picking::ray_cast::{MeshRayCast, MeshRayCastSettings, RayCastVisibility};
use bevy::prelude::*;
use bevy_accel::picking::SlotMeshTableMode;
use bevy_accel::prelude::*;
use std::hint::black_box;
use std::time::Instant;
mod picking_world;
use picking_world::world;

/// Rays `MeshRayCast` casts per round: few enough at 10^5 entities that a round is short next
/// to the machine's phases, and the rounds together cast every ray once.
const BEVY_RAYS_PER_ROUND: usize = 32;

/// What runs between two passes of ours.
#[derive(Clone, Copy, PartialEq)]
enum Between {
    /// `MeshRayCast`'s slice of the rays: the measurement.
    Bevy,
    /// Nothing: our passes run warm.
    Nothing,
    /// A 64 MiB read: our passes run cold.
    Flush,
}

/// Times of one round, per ray.
struct Round {
    accel_us: f64,
    bevy_us: f64,
}

impl Round {
    fn ratio(&self) -> f64 {
        self.bevy_us / self.accel_us
    }
}

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    let mid = values.len() / 2;
    if values.len() % 2 == 1 {
        values[mid]
    } else {
        (values[mid - 1] + values[mid]) / 2.0
    }
}

fn main() {
    // `cargo bench` passes `--bench`; a number among the arguments picks one size.
    let sizes: Vec<usize> = std::env::args().filter_map(|a| a.parse().ok()).collect();
    let sizes = if sizes.is_empty() {
        vec![10_000, 100_000]
    } else {
        sizes
    };
    let between = if std::env::args().any(|a| a == "between=nothing") {
        Between::Nothing
    } else if std::env::args().any(|a| a == "between=flush") {
        Between::Flush
    } else {
        Between::Bevy
    };
    let at_rest = std::env::args().any(|a| a == "dynamic");
    let moving_per_mille: Option<usize> =
        std::env::args().find_map(|a| a.strip_prefix("moving=").and_then(|p| p.parse().ok()));
    let snapshot = !std::env::args().any(|a| a == "nosnapshot");
    let settings = MeshRayCastSettings::default().with_visibility(RayCastVisibility::Any);
    for n in sizes {
        // Dynamic entities at rest: rays walk the snapshot the plugin builds of the still
        // dynamic tree, a default scene's path (entities are dynamic unless marked static).
        let dynamic = at_rest || moving_per_mille.is_some();
        let table = if std::env::args().any(|a| a == "table=never") {
            SlotMeshTableMode::Never
        } else {
            SlotMeshTableMode::Always
        };
        let (mut app, rays) = world(n, !dynamic, snapshot, table);
        if moving_per_mille.is_some() {
            // The snapshot is kept through motion whatever the ray count: the bench measures
            // what a ray costs through it (by default it is kept only while rays outnumber the
            // movers, which 1,024 rays against 1% of 100,000 movers would leave to chance).
            app.world_mut()
                .resource_mut::<AccelSettings>()
                .bvh
                .ray_snapshot_rays_per_mover = 0.0;
        }
        let mut ours = SystemState::<AccelRayCast>::new(app.world_mut());
        let mut bevy = SystemState::<MeshRayCast>::new(app.world_mut());
        let mut movers = SystemState::<Query<&mut Transform, With<Mesh3d>>>::new(app.world_mut());
        let mut step_rng = Rng::new(0x9e37_79b9);
        let (mut frame_us, mut maintain_us, mut sync_us) = (Vec::new(), Vec::new(), Vec::new());
        let mut snapshot_rounds = 0;

        // Both must see the same world: the nearest hit of every ray agrees (the equivalence
        // tests check far more; this guards the bench against timing a broken setup).
        let (mut agree, mut with_hit) = (0, 0);
        {
            let world = app.world();
            let mut accel = ours.get(world).expect("AccelRayCast is available");
            let mut mesh = bevy.get(world).expect("MeshRayCast is available");
            for &ray in &rays {
                let a = accel.cast_ray(ray, &settings).first().map(|h| h.0);
                let b = mesh.cast_ray(ray, &settings).first().map(|h| h.0);
                agree += usize::from(a == b);
                with_hit += usize::from(a.is_some());
            }
        }
        println!(
            "\n{n} {} entities, {} rays: nearest hits agree on {agree}, {with_hit} rays hit",
            match (moving_per_mille, at_rest) {
                (Some(p), _) if snapshot => format!("dynamic ({p} per mille moving, snapshot)"),
                (Some(p), _) => format!("dynamic ({p} per mille moving, binary tree)"),
                (None, true) => "dynamic (at rest)".into(),
                (None, false) => "static".into(),
            },
            rays.len()
        );

        // Reads more than the caches hold, as a frame's other work would (`between=flush`).
        let flush = vec![
            1u8;
            if between == Between::Flush {
                64 << 20
            } else {
                0
            }
        ];
        let rounds_per_sweep = rays.len().div_ceil(BEVY_RAYS_PER_ROUND);
        let mut rounds = Vec::new();
        for round in 0..3 * rounds_per_sweep {
            if let Some(per_mille) = moving_per_mille {
                // Small steps, as a crowd walks: most stay inside their fat boxes.
                let mut query = movers.get_mut(app.world_mut()).expect("the movers query");
                for mut transform in query.iter_mut() {
                    if step_rng.below(1000) < per_mille {
                        let r = step_rng.f32();
                        transform.translation += Vec3::new(r - 0.5, 0.5 - r, r * 0.5) * 0.2;
                    }
                }
                let t = Instant::now();
                app.update();
                frame_us.push(t.elapsed().as_secs_f64() * 1e6);
                let stats = app.world().resource::<AccelStats>();
                maintain_us.push(stats.maintain_time.as_secs_f64() * 1e6);
                sync_us.push(stats.sync_time.as_secs_f64() * 1e6);
                snapshot_rounds += usize::from(
                    app.world()
                        .resource::<AccelTrees>()
                        .query()
                        .has_dynamic_ray_snapshot(),
                );
            }
            let world = app.world();
            let mut accel = ours.get(world).expect("AccelRayCast is available");
            let mut mesh = bevy.get(world).expect("MeshRayCast is available");
            let t = Instant::now();
            for &ray in &rays {
                black_box(accel.cast_ray(ray, &settings).len());
            }
            let accel_us = t.elapsed().as_secs_f64() * 1e6 / rays.len() as f64;
            let first = (round % rounds_per_sweep) * BEVY_RAYS_PER_ROUND;
            let slice = &rays[first..(first + BEVY_RAYS_PER_ROUND).min(rays.len())];
            let t = Instant::now();
            match between {
                Between::Bevy => {
                    for &ray in slice {
                        black_box(mesh.cast_ray(ray, &settings).len());
                    }
                }
                Between::Nothing => {}
                Between::Flush => {
                    black_box(flush.iter().map(|&b| u64::from(b)).sum::<u64>());
                }
            }
            let bevy_us = t.elapsed().as_secs_f64() * 1e6 / slice.len() as f64;
            rounds.push(Round { accel_us, bevy_us });
        }
        // The first sweep warms caches and the allocator; the ratio is taken over the rest.
        let timed = &rounds[rounds_per_sweep..];
        let ratios: Vec<f64> = timed.iter().map(Round::ratio).collect();
        let (lo, hi) = ratios.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &r| {
            (lo.min(r), hi.max(r))
        });
        println!(
            "| {n} | {:.2} us | {:.1} us | **{:.0}x** | {lo:.0}x-{hi:.0}x | {} |",
            median(timed.iter().map(|r| r.accel_us).collect()),
            median(timed.iter().map(|r| r.bevy_us).collect()),
            median(ratios),
            timed.len()
        );
        if !frame_us.is_empty() {
            println!(
                "moving: median frame (`App::update`) {:.0} us, of which sync {:.0} us and \
                 maintenance (refits) {:.0} us; rays walked the snapshot in {snapshot_rounds} \
                 of {} rounds",
                median(frame_us.clone()),
                median(sync_us.clone()),
                median(maintain_us.clone()),
                frame_us.len()
            );
        }
    }
    println!(
        "(columns: entities, AccelRayCast per ray (median of rounds), MeshRayCast per \
         ray (median), median of the per-round ratios, their range, rounds)"
    );
}
