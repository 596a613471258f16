//! Every [`SpatialQuery`] against the brute-force oracle over the same boxes.

use crate::scenes::{random_frustum, rays};
use accel_testkit::Rng;
use core::ops::ControlFlow;
use spatial_accel::query::BruteForceIndex;
use spatial_accel::query::DynamicIndex;
use spatial_accel::query::views::ViewClassification;
use spatial_accel::{Aabb, Containment, Frustum, Ray, SpatialQuery, Sphere};
use std::collections::HashMap;

/// How many queries of each kind one check runs.
const QUERIES: usize = 40;

/// Checks every query of `index` against a brute-force list of `entries` (id, exact box):
/// after the exact test on each candidate, the answers must be the oracle's, and no query
/// may report a primitive twice.
pub fn check_queries<S: SpatialQuery + ?Sized>(
    name: &str,
    index: &S,
    entries: &[(u32, Aabb)],
    seed: u64,
) {
    let mut oracle = BruteForceIndex::new();
    for &(id, b) in entries {
        oracle.insert(id, b).expect("valid box");
    }
    let boxes: HashMap<u32, Aabb> = entries.iter().copied().collect();
    assert_eq!(
        boxes.len(),
        entries.len(),
        "{name}: the check needs distinct ids"
    );
    let extent = entries
        .iter()
        .fold(Aabb::EMPTY, |acc, (_, b)| acc.union(b))
        .extent()
        .max_element()
        .clamp(1.0, 1e6);
    let mut rng = Rng::new(seed);
    for ray in rays(QUERIES, seed, extent) {
        check_ray(name, index, &oracle, &boxes, &ray);
        // A segment: hits beyond its end do not count.
        let short = ray.with_t_max(rng.range(0.0, extent));
        check_ray(name, index, &oracle, &boxes, &short);
    }
    for _ in 0..QUERIES {
        let center = rng.vec3a(-extent, extent);
        let q = Aabb::from_center_half_extents(center, rng.vec3a(0.0, extent * 0.3));
        let want = exact(
            &oracle,
            &boxes,
            |s, v| s.for_each_overlapping_aabb(&q, v),
            |b| b.intersects_aabb(&q),
        );
        let got = exact(
            index,
            &boxes,
            |s, v| s.for_each_overlapping_aabb(&q, v),
            |b| b.intersects_aabb(&q),
        );
        assert_eq!(got, want, "{name}: box overlap {q:?}");

        let sphere = Sphere::new(center, rng.range(0.0, extent * 0.3));
        let test = |b: &Aabb| sphere.intersects_aabb(b);
        let want = exact(
            &oracle,
            &boxes,
            |s, v| s.for_each_overlapping_sphere(&sphere, v),
            test,
        );
        let got = exact(
            index,
            &boxes,
            |s, v| s.for_each_overlapping_sphere(&sphere, v),
            test,
        );
        assert_eq!(got, want, "{name}: sphere overlap {sphere:?}");

        // Points inside boxes as well as anywhere, so containment is found.
        let point = match entries.get(rng.below(entries.len().max(1))) {
            Some((_, b)) if rng.bool() => b.center(),
            _ => center,
        };
        let test = |b: &Aabb| b.contains_point(point);
        let want = exact(
            &oracle,
            &boxes,
            |s, v| s.for_each_containing_point(point, v),
            test,
        );
        let got = exact(
            index,
            &boxes,
            |s, v| s.for_each_containing_point(point, v),
            test,
        );
        assert_eq!(got, want, "{name}: point {point:?}");

        let k = [1, 4, 17][rng.below(3)];
        let d2 = |id: u32| boxes[&id].distance_squared_to_point(center);
        assert_eq!(
            index.nearest_k(center, k, d2),
            oracle.nearest_k(center, k, d2),
            "{name}: {k} nearest to {center:?}"
        );

        let frustum = random_frustum(&mut rng, extent);
        check_frustum(name, index, &boxes, &frustum);
        let views: Vec<Frustum> = (0..3).map(|_| random_frustum(&mut rng, extent)).collect();
        check_views(name, index, &boxes, &views);
    }
}

/// Closest, any and all hits of one ray, with each box's exact slab test as the primitive.
fn check_ray<S: SpatialQuery + ?Sized>(
    name: &str,
    index: &S,
    oracle: &BruteForceIndex,
    boxes: &HashMap<u32, Aabb>,
    ray: &Ray,
) {
    let hit = |id: u32, r: &Ray| r.intersect_aabb(&boxes[&id]);
    let want = oracle.cast_ray(ray, hit);
    let got = index.cast_ray(ray, hit);
    assert_eq!(
        got.map(|h| h.t),
        want.map(|h| h.t),
        "{name}: closest hit of {ray:?}"
    );
    if let Some(got) = got {
        // Ties between primitives at one distance may go either way; the distance may not.
        assert_eq!(
            hit(got.primitive, ray),
            Some(got.t),
            "{name}: hit record of {ray:?}"
        );
    }
    let any = index.cast_ray_any(ray, |id, r| hit(id, r).is_some());
    assert_eq!(any.is_some(), want.is_some(), "{name}: any hit of {ray:?}");
    assert!(
        any.is_none_or(|id| hit(id, ray).is_some()),
        "{name}: any hit is a hit"
    );
    let (mut want_all, mut got_all) = (Vec::new(), Vec::new());
    oracle.cast_ray_all(ray, hit, &mut want_all);
    index.cast_ray_all(ray, hit, &mut got_all);
    assert_eq!(got_all, want_all, "{name}: all hits of {ray:?}");
}

/// The sorted ids a candidate query reports that pass the exact test, after checking that
/// none was reported twice.
fn exact<S: ?Sized>(
    index: &S,
    boxes: &HashMap<u32, Aabb>,
    query: impl FnOnce(&S, &mut dyn FnMut(u32) -> ControlFlow<()>),
    test: impl Fn(&Aabb) -> bool,
) -> Vec<u32> {
    let mut all = Vec::new();
    query(index, &mut |id| {
        all.push(id);
        ControlFlow::Continue(())
    });
    assert_unique(&mut all);
    all.retain(|id| test(&boxes[id]));
    all
}

fn assert_unique(ids: &mut [u32]) {
    ids.sort_unstable();
    if let Some(w) = ids.windows(2).find(|w| w[0] == w[1]) {
        panic!("primitive {} reported twice by one query", w[0]);
    }
}

/// Every box the frustum reaches is reported; one reported as inside is inside.
pub fn check_frustum<S: SpatialQuery + ?Sized>(
    name: &str,
    index: &S,
    boxes: &HashMap<u32, Aabb>,
    frustum: &Frustum,
) {
    let mut got = Vec::new();
    index.for_each_in_frustum(frustum, |id, c| got.push((id, c)));
    let mut ids: Vec<u32> = got.iter().map(|&(id, _)| id).collect();
    assert_unique(&mut ids);
    for (&id, b) in boxes {
        let exact = frustum.classify_aabb(b);
        let reported = got.iter().find(|&&(g, _)| g == id).map(|&(_, c)| c);
        if exact != Containment::Outside {
            assert!(
                reported.is_some(),
                "{name}: frustum missed {id} ({exact:?})"
            );
        }
        if reported == Some(Containment::Inside) {
            assert_eq!(
                exact,
                Containment::Inside,
                "{name}: {id} is not inside the frustum"
            );
        }
    }
}

/// Every view that reaches a box is in its masks; a view said to hold it holds it.
pub fn check_views<S: SpatialQuery + ?Sized>(
    name: &str,
    index: &S,
    boxes: &HashMap<u32, Aabb>,
    views: &[Frustum],
) {
    let all_views = (1u32 << views.len()) - 1;
    let classify = |b: &Aabb, undecided: u32| {
        let mut c = ViewClassification::default();
        for (v, f) in views.iter().enumerate() {
            if undecided & (1 << v) != 0 {
                match f.classify_aabb(b) {
                    Containment::Inside => c.inside |= 1 << v,
                    Containment::Outside => c.outside |= 1 << v,
                    Containment::Intersecting => {}
                }
            }
        }
        c
    };
    let mut got = HashMap::new();
    index.for_each_in_views(all_views, classify, |id, masks| {
        assert!(
            got.insert(id, masks).is_none(),
            "{name}: {id} visited twice by the views"
        );
    });
    for (&id, b) in boxes {
        let exact = classify(b, all_views);
        let reached = all_views & !exact.outside;
        let masks = got.get(&id).copied().unwrap_or_default();
        assert_eq!(
            reached & !(masks.inside | masks.crossing),
            0,
            "{name}: views {reached:b} reach {id}, masks {masks:?}"
        );
        assert_eq!(
            masks.inside & !exact.inside,
            0,
            "{name}: views {:b} said to hold {id}, exact {exact:?}",
            masks.inside
        );
    }
}
