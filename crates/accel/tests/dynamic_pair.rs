//! The static/dynamic pair queried as one tree: every query against brute force over both
//! trees, through the dynamic tree and through its 8-wide ray copy, and the copy's background
//! build installed only while the tree it copied still holds.

mod scenes;

use accel::dynamic::{DynamicBvh, StaticDynamicPair};
use accel::{Aabb, BuildConfig, Bvh};
use scenes::{Rng, check_queries, random_box};
use std::collections::HashMap;

#[test]
fn pair_answers_queries_over_both_trees_as_brute_force() {
    let mut rng = Rng::new(12);
    // Disjoint id spaces, as the pair's docs ask: static ids are input indices 0..3,000,
    // dynamic ids start at 10,000.
    let statics: Vec<Aabb> = (0..3_000).map(|_| random_box(&mut rng, 80.0)).collect();
    let mut model: HashMap<u32, Aabb> = statics
        .iter()
        .enumerate()
        .map(|(i, b)| (i as u32, *b))
        .collect();
    let mut pair = StaticDynamicPair::new(
        Bvh::build(&statics, &BuildConfig::default()),
        DynamicBvh::new(),
    );
    let mut hs = Vec::new();
    for i in 0..2_000u32 {
        let b = random_box(&mut rng, 80.0);
        hs.push(pair.dynamic_mut().insert(10_000 + i, b).unwrap());
        model.insert(10_000 + i, b);
    }
    let static_before = pair.static_tree().nodes().to_vec();
    for round in 0..30 {
        for _ in 0..300 {
            let k = rng.below(hs.len() as u32) as usize;
            let b = random_box(&mut rng, 80.0);
            pair.dynamic_mut().update(hs[k], b).unwrap();
            model.insert(10_000 + k as u32, b);
        }
        pair.dynamic_mut().maintain();
        pair.dynamic().validate().unwrap();
        // Every other round rays walk the dynamic tree's 8-wide snapshot, taken after this
        // round's edits (the edits of the round before dropped the last one).
        assert!(!pair.has_dynamic_ray_snapshot());
        if round % 2 == 1 {
            assert!(pair.snapshot_dynamic_for_rays());
        }
        check_queries(&pair, &model, &mut rng, 80.0, 10);
    }
    // The static half is never touched.
    assert_eq!(pair.static_tree().nodes(), &static_before[..]);
    // Either half alone still answers.
    let (s, d) = pair.into_parts();
    let only_static = StaticDynamicPair::new(s, DynamicBvh::new());
    let static_model: HashMap<u32, Aabb> = model
        .iter()
        .filter(|(i, _)| **i < 10_000)
        .map(|(&i, &b)| (i, b))
        .collect();
    check_queries(&only_static, &static_model, &mut rng, 80.0, 10);
    let mut only_dynamic = StaticDynamicPair::new(Bvh::default(), d);
    assert!(only_dynamic.snapshot_dynamic_for_rays());
    let dyn_model: HashMap<u32, Aabb> = model
        .iter()
        .filter(|(i, _)| **i >= 10_000)
        .map(|(&i, &b)| (i, b))
        .collect();
    check_queries(&only_dynamic, &dyn_model, &mut rng, 80.0, 10);
}

/// Polls until a background snapshot of the dynamic tree is no longer being made; returns
/// whether one is held.
fn wait_for_ray_snapshot(pair: &mut StaticDynamicPair) -> bool {
    while pair.dynamic_ray_snapshot_pending() {
        if pair.poll_dynamic_ray_snapshot() {
            return true;
        }
        std::thread::yield_now();
    }
    pair.has_dynamic_ray_snapshot()
}

#[test]
fn background_ray_snapshot_is_installed_only_if_the_tree_did_not_change() {
    let mut rng = Rng::new(31);
    let mut pair = StaticDynamicPair::new(Bvh::default(), DynamicBvh::new());
    let mut model: HashMap<u32, Aabb> = HashMap::new();
    let mut hs = Vec::new();
    for i in 0..5_000u32 {
        let b = random_box(&mut rng, 80.0);
        hs.push(pair.dynamic_mut().insert(i, b).unwrap());
        model.insert(i, b);
    }
    pair.dynamic_mut().maintain();
    for round in 0..6 {
        assert!(pair.start_dynamic_ray_snapshot());
        let changed = round % 2 == 1;
        if changed {
            // A change while the copy is made: it must be dropped, not installed.
            for _ in 0..200 {
                let k = rng.below(hs.len() as u32) as usize;
                let b = random_box(&mut rng, 80.0);
                pair.dynamic_mut().update(hs[k], b).unwrap();
                model.insert(k as u32, b);
            }
            pair.dynamic_mut().maintain();
        }
        assert_eq!(wait_for_ray_snapshot(&mut pair), !changed, "round {round}");
        check_queries(&pair, &model, &mut rng, 80.0, 20);
    }
}
