//! Long runs of churn on the loose octree and the quadtree: every frame moves, inserts and
//! removes entries, then maintains, validates and checks one query against brute force; and
//! the arena stays within a bound over runs that go back to empty.

use accel_testkit::Rng;
use core::ops::ControlFlow;
use glam::Vec3A;
use spatial_accel::octree::{LooseTree, OctreeConfig, OctreeHandle};
use spatial_accel::query::IndexError;
use spatial_accel::{Aabb, LooseOctree, Quadtree, Ray, SpatialQuery, Sphere};
use std::collections::HashMap;

/// One frame's query, by turns a box, a sphere, a ray and the nearest, compared with the
/// exact answer over `model`.
fn check_one_query<S: SpatialQuery>(
    name: &str,
    tree: &S,
    model: &[(OctreeHandle, u32, Aabb)],
    rng: &mut Rng,
    frame: usize,
) {
    let exact = |test: &dyn Fn(&Aabb) -> bool| {
        let mut ids: Vec<u32> = model.iter().filter(|e| test(&e.2)).map(|e| e.1).collect();
        ids.sort_unstable();
        ids
    };
    let boxes: HashMap<u32, Aabb> = model.iter().map(|e| (e.1, e.2)).collect();
    let box_of = |id: u32| boxes[&id];
    let center = rng.vec3a(-70.0, 70.0);
    match frame % 4 {
        0 => {
            let q = Aabb::from_center_half_extents(center, rng.vec3a(0.0, 20.0));
            let mut got = Vec::new();
            tree.for_each_overlapping_aabb(&q, |id| {
                got.push(id);
                ControlFlow::Continue(())
            });
            got.retain(|&id| box_of(id).intersects_aabb(&q));
            got.sort_unstable();
            assert_eq!(
                got,
                exact(&|b| b.intersects_aabb(&q)),
                "{name}: frame {frame} box"
            );
        }
        1 => {
            let s = Sphere::new(center, rng.range(0.0, 20.0));
            let mut got = Vec::new();
            tree.for_each_overlapping_sphere(&s, |id| {
                got.push(id);
                ControlFlow::Continue(())
            });
            got.retain(|&id| s.intersects_aabb(&box_of(id)));
            got.sort_unstable();
            assert_eq!(
                got,
                exact(&|b| s.intersects_aabb(b)),
                "{name}: frame {frame} sphere"
            );
        }
        2 => {
            let ray = Ray::new(center, rng.unit_vector());
            let got = tree.cast_ray(&ray, |id, r| r.intersect_aabb(&box_of(id)));
            let want = model
                .iter()
                .filter_map(|e| ray.intersect_aabb(&e.2))
                .min_by(f32::total_cmp);
            assert_eq!(got.map(|h| h.t), want, "{name}: frame {frame} ray");
        }
        _ => {
            let d2 = |id: u32| box_of(id).distance_squared_to_point(center);
            let got: Vec<f32> = tree.nearest_k(center, 5, d2).iter().map(|p| p.1).collect();
            let mut want: Vec<f32> = model
                .iter()
                .map(|e| e.2.distance_squared_to_point(center))
                .collect();
            want.sort_unstable_by(f32::total_cmp);
            want.truncate(5);
            assert_eq!(got, want, "{name}: frame {frame} nearest");
        }
    }
}

/// `frames` frames of churn over about `target` entries in a world of half size 64: each
/// frame moves a tenth of them (mostly small steps, some jumps, some resizes, now and then one
/// far outside the world), inserts and removes a few, then maintains, validates and checks
/// one query against brute force. Returns the most octants seen in use.
///
/// Checks on the way that most small steps are box writes and that the root grows for the
/// far jumps, so the run exercises both paths.
fn churn<const AXES: usize>(
    name: &str,
    tree: &mut LooseTree<AXES>,
    model: &mut Vec<(OctreeHandle, u32, Aabb)>,
    frames: usize,
    target: usize,
    seed: u64,
) -> usize {
    let mut rng = Rng::new(seed);
    let mut next_id = model.iter().map(|e| e.1 + 1).max().unwrap_or(0);
    let mut peak = tree.octant_count();
    let (mut steps, mut step_writes, mut grown_frames) = (0usize, 0usize, 0usize);
    let random_box = |rng: &mut Rng| {
        Aabb::from_center_half_extents(rng.vec3a(-60.0, 60.0), rng.vec3a(0.05, 3.0))
    };
    for frame in 0..frames {
        while model.len() < target / 2 || (model.len() < target && rng.chance(0.4)) {
            let b = random_box(&mut rng);
            let h = tree.insert(next_id, b).unwrap();
            model.push((h, next_id, b));
            next_id += 1;
        }
        for _ in 0..rng.below(3) {
            if !model.is_empty() {
                let (h, id, _) = model.swap_remove(rng.below(model.len()));
                assert_eq!(tree.remove(h), Ok(id), "{name}: frame {frame} remove");
                assert_eq!(tree.remove(h), Err(IndexError::StaleHandle));
            }
        }
        for _ in 0..model.len() / 10 {
            let i = rng.below(model.len());
            let (h, _, old) = model[i];
            let kind = rng.below(100);
            let b = match kind {
                0..=79 => {
                    let step = rng.vec3a(-0.4, 0.4);
                    Aabb::new(old.min + step, old.max + step)
                }
                80..=89 => random_box(&mut rng),
                90..=97 => {
                    let grow = rng.bool() && old.half_extents().max_element() < 8.0;
                    let scale = if grow { 2.0 } else { 0.5 };
                    Aabb::from_center_half_extents(old.center(), old.half_extents() * scale)
                }
                // Far jumps in the first frames of every 500, so the root grows there...
                _ if frame % 500 < 5 => {
                    Aabb::from_center_half_extents(rng.vec3a(-1e5, 1e5), Vec3A::ONE)
                }
                _ => random_box(&mut rng),
            };
            let cell = tree.loose_cell_of(h);
            let changed = tree.update(h, b).unwrap();
            if !changed {
                assert_eq!(tree.loose_cell_of(h), cell, "{name}: Ok(false) but moved");
            }
            if kind < 80 {
                steps += 1;
                step_writes += usize::from(!changed);
            }
            model[i].2 = b;
        }
        if frame % 500 == 100 {
            // ...and the far entries come back mid-way, so it collapses again.
            for (h, _, b) in model.iter_mut() {
                if b.center().abs().max_element() > 100.0 {
                    *b = random_box(&mut rng);
                    assert_eq!(
                        tree.update(*h, *b),
                        Ok(true),
                        "{name}: a far entry came back"
                    );
                }
            }
            tree.maintain();
        }
        let root = tree.root_cell().expect("entries are left");
        grown_frames += usize::from(root.half_extents().x > tree.config().world_half_size);
        tree.maintain();
        if let Err(e) = tree.validate() {
            panic!("{name}: frame {frame}: {e}");
        }
        assert_eq!(tree.len(), model.len(), "{name}: frame {frame} count");
        peak = peak.max(tree.octant_count());
        check_one_query(name, &*tree, model, &mut rng, frame);
    }
    for &(h, id, b) in model.iter() {
        assert_eq!(
            (tree.id(h), tree.bounds_of(h)),
            (Some(id), Some(b)),
            "{name}"
        );
    }
    assert!(
        step_writes * 2 > steps,
        "{name}: only {step_writes} of {steps} small steps were box writes"
    );
    assert!(
        grown_frames > 0 && grown_frames < frames / 2,
        "{name}: the root was grown in {grown_frames} of {frames} frames"
    );
    peak
}

#[test]
fn ten_thousand_frames_of_octree_churn() {
    let config = OctreeConfig {
        world_half_size: 64.0,
        max_depth: 8,
        ..OctreeConfig::default()
    };
    let mut tree = LooseOctree::with_config(config).unwrap();
    let mut model = Vec::new();
    churn("octree churn", &mut tree, &mut model, 10_000, 300, 21);
}

#[test]
fn quadtree_and_tighter_octree_churn() {
    for k in [1.0, 1.25] {
        let config = OctreeConfig {
            world_half_size: 64.0,
            max_depth: 8,
            ..OctreeConfig::default().with_looseness(k)
        };
        let mut model = Vec::new();
        let mut tree = LooseOctree::with_config(config).unwrap();
        churn(
            &format!("octree churn k={k}"),
            &mut tree,
            &mut model,
            2000,
            200,
            22,
        );
        let mut model = Vec::new();
        let mut tree = Quadtree::with_config(config).unwrap();
        churn(
            &format!("quadtree churn k={k}"),
            &mut tree,
            &mut model,
            2000,
            200,
            23,
        );
    }
    let mut model = Vec::new();
    let mut tree = Quadtree::new();
    churn("quadtree churn", &mut tree, &mut model, 3000, 300, 24);
    // The depth limit from the population (entries share the deepest octants it allows).
    for occupancy in [1, 4, 16] {
        let config = OctreeConfig {
            world_half_size: 64.0,
            max_depth: 8,
            target_occupancy: occupancy,
            ..OctreeConfig::default()
        };
        let mut model = Vec::new();
        let mut tree = LooseOctree::with_config(config).unwrap();
        let name = format!("octree churn, occupancy {occupancy}");
        churn(&name, &mut tree, &mut model, 2000, 300, 25);
        let mut model = Vec::new();
        let mut tree = Quadtree::with_config(config).unwrap();
        let name = format!("quadtree churn, occupancy {occupancy}");
        churn(&name, &mut tree, &mut model, 2000, 300, 26);
    }
}

#[test]
fn churn_back_to_empty_does_not_grow_the_arena() {
    let config = OctreeConfig {
        world_half_size: 64.0,
        max_depth: 8,
        ..OctreeConfig::default()
    };
    let mut tree = LooseOctree::with_config(config).unwrap();
    let mut model = Vec::new();
    let mut peak = 0;
    for round in 0..3 {
        peak = peak.max(churn(
            "arena churn",
            &mut tree,
            &mut model,
            1500,
            300,
            30 + round,
        ));
        for (h, id, _) in model.drain(..) {
            assert_eq!(tree.remove(h), Ok(id));
        }
        tree.maintain();
        tree.validate().unwrap();
        assert_eq!((tree.len(), tree.octant_count()), (0, 0), "round {round}");
        assert_eq!(tree.root_cell(), None);
        // An update makes its target chain before it frees the old one, and a far jump grows
        // the root first: at most a chain to the deepest level and the growth above the
        // world beyond the most octants ever seen in use between frames.
        let growth = (1e5f32 / 64.0).log2().ceil() as usize + 1;
        let bound = peak + usize::from(config.max_depth) + 1 + growth;
        assert!(
            tree.allocated_octants() <= bound,
            "round {round}: {} octants allocated, bound {bound}",
            tree.allocated_octants()
        );
    }
}
