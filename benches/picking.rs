//! Per-ray cost of `AccelRayCast` against Bevy's `MeshRayCast` on the same worlds: 10^4 and
//! 10^5 entities of about 1k-triangle meshes, random rays through the scene.
//!
//! `cargo bench -p bevy_accel --bench picking -- --warm-up-time 1 --measurement-time 3`

use bevy::ecs::system::SystemState;
use bevy::picking::mesh_picking::ray_cast::{MeshRayCast, MeshRayCastSettings, RayCastVisibility};
use bevy::prelude::*;
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

fn picking(c: &mut Criterion) {
    let settings = MeshRayCastSettings::default().with_visibility(RayCastVisibility::Any);
    for n in [10_000, 100_000] {
        let mut group = c.benchmark_group(format!("picking/{n}"));
        group.sample_size(10);
        for (is_static, snapshot, name) in [
            (true, true, "bevy_accel AccelRayCast, static entities"),
            (
                false,
                false,
                "bevy_accel AccelRayCast, dynamic entities, binary tree",
            ),
        ] {
            let (mut app, rays) = world(n, is_static, snapshot);
            let mut ours = SystemState::<AccelRayCast>::new(app.world_mut());
            let mut ray_cast = ours.get(app.world()).expect("AccelRayCast is available");
            assert!(!ray_cast.trees().query().has_dynamic_ray_snapshot());
            bench_casts(&mut group, name, &rays, |ray| {
                ray_cast.cast_ray(ray, &settings).len()
            });
        }
        let (mut app, rays) = world(n, false, true);
        let mut ours = SystemState::<AccelRayCast>::new(app.world_mut());
        let mut bevy = SystemState::<MeshRayCast>::new(app.world_mut());
        let world = app.world();
        let mut ray_cast = ours.get(world).expect("AccelRayCast is available");
        assert!(ray_cast.trees().query().has_dynamic_ray_snapshot());
        bench_casts(
            &mut group,
            "bevy_accel AccelRayCast, dynamic entities at rest, snapshot",
            &rays,
            |ray| ray_cast.cast_ray(ray, &settings).len(),
        );
        let mut ray_cast = bevy.get(world).expect("MeshRayCast is available");
        bench_casts(&mut group, "bevy MeshRayCast", &rays, |ray| {
            ray_cast.cast_ray(ray, &settings).len()
        });
        group.finish();
    }
}

criterion_group!(benches, picking);
criterion_main!(benches);
