//! Picking: `AccelRayCast` (mesh hits, and bounds only with `cast_ray_bounds`) against Bevy's
//! `MeshRayCast` on the same world and rays, nearest hit per ray, `RayCastVisibility::Any`.
//! Absorbs the former `benches/picking_ratio.rs`, `benches/picking.rs` and
//! `benches/picking_world`.
//!
//! Timed in alternation: at 10^5 entities a ray of ours is bound by memory latency, and the
//! other tenants of a shared machine move it by 2x between runs minutes apart, while
//! `MeshRayCast` streams its boxes and moves by about 10%. So each round times every ray of
//! ours once (*cold*: `MeshRayCast`'s last slice has just evicted our trees, as a game's other
//! work would between its one or two rays a frame), then the same rays again (*warm*: what a
//! ray reads is cached, as in a criterion loop), then a slice of 32 rays with `MeshRayCast`;
//! both figures of a round come from the same few hundred milliseconds. Rounds alternate
//! between mesh casts and bounds-only casts; the first sweep of the rays warms the caches and
//! the allocator and is not counted. Times are medians over the rounds; the notes give the
//! median of the per-round ratios (Bevy's time over our cold one) and their range.
//!
//! Worlds (see [`world::WorldKind`]): static entities (the static tree's wide copy), with and
//! without the slot mesh table; dynamic at rest (the dynamic BVH's 16-wide snapshot), on the
//! binary tree, with 1% moving before every round (the snapshot refit; the notes give the
//! frame's cost), and at rest in the octree and the grid. A world is built after the last one
//! is dropped; at 10^5 entities the per-ray time depends on what the process allocated
//! before, so compare rows of one world.
//!
//! Error: the share of rays whose nearest hit entity differs from `MeshRayCast`'s. For mesh
//! casts it must be 0, and every disagreement counts as a miss in the report's failure rows
//! (checked on every ray before the timed rounds and again after them); for bounds-only casts
//! it is the price of skipping the triangles.

mod world;

use super::point;
use crate::json::{Point, Report, StressRow};
use crate::progress::Progress;
use crate::timing::median;
use bevy::ecs::system::SystemState;
use bevy::picking::mesh_picking::ray_cast::{MeshRayCast, MeshRayCastSettings, RayCastVisibility};
use bevy::prelude::*;
use bevy_accel::picking::SlotMeshTableMode;
use bevy_accel::prelude::*;
use std::hint::black_box;
use std::time::Instant;
use world::{WorldKind, has_snapshot, world};

/// Rays `MeshRayCast` casts per round: few enough at 10^5 entities that a round is short next
/// to the machine's phases, and a sweep of rounds casts every ray once.
const BEVY_RAYS_PER_ROUND: usize = 32;

/// At most this many wrong mesh hits are described in the report.
const SAMPLES: usize = 10;

/// The default world's settings, which the others vary.
const STATIC: WorldKind = WorldKind {
    name: "static",
    is_static: true,
    snapshot: true,
    table: SlotMeshTableMode::Always,
    index: IndexChoice::Bvh,
    moving_per_mille: None,
};

const AT_REST: WorldKind = WorldKind {
    name: "dynamic at rest, snapshot",
    is_static: false,
    ..STATIC
};

const GRID: WorldKind = WorldKind {
    name: "dynamic at rest, grid",
    snapshot: false,
    index: IndexChoice::Grid,
    ..AT_REST
};

/// The sizes of one run.
struct Sizes {
    entities: &'static [usize],
    worlds: &'static [WorldKind],
    rays: usize,
    /// Sweeps of the rays timed after the warm-up sweep.
    timed_sweeps: usize,
}

const FULL: Sizes = Sizes {
    entities: &[10_000, 100_000],
    worlds: &[
        STATIC,
        WorldKind {
            name: "static, no slot mesh table",
            table: SlotMeshTableMode::Never,
            ..STATIC
        },
        AT_REST,
        WorldKind {
            name: "dynamic, binary tree",
            snapshot: false,
            ..AT_REST
        },
        WorldKind {
            name: "dynamic, 1% moving, snapshot",
            moving_per_mille: Some(10),
            ..AT_REST
        },
        WorldKind {
            name: "dynamic at rest, octree",
            snapshot: false,
            index: IndexChoice::Octree,
            ..AT_REST
        },
        GRID,
    ],
    rays: 1024,
    timed_sweeps: 4,
};

const QUICK: Sizes = Sizes {
    entities: &[10_000],
    worlds: &[STATIC, AT_REST, GRID],
    rays: 256,
    timed_sweeps: 2,
};

/// What our casts are asked for.
#[derive(Clone, Copy, PartialEq)]
enum Target {
    Meshes,
    Bounds,
}

/// The nearest hits' agreement with `MeshRayCast` over every ray.
#[derive(Default)]
struct Agreement {
    rays: u64,
    mesh_wrong: u64,
    bounds_wrong: u64,
    /// The first disagreements of mesh casts.
    samples: Vec<String>,
}

/// Casts every ray with the three and counts where ours differ from `MeshRayCast`'s nearest
/// hit.
fn agreement(
    app: &App,
    states: &mut (SystemState<AccelRayCast>, SystemState<MeshRayCast>),
    rays: &[Ray3d],
    settings: &MeshRayCastSettings,
    into: &mut Agreement,
) {
    let world = app.world();
    let mut accel = states.0.get(world).expect("AccelRayCast is available");
    let mut mesh = states.1.get(world).expect("MeshRayCast is available");
    for &ray in rays {
        let want = mesh
            .cast_ray(ray, settings)
            .first()
            .map(|h| (h.0, h.1.distance));
        let got = accel
            .cast_ray(ray, settings)
            .first()
            .map(|h| (h.0, h.1.distance));
        let bounds = accel
            .cast_ray_bounds(ray, f32::INFINITY, settings)
            .first()
            .map(|h| h.0);
        into.rays += 1;
        into.bounds_wrong += u64::from(bounds != want.map(|w| w.0));
        if got.map(|g| g.0) != want.map(|w| w.0) {
            into.mesh_wrong += 1;
            if into.samples.len() < SAMPLES {
                into.samples.push(format!(
                    "ray from {} along {}: MeshRayCast's nearest hit {want:?}, ours {got:?}",
                    ray.origin, *ray.direction
                ));
            }
        }
    }
}

/// One round's times, microseconds per ray.
struct Round {
    target: Target,
    cold: f64,
    warm: f64,
    bevy: f64,
}

/// Microseconds per ray of `cast` over `rays`.
fn per_ray_us(rays: &[Ray3d], mut cast: impl FnMut(Ray3d) -> usize) -> f64 {
    let t = Instant::now();
    for &ray in rays {
        black_box(cast(ray));
    }
    t.elapsed().as_secs_f64() * 1e6 / rays.len().max(1) as f64
}

/// The per-frame medians of a moving world, microseconds.
#[derive(Default)]
struct Motion {
    frame: Vec<f64>,
    sync: Vec<f64>,
    maintain: Vec<f64>,
    snapshot_rounds: usize,
}

/// Moves `per_mille` of the entities a small step, as a crowd walks (most stay inside their
/// fat boxes), and runs the frame that takes the moves in.
fn step(app: &mut App, per_mille: usize, rng: &mut accel_testkit::Rng, motion: &mut Motion) {
    let world = app.world_mut();
    let mut movers = world.query_filtered::<&mut Transform, With<Mesh3d>>();
    for mut transform in movers.iter_mut(world) {
        if rng.below(1000) < per_mille {
            let r = rng.f32();
            transform.translation += Vec3::new(r - 0.5, 0.5 - r, r * 0.5) * 0.2;
        }
    }
    let t = Instant::now();
    app.update();
    motion.frame.push(t.elapsed().as_secs_f64() * 1e6);
    let stats = app.world().resource::<AccelStats>();
    motion
        .maintain
        .push(stats.maintain_time.as_secs_f64() * 1e6);
    motion.sync.push(stats.sync_time.as_secs_f64() * 1e6);
    motion.snapshot_rounds += usize::from(has_snapshot(app));
}

/// The rounds on one world; `rays` are cast in slices of [`BEVY_RAYS_PER_ROUND`] by Bevy.
fn rounds(
    app: &mut App,
    states: &mut (SystemState<AccelRayCast>, SystemState<MeshRayCast>),
    rays: &[Ray3d],
    (kind, timed_sweeps): (WorldKind, usize),
    settings: &MeshRayCastSettings,
    motion: &mut Motion,
) -> Vec<Round> {
    let per_sweep = rays.len().div_ceil(BEVY_RAYS_PER_ROUND);
    let mut rng = accel_testkit::Rng::new(0x9e37_79b9);
    let mut out = Vec::new();
    for round in 0..(1 + timed_sweeps) * per_sweep {
        if let Some(per_mille) = kind.moving_per_mille {
            step(app, per_mille, &mut rng, motion);
        }
        let world = app.world();
        let mut accel = states.0.get(world).expect("AccelRayCast is available");
        let mut mesh = states.1.get(world).expect("MeshRayCast is available");
        let target = if round % 2 == 0 {
            Target::Meshes
        } else {
            Target::Bounds
        };
        let mut ours = |ray: Ray3d| match target {
            Target::Meshes => accel.cast_ray(ray, settings).len(),
            Target::Bounds => accel.cast_ray_bounds(ray, f32::INFINITY, settings).len(),
        };
        let cold = per_ray_us(rays, &mut ours);
        let warm = per_ray_us(rays, &mut ours);
        let first = (round % per_sweep) * BEVY_RAYS_PER_ROUND;
        let slice = &rays[first..(first + BEVY_RAYS_PER_ROUND).min(rays.len())];
        let bevy = per_ray_us(slice, |ray| mesh.cast_ray(ray, settings).len());
        if round >= per_sweep {
            out.push(Round {
                target,
                cold,
                warm,
                bevy,
            });
        }
    }
    out
}

/// Runs the suite.
pub fn run(quick: bool) -> Report {
    let sizes = if quick { QUICK } else { FULL };
    let settings = MeshRayCastSettings::default().with_visibility(RayCastVisibility::Any);
    let mut progress = Progress::new("picking", sizes.entities.len() * sizes.worlds.len() + 1);
    let mut points: Vec<Point> = Vec::new();
    let (mut notes, mut stress, mut samples) = (Vec::new(), Vec::new(), Vec::new());
    for &n in sizes.entities {
        for &kind in sizes.worlds {
            let scene = format!("{n} entities, {}", kind.name);
            progress.step(&scene);
            let (mut app, rays, snapshot_note) = world(n, kind, sizes.rays);
            notes.extend(snapshot_note);
            let mut states = (
                SystemState::<AccelRayCast>::new(app.world_mut()),
                SystemState::<MeshRayCast>::new(app.world_mut()),
            );
            let mut agree = Agreement::default();
            agreement(&app, &mut states, &rays, &settings, &mut agree);
            let mut motion = Motion::default();
            let timed = rounds(
                &mut app,
                &mut states,
                &rays,
                (kind, sizes.timed_sweeps),
                &settings,
                &mut motion,
            );
            agreement(&app, &mut states, &rays, &settings, &mut agree);

            let of = |target: Target| timed.iter().filter(move |r| r.target == target);
            let wrong_pct = |wrong: u64| Some(100.0 * wrong as f64 / agree.rays.max(1) as f64);
            let quality = "nearest hit off MeshRayCast's, % of rays";
            let bevy_us = median(timed.iter().map(|r| r.bevy).collect());
            points.push(point(
                &scene,
                "MeshRayCast",
                "",
                ("us per ray", bevy_us),
                (quality, Some(0.0)),
            ));
            for (target, method, wrong) in [
                (Target::Meshes, "AccelRayCast", agree.mesh_wrong),
                (Target::Bounds, "AccelRayCast bounds", agree.bounds_wrong),
            ] {
                let cold = median(of(target).map(|r| r.cold).collect());
                let warm = median(of(target).map(|r| r.warm).collect());
                for (setting, us) in [("cold", cold), ("warm", warm)] {
                    points.push(point(
                        &scene,
                        method,
                        setting,
                        ("us per ray", us),
                        (quality, wrong_pct(wrong)),
                    ));
                }
                let ratios: Vec<f64> = of(target).map(|r| r.bevy / r.cold.max(1e-9)).collect();
                let (lo, hi) = ratios.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &r| {
                    (lo.min(r), hi.max(r))
                });
                notes.push(format!(
                    "{scene}, {method}: MeshRayCast/ours {:.0}x cold (per round {lo:.0}x-{hi:.0}x, \
                     {} rounds), {:.0}x warm",
                    median(ratios.clone()),
                    ratios.len(),
                    bevy_us / warm.max(1e-9),
                ));
            }
            if !motion.frame.is_empty() {
                notes.push(format!(
                    "{scene}: median frame (`App::update`) {:.0} us, of which sync {:.0} us and \
                     maintenance (refits) {:.0} us; rays walked the snapshot in {} of {} rounds",
                    median(motion.frame.clone()),
                    median(motion.sync.clone()),
                    median(motion.maintain.clone()),
                    motion.snapshot_rounds,
                    motion.frame.len()
                ));
            }
            let room = SAMPLES.saturating_sub(samples.len());
            samples.extend(
                agree
                    .samples
                    .iter()
                    .take(room)
                    .map(|s| format!("{scene}: {s}")),
            );
            stress.push(StressRow {
                structure: format!("AccelRayCast/{:?}", kind.index),
                query: format!("{scene}: MeshRayCast's nearest hit"),
                cases: agree.rays,
                misses: agree.mesh_wrong,
                ..StressRow::default()
            });
        }
    }
    progress.step("done");
    progress.finish();
    Report {
        suite: "picking".into(),
        quick,
        points,
        notes,
        stress,
        failure_samples: samples,
        ..Report::default()
    }
}
