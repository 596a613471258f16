//! The dynamic BVH's refits: crowds that jump at once, frames where most leaves move (the
//! whole-tree refit and its compiled schedule), each checked against brute force.

mod scenes;

use accel_testkit::Rng;
use core::ops::ControlFlow;
use glam::Vec3A;
use scenes::{check_ids, check_queries, random_box};
use spatial_accel::dynamic::{DynamicBvh, DynamicBvhConfig, LeafHandle};
use spatial_accel::{Aabb, SpatialQuery};
use std::collections::HashMap;

#[test]
fn a_crowd_jumping_at_once_is_refit_not_reinserted_and_stays_exact() {
    let mut t = DynamicBvh::new();
    let boxes: Vec<Aabb> = (0..2000)
        .map(|i| {
            let p = Vec3A::new((i % 50) as f32 * 3.0, (i / 50) as f32 * 3.0, 0.0);
            Aabb::new(p, p + 1.0)
        })
        .collect();
    let hs: Vec<LeafHandle> = boxes
        .iter()
        .enumerate()
        .map(|(i, b)| t.insert(i as u32, *b).unwrap())
        .collect();
    t.refit();
    // Every leaf jumps clear of its fat box: far more than 1/64 of the tree.
    let moved: Vec<Aabb> = boxes
        .iter()
        .map(|b| Aabb::new(b.min + 40.0, b.max + 40.0))
        .collect();
    for (h, b) in hs.iter().zip(&moved) {
        assert_eq!(t.update(*h, *b), Ok(true));
    }
    assert!(t.refit() > 0, "a mass jump is refit");
    t.validate().unwrap();
    for (i, (h, b)) in hs.iter().zip(&moved).enumerate() {
        assert!(t.fat_bounds(*h).unwrap().contains_aabb(b));
        let mut found = Vec::new();
        t.for_each_overlapping_aabb(b, |id| {
            found.push(id);
            ControlFlow::Continue(())
        });
        assert!(found.contains(&(i as u32)));
    }
}

#[test]
fn mass_motion_frames_take_the_whole_tree_refit_and_stay_exact() {
    // Over a quarter of the leaves move each frame (the whole-tree refit), mixed with
    // removals, insertions and a few teleports, across frames.
    let mut rng = Rng::new(11);
    let extent = 80.0;
    let mut t = DynamicBvh::new();
    let mut model: HashMap<u32, Aabb> = HashMap::new();
    let mut handles: HashMap<u32, LeafHandle> = HashMap::new();
    let mut next = 0u32;
    for _ in 0..3000 {
        let b = random_box(&mut rng, extent);
        handles.insert(next, t.insert(next, b).unwrap());
        model.insert(next, b);
        next += 1;
    }
    t.maintain();
    for frame in 0..20 {
        let ids: Vec<u32> = model.keys().copied().collect();
        for &id in &ids {
            if rng.below(10) < 4 {
                let old = model[&id];
                let b = if rng.below(50) == 0 {
                    random_box(&mut rng, extent)
                } else {
                    let d = rng.vec3a(-2.0, 2.0);
                    Aabb::new(old.min + d, old.max + d)
                };
                t.update(handles[&id], b).unwrap();
                model.insert(id, b);
            }
        }
        for _ in 0..50 {
            let id = ids[rng.below(ids.len())];
            if let Some(h) = handles.remove(&id) {
                assert_eq!(t.remove(h), Ok(id));
                model.remove(&id);
            }
            let b = random_box(&mut rng, extent);
            handles.insert(next, t.insert(next, b).unwrap());
            model.insert(next, b);
            next += 1;
        }
        let report = t.maintain();
        assert!(report.refit_nodes > 0, "frame {frame}: nothing refit");
        t.validate()
            .unwrap_or_else(|e| panic!("frame {frame}: {e}"));
        check_ids(&t, &model, &handles);
        check_queries(&t, &model, &mut rng, extent, 8);
    }
}

#[test]
fn whole_tree_refit_replays_its_schedule_until_links_change() {
    // Frames of pure mass motion replay the compiled shape; between them every kind of link
    // edit must invalidate it. The validator compares a schedule marked current with the
    // tree. Without rotations the insertion and the removal are the only edits of their
    // rounds; with them, a partial refit of small moves rewires links by rotation alone.
    for rotations in [false, true] {
        schedule_scenario(DynamicBvhConfig {
            rotations,
            ..DynamicBvhConfig::default()
        });
    }
}

/// Moves about `share` percent of the leaves by up to `step` units per axis.
fn move_share(
    t: &mut DynamicBvh,
    model: &mut HashMap<u32, Aabb>,
    handles: &HashMap<u32, LeafHandle>,
    rng: &mut Rng,
    (share, step): (usize, f32),
) {
    for (id, b) in model.iter_mut() {
        if rng.below(100) < share {
            let d = rng.vec3a(-step, step);
            *b = Aabb::new(b.min + d, b.max + d);
            t.update(handles[id], *b).unwrap();
        }
    }
}

fn schedule_scenario(config: DynamicBvhConfig) {
    let mut rng = Rng::new(23);
    let extent = 60.0;
    let mut t = DynamicBvh::with_config(config);
    let mut model: HashMap<u32, Aabb> = HashMap::new();
    let mut handles: HashMap<u32, LeafHandle> = HashMap::new();
    for id in 0..2000u32 {
        let b = random_box(&mut rng, extent);
        handles.insert(id, t.insert(id, b).unwrap());
        model.insert(id, b);
    }
    t.maintain();
    let rotations = config.rotations;
    for round in 0..6 {
        for frame in 0..3 {
            move_share(&mut t, &mut model, &handles, &mut rng, (60, 3.0));
            assert!(t.refit() > 0);
            t.validate().unwrap_or_else(|e| {
                panic!("rotations {rotations}, round {round}, mass frame {frame}: {e}")
            });
            check_queries(&t, &model, &mut rng, extent, 4);
        }
        match round {
            0 => {
                let b = random_box(&mut rng, extent);
                handles.insert(9999, t.insert(9999, b).unwrap());
                model.insert(9999, b);
            }
            1 => {
                let id = *model.keys().next().unwrap();
                assert_eq!(t.remove(handles.remove(&id).unwrap()), Ok(id));
                model.remove(&id);
            }
            // A few small moves, none clear of its fat box: the partial refit, whose
            // rotations (when on) are its only link edits.
            2 => {
                move_share(&mut t, &mut model, &handles, &mut rng, (2, 0.3));
                t.refit();
            }
            3 => {
                t.optimize(std::time::Duration::from_secs(1), 64);
            }
            _ => t.rebuild(),
        }
        t.validate().unwrap_or_else(|e| {
            panic!("rotations {rotations}, round {round}, after the edit: {e}")
        });
        assert_eq!(t.height(), t.stats(&t.config().sah).max_depth);
    }
    check_ids(&t, &model, &handles);
}
