//! What moving instances costs a two-level scene: `InstancedScene::update_instances` (the top
//! level refit along the moved instances' paths, rebuilt once its expected slot boxes per ray
//! are 10% above a fresh build's) against a new scene over every instance each frame
//! (`InstancedScene::new`: what a caller without updates would do), with 1%, 10% and all of
//! the instances moving; and what the refits cost rays afterwards, through the updated scene
//! against a new one over the same instances.
//!
//! The scene: N copies of the bunny (one shared mesh BVH) placed at random in a cube of side
//! 2 * 50 * cbrt(N / 1000), so that the density stays that of 1,000 copies in a cube of side
//! 100. Each frame, the moving instances take a step of up to 1% of the cube's side per axis.
//! N = 10,000 and 100,000, 100 frames (1,000 and 10 frames with `--quick`).
//!
//! This replaces `crates/spatial_accel/examples/scene_update_timing.rs`; its Markdown lines are the
//! instance-update rows of BENCHMARKS.md's "Mesh builds and instanced scenes".

use crate::json::{Report, StressRow};
use crate::progress::Progress;
use crate::suites::{incoherent_rays, point};
use crate::timing::median;
use accel_testkit::Rng;
use glam::{Affine3A, Quat, Vec3};
use spatial_accel::mesh::{Instance, InstancedScene, MeshBvh};
use spatial_accel::{Backfaces, Ray};
use std::sync::Arc;
use std::time::Instant;

/// The shares of the instances that move each frame, in percent.
const MOVING: [usize; 3] = [1, 10, 100];

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

/// The rays whose closest hit differs between the updated scene and a new one over the same
/// instances (by distance: ties may name different triangles), as messages.
fn disagreements(updated: &InstancedScene, fresh: &InstancedScene, rays: &[Ray]) -> Vec<String> {
    rays.iter()
        .enumerate()
        .filter_map(|(k, r)| {
            let a = updated.cast_ray(r, Backfaces::Include).map(|h| h.hit.t);
            let b = fresh.cast_ray(r, Backfaces::Include).map(|h| h.hit.t);
            (a != b).then(|| {
                format!(
                    "instance updates, ray {k}: updated scene hits at {a:?}, a new one at {b:?}"
                )
            })
        })
        .collect()
}

/// One scene size: every share of moving instances in turn, `frames` frames each.
fn measure(count: usize, frames: usize, mesh: &Arc<MeshBvh>, report: &mut Report) {
    let half_side = 50.0 * (count as f32 / 1000.0).cbrt();
    let size = mesh.bounds().extent().max_element();
    let mut rng = Rng::new(7);
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
    let rays = incoherent_rays(20_000, half_side, 11);
    let step = 0.01 * 2.0 * half_side;
    for percent in MOVING {
        let moving = (count * percent / 100).max(1);
        let mut scene = InstancedScene::new(placements.iter().map(|&m| instance(m)).collect());
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
            updated.push(started.elapsed().as_secs_f64() * 1e3);
            let everything: Vec<Instance> = placements.iter().map(|&m| instance(m)).collect();
            let started = Instant::now();
            let fresh = InstancedScene::new(everything);
            new_scene.push(started.elapsed().as_secs_f64() * 1e3);
            drop(fresh);
        }
        let new_one = InstancedScene::new(placements.iter().map(|&m| instance(m)).collect());
        // Alternated, three rounds, so that neither tree has the cache or the machine's quiet
        // phase to itself.
        let (mut through_updated, mut through_new) = (Vec::new(), Vec::new());
        for _ in 0..3 {
            through_updated.push(rays_per_second(&scene, &rays));
            through_new.push(rays_per_second(&new_one, &rays));
        }
        // The mean as well as the median: the frames that rebuild are few, and the median
        // leaves them out.
        let mean = updated.iter().sum::<f64>() / updated.len().max(1) as f64;
        let new_mean = new_scene.iter().sum::<f64>() / new_scene.len().max(1) as f64;
        let (median_ms, new_ms) = (median(updated), median(new_scene));
        let rays_ratio = median(through_updated) / median(through_new);
        let figure = if percent == MOVING[0] {
            format!("`update_instances`, {count} instances, {percent}% moving")
        } else if percent == 100 {
            "the same, all moving".to_string()
        } else {
            format!("the same, {percent}% moving")
        };
        report.markdown.push(format!(
            "| {figure} | {median_ms:.3} ms ({mean:.3}) | a new scene {new_ms:.2} ms | {:.1}x \
             ({:.1}x) | rays {rays_ratio:.2}x a new scene's |",
            new_ms / median_ms,
            new_ms / mean,
        ));
        report.notes.push(format!(
            "{count} instances, {percent}% moving: a new scene's mean {new_mean:.2} ms; slot \
             area cost {:.2} against a new scene's {:.2}",
            scene.top_level().slot_area_cost(),
            new_one.top_level().slot_area_cost(),
        ));
        let scene_name = format!("{count} bunny instances, {percent}% moving");
        report.points.push(point(
            &scene_name,
            "update_instances",
            "default threshold",
            ("ms per frame (median)", median_ms),
            ("ray time / a new scene's", Some(1.0 / rays_ratio)),
        ));
        report.points.push(point(
            &scene_name,
            "InstancedScene::new",
            "every frame",
            ("ms per frame (median)", new_ms),
            ("ray time / a new scene's", Some(1.0)),
        ));
        let check = &rays[..rays.len().min(2_000)];
        let wrong = disagreements(&scene, &new_one, check);
        report.stress.push(StressRow {
            structure: format!("InstancedScene, {count} instances, {percent}% moving"),
            query: "closest hit, updated vs new".into(),
            cases: check.len() as u64,
            misses: wrong.len() as u64,
            ..StressRow::default()
        });
        report.failure_samples.extend(wrong.into_iter().take(3));
    }
}

/// Runs this part and adds its rows to `report`.
pub fn run(quick: bool, report: &mut Report) {
    let (counts, frames): (&[usize], usize) = if quick {
        (&[1_000], 10)
    } else {
        (&[10_000, 100_000], 100)
    };
    let bunny = accel_testkit::bunny();
    let (vertices, indices): (Vec<Vec3>, Vec<u32>) = (
        bunny.triangles().flat_map(|t| t.map(Vec3::from)).collect(),
        (0..bunny.indices.len() as u32 * 3).collect(),
    );
    let mesh = Arc::new(MeshBvh::new(&vertices, &indices).expect("the bunny"));
    let mut progress = Progress::new("update: instances", counts.len() + 1);
    report
        .markdown
        .push("| figure | accel | peer, same run | accel speed-up | note |".into());
    report.markdown.push("|---|---:|---|---:|---|".into());
    for &count in counts {
        progress.step(&format!("{count} instances"));
        measure(count, frames, &mesh, report);
    }
    report.markdown.push(String::new());
    progress.step("done");
    progress.finish();
}
