//! Per-ray cost of `AccelRayCast` against Bevy's `MeshRayCast` on the same worlds: 10^4 and
//! 10^5 entities of about 1k-triangle meshes, random rays through the scene.
//!
//! `cargo bench -p bevy_accel --bench picking -- --warm-up-time 1 --measurement-time 3`
//!
//! A world is built only when a benchmark on it matches the command line's filter (plain
//! substrings separated by `|` here, where criterion takes a regex). Why: at 10^5 entities the per-ray time
//! depends on what the process allocated before the world (the same rays ran much slower in
//! a world built after two others had been built and dropped than in the first one:
//! docs/experiments.md, Picking), so
//! rows are best compared each from its own run, e.g. `-- "100000/bevy_accel AccelRayCast,
//! static|100000/bevy MeshRayCast, static"`. `MeshRayCast` is timed on the static world and on
//! the dynamic one at rest, so each of our rows on those worlds has Bevy's time from the same
//! world and run.

use bevy::ecs::system::SystemState;
use bevy::picking::mesh_picking::ray_cast::{MeshRayCast, MeshRayCastSettings, RayCastVisibility};
use bevy::prelude::*;
use bevy_accel::picking::SlotMeshTableMode;
use bevy_accel::prelude::*;
mod picking_world;
use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, Criterion, criterion_group, criterion_main};
use picking_world::world;
use std::hint::black_box;

/// Times `cast` on the rays in turn, one ray per iteration.
fn bench_casts(
    group: &mut BenchmarkGroup<'_, WallTime>,
    name: &str,
    rays: &[Ray3d],
    mut cast: impl FnMut(Ray3d) -> usize,
) {
    let mut i = 0;
    group.bench_function(name, |b| {
        b.iter(|| {
            i = (i + 1) % rays.len();
            black_box(cast(rays[i]))
        })
    });
}

/// Whether the command line's filter (if any) selects a benchmark among `ids`: the filter's
/// `|`-separated parts are taken as plain substrings (criterion takes a regex).
fn wanted(ids: &[String]) -> bool {
    /// Criterion's options that take a value as the next argument.
    const WITH_VALUE: &[&str] = &[
        "--warm-up-time",
        "--measurement-time",
        "--sample-size",
        "--nresamples",
        "--noise-threshold",
        "--confidence-level",
        "--significance-level",
        "--save-baseline",
        "--baseline",
        "--baseline-lenient",
        "--load-baseline",
        "--profile-time",
        "--plotting-backend",
        "--output-format",
        "--color",
        "--format",
    ];
    let mut filters = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        if WITH_VALUE.contains(&arg.as_str()) {
            args.next();
        } else if !arg.starts_with('-') {
            filters.extend(arg.split('|').map(str::to_owned));
        }
    }
    filters.is_empty()
        || ids
            .iter()
            .any(|id| filters.iter().any(|f| id.contains(f.as_str())))
}

fn picking(c: &mut Criterion) {
    let settings = MeshRayCastSettings::default().with_visibility(RayCastVisibility::Any);
    for n in [10_000, 100_000] {
        let mut group = c.benchmark_group(format!("picking/{n}"));
        group.sample_size(10);
        // (entities static, snapshot allowed, slot mesh table, our row, Bevy's row on the
        // same world)
        for (is_static, snapshot, table, name, bevy_name) in [
            (
                true,
                true,
                SlotMeshTableMode::Always,
                "bevy_accel AccelRayCast, static entities",
                Some("bevy MeshRayCast, static world"),
            ),
            (
                true,
                true,
                SlotMeshTableMode::Never,
                "bevy_accel AccelRayCast without the slot mesh table, static entities",
                None,
            ),
            (
                false,
                false,
                SlotMeshTableMode::Always,
                "bevy_accel AccelRayCast, dynamic entities, binary tree",
                None,
            ),
            (
                false,
                true,
                SlotMeshTableMode::Always,
                "bevy_accel AccelRayCast, dynamic entities at rest, snapshot",
                Some("bevy MeshRayCast, dynamic world at rest"),
            ),
        ] {
            let ids =
                [Some(name), bevy_name].map(|row| format!("picking/{n}/{}", row.unwrap_or(name)));
            if !wanted(&ids) {
                continue;
            }
            let (mut app, rays) = world(n, is_static, snapshot, table);
            let mut ours = SystemState::<AccelRayCast>::new(app.world_mut());
            let mut bevy = SystemState::<MeshRayCast>::new(app.world_mut());
            let world = app.world();
            let mut ray_cast = ours.get(world).expect("AccelRayCast is available");
            assert_eq!(
                ray_cast.trees().query().has_dynamic_ray_snapshot(),
                !is_static && snapshot
            );
            bench_casts(&mut group, name, &rays, |ray| {
                ray_cast.cast_ray(ray, &settings).len()
            });
            if let Some(bevy_name) = bevy_name {
                let mut ray_cast = bevy.get(world).expect("MeshRayCast is available");
                bench_casts(&mut group, bevy_name, &rays, |ray| {
                    ray_cast.cast_ray(ray, &settings).len()
                });
            }
        }
        group.finish();
    }
}

criterion_group!(benches, picking);
criterion_main!(benches);
