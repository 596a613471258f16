//! The multi-view walk (`SpatialQuery::for_each_in_views`) against brute force: several
//! frusta at once over the static tree, its wide and sphere forms, the dynamic tree and the
//! pair of both.

mod scenes;

use accel_testkit::Rng;
use scenes::{random_box, random_frustum};
use spatial_accel::bvh::SphereBvh;
use spatial_accel::bvh::wide::{Bvh4, Bvh8, QBvh8};
use spatial_accel::dynamic::{DynamicBvh, StaticDynamicPair};
use spatial_accel::query::views::{ViewClassification, ViewMasks, for_each_in_views};
use spatial_accel::{Aabb, BuildConfig, Bvh, Containment, Frustum, SpatialQuery};
use std::collections::HashMap;

/// Classifies a box against each undecided view, as a caller of the walk does.
fn classify(views: &[Frustum], b: &Aabb, undecided: u32) -> ViewClassification {
    let mut c = ViewClassification::default();
    for (i, f) in views.iter().enumerate() {
        if undecided >> i & 1 == 0 {
            continue;
        }
        match f.classify_aabb(b) {
            Containment::Inside => c.inside |= 1 << i,
            Containment::Outside => c.outside |= 1 << i,
            Containment::Intersecting => {}
        }
    }
    c
}

/// Walks `views` over `tree` and checks every primitive of `model` against brute force: each
/// visited once at most; a view holding it wholly holds its exact box; every view its exact
/// box is not outside of reaches it.
fn check_walk<T: SpatialQuery>(tree: &T, model: &HashMap<u32, Aabb>, views: &[Frustum]) {
    let all = (1u32 << views.len()) - 1;
    let mut got: HashMap<u32, ViewMasks> = HashMap::new();
    tree.for_each_in_views(
        all,
        |b, undecided| classify(views, b, undecided),
        |id, masks| {
            assert!(got.insert(id, masks).is_none(), "id {id} visited twice");
            assert_eq!(masks.inside & masks.crossing, 0, "id {id}: {masks:?}");
            assert_ne!(
                masks.inside | masks.crossing,
                0,
                "id {id} reached by no view"
            );
        },
    );
    for (&id, b) in model {
        let masks = got.get(&id).copied().unwrap_or_default();
        for (v, f) in views.iter().enumerate() {
            let exact = f.classify_aabb(b);
            let bit = 1u32 << v;
            if masks.inside & bit != 0 {
                assert_eq!(
                    exact,
                    Containment::Inside,
                    "id {id}, view {v}: taken as inside"
                );
            }
            if exact != Containment::Outside {
                assert_ne!(
                    (masks.inside | masks.crossing) & bit,
                    0,
                    "id {id}, view {v}: not reached but {exact:?}"
                );
            }
        }
    }
}

#[test]
fn every_view_reaches_what_brute_force_finds_on_every_tree() {
    let mut rng = Rng::new(31);
    let extent = 60.0;
    let statics: Vec<Aabb> = (0..2_000).map(|_| random_box(&mut rng, extent)).collect();
    let static_model: HashMap<u32, Aabb> = statics
        .iter()
        .enumerate()
        .map(|(i, b)| (i as u32, *b))
        .collect();
    let bvh = Bvh::build(&statics, &BuildConfig::default());
    let (bvh8, qbvh8, bvh4) = (
        Bvh8::from_bvh(&bvh),
        QBvh8::from_bvh(&bvh),
        Bvh4::from_bvh(&bvh),
    );
    let spheres = SphereBvh::from_bvh(&bvh, &statics);
    let mut dynamic = DynamicBvh::new();
    let mut dynamic_model = HashMap::new();
    for i in 0..1_500u32 {
        let b = random_box(&mut rng, extent);
        dynamic.insert(10_000 + i, b).unwrap();
        dynamic_model.insert(10_000 + i, b);
    }
    let pair = StaticDynamicPair::new(bvh.clone(), dynamic.clone());
    let mut pair_model = static_model.clone();
    pair_model.extend(dynamic_model.iter().map(|(&i, &b)| (i, b)));
    for round in 0..40 {
        // One view up to eight, sometimes the same frustum twice (views deciding alike).
        let count = 1 + round % 8;
        let mut views: Vec<Frustum> = (0..count)
            .map(|_| random_frustum(&mut rng, extent))
            .collect();
        if count > 2 && round % 3 == 0 {
            views[1] = views[0];
        }
        check_walk(&bvh, &static_model, &views);
        check_walk(&bvh8, &static_model, &views);
        check_walk(&qbvh8, &static_model, &views);
        check_walk(&bvh4, &static_model, &views);
        check_walk(&spheres, &static_model, &views);
        check_walk(&dynamic, &dynamic_model, &views);
        check_walk(&pair, &pair_model, &views);
    }
}

#[test]
fn no_views_and_empty_trees_visit_nothing() {
    let mut rng = Rng::new(5);
    let boxes: Vec<Aabb> = (0..100).map(|_| random_box(&mut rng, 10.0)).collect();
    let bvh = Bvh::build(&boxes, &BuildConfig::default());
    let mut visits = 0;
    for_each_in_views(
        &bvh,
        0,
        |_, _| ViewClassification::default(),
        |_, _| visits += 1,
    );
    for_each_in_views(
        &DynamicBvh::new(),
        1,
        |_, _| ViewClassification::default(),
        |_, _| visits += 1,
    );
    assert_eq!(visits, 0);
    // A view deciding nothing anywhere reaches every primitive, each crossing it.
    let mut crossing = 0;
    for_each_in_views(
        &bvh,
        1,
        |_, _| ViewClassification::default(),
        |_, m| {
            crossing += usize::from(
                m == ViewMasks {
                    inside: 0,
                    crossing: 1,
                },
            )
        },
    );
    assert_eq!(crossing, boxes.len());
}
