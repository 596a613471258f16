//! The static/dynamic pair queried as one tree: every query against brute force over both
//! trees, through the dynamic tree and through its 8-wide ray snapshot, the snapshot's
//! background build installed only while the tree's leaves are the ones it was built from,
//! and the snapshot kept through motion by refits.

mod scenes;

use accel_testkit::Rng;
use scenes::{check_queries, random_box};
use spatial_accel::dynamic::{DynamicBvh, StaticDynamicPair};
use spatial_accel::{Aabb, BuildConfig, Bvh};
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
            let k = rng.below(hs.len());
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
            assert!(pair.snapshot_dynamic_for_rays(&BuildConfig::default()));
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
    assert!(only_dynamic.snapshot_dynamic_for_rays(&BuildConfig::default()));
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
        assert!(pair.start_dynamic_ray_snapshot(&BuildConfig::default()));
        let changed = round % 2 == 1;
        if changed {
            // A change while the copy is made: it must be dropped, not installed.
            for _ in 0..200 {
                let k = rng.below(hs.len());
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

/// Announcing candidates ahead changes nothing the walk visits: the same primitives in the
/// same order, through the static tree's wide form, the dynamic tree's binary walk and its
/// wide snapshot; announcements name only primitives the trees hold, and the wide walks do
/// make them (a hook that never fired would pass the first check vacuously).
#[test]
fn announcing_walk_visits_what_the_plain_walk_visits() {
    use core::ops::ControlFlow;
    use spatial_accel::query::RayWalk;
    use spatial_accel::query::ray_walk::closest_hit_announcing;
    let mut rng = Rng::new(31);
    let statics: Vec<Aabb> = (0..2_000).map(|_| random_box(&mut rng, 60.0)).collect();
    let mut pair = StaticDynamicPair::new(
        Bvh::build(&statics, &BuildConfig::default()),
        DynamicBvh::new(),
    );
    let dynamics: Vec<Aabb> = (0..1_500).map(|_| random_box(&mut rng, 60.0)).collect();
    for (i, b) in dynamics.iter().enumerate() {
        pair.dynamic_mut().insert(10_000 + i as u32, *b).unwrap();
    }
    pair.dynamic_mut().maintain();
    // A visitor that shrinks the range at some hits, so pruning takes part.
    fn visitor(
        seen: &mut Vec<u32>,
    ) -> impl FnMut(u32, &mut spatial_accel::Ray) -> ControlFlow<()> + '_ {
        move |p, r| {
            seen.push(p);
            if p % 3 == 0 {
                r.t_max = r.t_max.min(r.t_min + (r.t_max - r.t_min) * 0.9);
            }
            ControlFlow::Continue(())
        }
    }
    let held = |p: u32| (p as usize) < statics.len() || (10_000..11_500).contains(&p);
    let mut announced_total = 0;
    for snapshot in [false, true] {
        if snapshot {
            assert!(pair.snapshot_dynamic_for_rays(&BuildConfig::default()));
        }
        for _ in 0..300 {
            let origin = rng.vec3a(-70.0, 70.0);
            let ray = spatial_accel::Ray::new(origin, rng.vec3a(-30.0, 30.0) - origin);
            let (mut plain, mut told, mut announced) = (Vec::new(), Vec::new(), Vec::new());
            pair.walk_ray(&mut ray.clone(), visitor(&mut plain));
            pair.walk_ray_announcing(&mut ray.clone(), |p| announced.push(p), visitor(&mut told));
            assert_eq!(plain, told);
            assert!(announced.iter().all(|&p| held(p)));
            announced_total += announced.len();
            let hit = |p: u32, r: &spatial_accel::Ray| {
                let b = match p.checked_sub(10_000) {
                    None => statics[p as usize],
                    Some(d) => dynamics[d as usize],
                };
                r.intersect_aabb(&b)
            };
            // `closest_hit` is `closest_hit_announcing` with a hook that does nothing; this
            // one listens, so the announcing path is what gets compared.
            let mut heard = 0usize;
            assert_eq!(
                closest_hit_announcing(&pair, &ray, |_| heard += 1, hit),
                spatial_accel::query::ray_walk::closest_hit(&pair, &ray, hit)
            );
            announced_total += heard;
        }
    }
    assert!(announced_total > 0, "no walk announced a candidate");
}

/// Motion through `update_dynamic` keeps the ray snapshot, refit by `maintain_dynamic`:
/// queries equal brute force after every round (small moves and jumps, a snapshot rebuilt
/// now or in the background from time to time, and a background one that moves overtook);
/// rays never walk a snapshot with updates not yet refit; insertions and removals drop it.
#[test]
fn ray_snapshot_survives_motion_and_matches_brute_force() {
    let mut rng = Rng::new(77);
    let config = BuildConfig::default();
    let statics: Vec<Aabb> = (0..1_000).map(|_| random_box(&mut rng, 80.0)).collect();
    let mut model: HashMap<u32, Aabb> = statics
        .iter()
        .enumerate()
        .map(|(i, b)| (i as u32, *b))
        .collect();
    let mut pair = StaticDynamicPair::new(Bvh::build(&statics, &config), DynamicBvh::new());
    let mut hs = Vec::new();
    for i in 0..3_000u32 {
        let b = random_box(&mut rng, 80.0);
        hs.push(pair.dynamic_mut().insert(10_000 + i, b).unwrap());
        model.insert(10_000 + i, b);
    }
    pair.maintain_dynamic();
    assert!(pair.snapshot_dynamic_for_rays(&config));
    for round in 0..24 {
        // Few movers in most rounds (path refits), most of them in some (a whole sweep).
        let movers = if round % 6 == 5 { 2_500 } else { 40 };
        for _ in 0..movers {
            let k = rng.below(hs.len());
            let id = 10_000 + k as u32;
            let b = if rng.below(4) == 0 {
                random_box(&mut rng, 80.0)
            } else {
                let step = glam::Vec3A::splat(rng.range(-0.5, 0.5));
                Aabb::new(model[&id].min + step, model[&id].max + step)
            };
            pair.update_dynamic(hs[k], b).unwrap();
            model.insert(id, b);
        }
        assert!(
            !pair.has_dynamic_ray_snapshot(),
            "round {round}: a snapshot with updates not refit serves rays"
        );
        if round % 8 == 3 {
            // Started before this round's maintenance: installed later, refit to the moves
            // made while it was built.
            assert!(pair.refresh_dynamic_ray_snapshot(&config, true));
            for _ in 0..50 {
                let k = rng.below(hs.len());
                let b = random_box(&mut rng, 80.0);
                pair.update_dynamic(hs[k], b).unwrap();
                model.insert(10_000 + k as u32, b);
            }
            pair.maintain_dynamic();
            assert!(wait_for_ray_snapshot(&mut pair), "round {round}");
        } else {
            pair.maintain_dynamic();
        }
        if round % 8 == 7 {
            assert!(pair.refresh_dynamic_ray_snapshot(&config, false));
            assert_eq!(pair.dynamic_ray_snapshot_moving_refits(), Some(0));
        }
        assert!(pair.has_dynamic_ray_snapshot(), "round {round}");
        pair.dynamic().validate().unwrap();
        check_queries(&pair, &model, &mut rng, 80.0, 10);
    }
    // An insertion drops it; so does a removal.
    let b = random_box(&mut rng, 80.0);
    let extra = pair.dynamic_mut().insert(20_000, b).unwrap();
    model.insert(20_000, b);
    pair.maintain_dynamic();
    assert!(!pair.has_dynamic_ray_snapshot());
    check_queries(&pair, &model, &mut rng, 80.0, 10);
    assert!(pair.snapshot_dynamic_for_rays(&config));
    pair.dynamic_mut().remove(extra).unwrap();
    model.remove(&20_000);
    pair.maintain_dynamic();
    assert!(!pair.has_dynamic_ray_snapshot());
    check_queries(&pair, &model, &mut rng, 80.0, 10);
}
