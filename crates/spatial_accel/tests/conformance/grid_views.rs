//! The grid's views over cells that fill their range, where the frustum and view walks halve
//! the occupied range into blocks and skip the blocks out of view: a field of boxes on a
//! plane seen from above and from the ground (the plugin's scene), a dense cube, and boxes
//! spanning several cells, fresh and through frames of motion, each view checked against
//! brute force.

use crate::scenes::random_frustum;
use crate::spatial::{check_frustum, check_queries, check_views};
use accel_testkit::Rng;
use glam::{Mat4, Vec3, Vec3A};
use spatial_accel::grid::{GridConfig, GridHandle, UniformGrid};
use spatial_accel::query::DynamicIndex;
use spatial_accel::{Aabb, Frustum};
use std::collections::HashMap;
use std::time::Duration;

/// `n` boxes on the xz plane, `spacing` apart, half extents from `half`.
fn field(n: usize, spacing: f32, half: (f32, f32), rng: &mut Rng) -> Vec<(u32, Aabb)> {
    let side = (n as f32).sqrt().ceil() as usize;
    (0..n)
        .map(|i| {
            let c = Vec3A::new((i % side) as f32, 0.0, (i / side) as f32) * spacing;
            let h = Vec3A::splat(rng.range(half.0, half.1));
            (i as u32, Aabb::new(c - h, c + h))
        })
        .collect()
}

/// `n` boxes on a cube lattice `spacing` apart.
fn cube(n: usize, spacing: f32, half: (f32, f32), rng: &mut Rng) -> Vec<(u32, Aabb)> {
    let side = (n as f32).cbrt().ceil() as usize;
    (0..n)
        .map(|i| {
            let c = Vec3A::new(
                (i % side) as f32,
                (i / side % side) as f32,
                (i / side / side) as f32,
            ) * spacing;
            let h = rng.vec3a(half.0, half.1);
            (i as u32, Aabb::new(c - h, c + h))
        })
        .collect()
}

/// A camera looking down at the field from `height` (about `share` of it in view) or across
/// it from the ground, as the plugin's frame bench places them.
fn camera(rng: &mut Rng, field_size: f32, from_above: bool) -> Frustum {
    let target = Vec3::new(rng.range(0.0, field_size), 0.0, rng.range(0.0, field_size));
    let (eye, up) = if from_above {
        (target + Vec3::new(0.5, rng.range(5.0, 60.0), 0.5), Vec3::Z)
    } else {
        (
            Vec3::new(rng.range(-10.0, 0.0), 2.0, rng.range(-10.0, 0.0)),
            Vec3::Y,
        )
    };
    let view = Mat4::look_at_rh(eye, target, up);
    let projection = Mat4::perspective_infinite_reverse_rh(rng.range(0.3, 1.2), 1.6, 0.1);
    Frustum::from_clip_from_world(&(projection * view))
}

fn views_match(name: &str, grid: &UniformGrid, boxes: &HashMap<u32, Aabb>, views: &[Frustum]) {
    for f in views {
        check_frustum(name, grid, boxes, f);
    }
    check_views(name, grid, boxes, views);
}

#[test]
fn views_of_filled_cells_equal_brute_force_fresh_and_through_motion() {
    let mut rng = Rng::new(0x6a1d);
    let scenes = [
        ("field", field(4_096, 4.0, (0.5, 0.5), &mut rng), 256.0),
        (
            "mixed field",
            field(4_096, 2.0, (0.1, 3.0), &mut rng),
            128.0,
        ),
        ("cube", cube(4_096, 3.0, (0.2, 1.0), &mut rng), 48.0),
        (
            "spanning cube",
            cube(2_197, 1.0, (0.2, 2.5), &mut rng),
            13.0,
        ),
    ];
    for (scene, entries, size) in scenes {
        for (config_name, config) in [
            ("auto", GridConfig::default()),
            ("cell 1", GridConfig::fixed(1.0)),
            ("cell 8", GridConfig::fixed(8.0)),
        ] {
            let name = format!("{scene}, {config_name}");
            let mut grid = UniformGrid::with_config(config);
            let handles: Vec<GridHandle> = entries
                .iter()
                .map(|&(id, b)| grid.insert(id, b).expect("valid box"))
                .collect();
            grid.maintain(Duration::ZERO);
            check_queries(&name, &grid, &entries, 7);
            let mut boxes: HashMap<u32, Aabb> = entries.iter().copied().collect();
            for frame in 0..40 {
                // A tenth moves by up to two units, and now and then one jumps across the
                // scene (staying on the plane of a field, so the cells stay filled).
                let flat = scene.contains("field");
                for (i, &(id, _)) in entries.iter().enumerate() {
                    if rng.below(10) != 0 {
                        continue;
                    }
                    let b = boxes[&id];
                    let mut step = if rng.below(50) == 0 {
                        rng.vec3a(0.0, size) - b.center()
                    } else {
                        rng.vec3a(-2.0, 2.0)
                    };
                    if flat {
                        step.y = step.y.clamp(-0.5, 0.5);
                    }
                    let moved = Aabb::new(b.min + step, b.max + step);
                    grid.update(handles[i], moved).expect("valid box");
                    boxes.insert(id, moved);
                }
                grid.maintain(Duration::from_micros(200));
                let views: Vec<Frustum> = (0..3)
                    .map(|v| match v {
                        0 => camera(&mut rng, size, true),
                        1 => camera(&mut rng, size, false),
                        _ => random_frustum(&mut rng, size),
                    })
                    .collect();
                views_match(&format!("{name}, frame {frame}"), &grid, &boxes, &views);
            }
            grid.validate().unwrap();
        }
    }
}
