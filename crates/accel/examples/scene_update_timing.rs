//! What moving instances costs a two-level scene: `InstancedScene::update_instances` (the top
//! level refit along the moved instances' paths, rebuilt when refits have made it loose)
//! against a new scene over every instance each frame (`InstancedScene::new`, given the
//! instances; what a caller would do without updates), with 1%, 10% and all of the instances
//! moving; and what the refits cost rays afterwards.
//!
//! The scene: `n` copies of the bunny (one shared mesh BVH) placed at random in a cube of side
//! 2 * 50 * cbrt(n / 1000), so that the density stays that of 1,000 copies in a cube of side 100.
//! Each frame, the moving instances take a step of up to 1% of the cube's side on each axis
//! (a game's motion between frames). Median of `frames` frames.
//!
//! After those frames, incoherent rays (origins in the cube, random directions) through the
//! updated scene against a new scene over the same instances: how far the refits have let the
//! top level's quality go.
//!
//! `cargo run --release -p accel --example scene_update_timing [instances] [frames]`
//! (defaults 10,000 and 100). `REBUILD_THRESHOLD=g` sets the scene's rebuild threshold
//! (`InstancedScene::set_rebuild_threshold`; `inf` never rebuilds on its own).

#[path = "../benches/common/mod.rs"]
mod common;

use accel::mesh::{Instance, InstancedScene, MeshBvh};
use accel::{Backfaces, Ray};
use glam::{Affine3A, Quat, Vec3};
use std::sync::Arc;
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Rays per second of closest-hit casts through `scene`.
fn rays_per_second(scene: &InstancedScene, rays: &[Ray]) -> f64 {
    let started = Instant::now();
    let hits = rays
        .iter()
        .filter(|r| scene.cast_ray(r, Backfaces::Include).is_some())
        .count();
    std::hint::black_box(hits);
    rays.len() as f64 / started.elapsed().as_secs_f64()
}

fn main() {
    let mut args = std::env::args().skip(1);
    let count: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(10_000);
    let frames: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(100);
    let half_side = 50.0 * (count as f32 / 1000.0).cbrt();

    let bunny = accel_testkit::bunny();
    let (vertices, indices): (Vec<Vec3>, Vec<u32>) = (
        bunny.triangles().flat_map(|t| t.map(Vec3::from)).collect(),
        (0..bunny.indices.len() as u32 * 3).collect(),
    );
    let mesh = Arc::new(MeshBvh::new(&vertices, &indices).expect("the bunny"));
    let size = mesh.bounds().extent().max_element();

    let mut rng = accel_testkit::Rng::new(7);
    let mut placements: Vec<Affine3A> = (0..count)
        .map(|_| {
            let rotation = Quat::from_axis_angle(
                rng.unit_vector().into(),
                rng.range(0.0, core::f32::consts::TAU),
            );
            Affine3A::from_scale_rotation_translation(
                Vec3::splat(rng.range(2.0, 6.0) / size),
                rotation,
                rng.vec3(-half_side, half_side),
            )
        })
        .collect();
    let instance = |m: Affine3A| Instance {
        mesh: mesh.clone(),
        world_from_local: m,
    };
    let rays: Vec<Ray> = common::incoherent_rays(20_000, half_side, 11)
        .into_iter()
        .map(|(o, d)| Ray::new(o, d))
        .collect();
    let step = 0.01 * 2.0 * half_side;
    let threshold: f32 = std::env::var("REBUILD_THRESHOLD")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(InstancedScene::DEFAULT_REBUILD_THRESHOLD);

    println!(
        "{count} instances, {frames} frames; median ms per frame (update_instances | a new \
         scene), then rays after the frames"
    );
    for percent in [1usize, 10, 100] {
        let moving = (count * percent / 100).max(1);
        let mut scene = InstancedScene::new(placements.iter().map(|&m| instance(m)).collect());
        scene.set_rebuild_threshold(threshold);
        let (mut updated, mut new_scene) = (Vec::new(), Vec::new());
        for _ in 0..frames {
            let updates: Vec<(u32, Instance)> = (0..moving)
                .map(|_| {
                    let i = rng.below(count);
                    let moved = Affine3A::from_translation(rng.vec3(-step, step)) * placements[i];
                    placements[i] = moved;
                    (i as u32, instance(moved))
                })
                .collect();
            let started = Instant::now();
            scene
                .update_instances(updates)
                .expect("indices within the scene");
            updated.push(started.elapsed().as_secs_f64());
            // What a caller without `update_instances` does: a new scene over every instance.
            let everything: Vec<Instance> = placements.iter().map(|&m| instance(m)).collect();
            let started = Instant::now();
            let fresh = InstancedScene::new(everything);
            new_scene.push(started.elapsed().as_secs_f64());
            drop(fresh);
        }
        let new_one = InstancedScene::new(placements.iter().map(|&m| instance(m)).collect());
        // Alternated, three rounds, so that neither tree has the cache or the machine's
        // quiet phase to itself.
        let (mut through_updated, mut through_new) = (Vec::new(), Vec::new());
        for _ in 0..3 {
            through_updated.push(rays_per_second(&scene, &rays));
            through_new.push(rays_per_second(&new_one, &rays));
        }
        // The mean as well as the median: the frames that rebuild are few, and the median
        // leaves them out.
        let mean = updated.iter().sum::<f64>() / updated.len() as f64 * 1e3;
        let (updated, new_scene) = (median(updated) * 1e3, median(new_scene) * 1e3);
        let (a, b) = (median(through_updated), median(through_new));
        println!(
            "  {percent:>3}% moving ({moving} a frame): {updated:.3} ms (mean {mean:.3}) | \
             {new_scene:.3} ms ({:.1}x the median, {:.1}x the mean); rays {:.0}k/s through the \
             updated top level, {:.0}k/s through a new one ({:.2}x); slot area cost {:.2} against {:.2}",
            new_scene / updated,
            new_scene / mean,
            a / 1e3,
            b / 1e3,
            a / b,
            scene.top_level().slot_area_cost(),
            new_one.top_level().slot_area_cost(),
        );
    }
}
