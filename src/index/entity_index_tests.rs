//! Every query of the index with its three layers (static tree, dynamic index, busy movers)
//! against the flat oracle over the same boxes.

use super::*;
use accel_testkit::{BoxScene, Rng, box_scene};
use spatial_accel::query::BruteForceIndex;
use spatial_accel::{BuildConfig, Ray};

/// The boxes split in thirds: static, dynamic, busy; ids are the boxes' indices.
fn three_layers(choice: IndexChoice, boxes: &[Aabb]) -> EntityIndex {
    let third = boxes.len() / 3;
    let static_tree = Bvh::build(&boxes[..third], &BuildConfig::default());
    let mut index = EntityIndex::new(choice, static_tree);
    for (i, b) in boxes.iter().enumerate().take(2 * third).skip(third) {
        index.insert(i as u32, *b).unwrap();
    }
    for (i, b) in boxes.iter().enumerate().skip(2 * third) {
        // Keys spread and out of order, as entity indices are.
        let key = (boxes.len() - i) as u32 * 7;
        index
            .busy_movers_mut()
            .insert(key, 1, i as u32, *b, 0)
            .unwrap();
    }
    match &mut index.layers {
        Layers::Bvh(pair) => {
            pair.dynamic_mut().maintain();
        }
        Layers::Layered(layers) => {
            layers.dynamic_mut().maintain(core::time::Duration::ZERO);
        }
    }
    index
}

/// A query's visitor, as the overlap queries take it.
type Visit<'a> = dyn FnMut(u32) -> ControlFlow<()> + 'a;

fn sorted(mut ids: Vec<u32>) -> Vec<u32> {
    ids.sort_unstable();
    ids
}

#[test]
fn every_query_through_three_layers_equals_the_oracle() {
    let boxes = box_scene(BoxScene::Uniform, 600, 0xb05e);
    let oracle = BruteForceIndex::from_boxes(&boxes);
    for choice in [IndexChoice::Bvh, IndexChoice::Grid, IndexChoice::Octree] {
        let index = three_layers(choice, &boxes);
        assert_eq!(index.busy_movers().len(), 200);
        let all = boxes.iter().fold(Aabb::EMPTY, |acc, b| acc.union(b));
        assert!(index.bounds().contains_aabb(&all));
        let mut rng = Rng::new(9);
        // Trees report candidates (a static leaf's every entry): each once, and the exact
        // test decides, as every caller does.
        let collect = |q: &dyn Fn(&mut Visit), exact: &dyn Fn(&Aabb) -> bool| {
            let mut out = Vec::new();
            q(&mut |id| {
                out.push(id);
                ControlFlow::Continue(())
            });
            let all = out.len();
            out = sorted(out);
            out.dedup();
            assert_eq!(out.len(), all, "{choice:?}: a candidate reported twice");
            out.retain(|&id| exact(&boxes[id as usize]));
            out
        };
        for _ in 0..200 {
            let c = rng.vec3a(-110.0, 110.0);
            let half = Vec3A::splat(rng.range(0.5, 20.0));
            let query = Aabb::new(c - half, c + half);
            let exact = |b: &Aabb| b.intersects_aabb(&query);
            assert_eq!(
                collect(&|v| index.for_each_overlapping_aabb(&query, v), &exact),
                collect(&|v| oracle.for_each_overlapping_aabb(&query, v), &exact),
                "{choice:?}: box {query:?}"
            );
            let sphere = Sphere::new(c, half.x);
            let exact = |b: &Aabb| sphere.intersects_aabb(b);
            assert_eq!(
                collect(&|v| index.for_each_overlapping_sphere(&sphere, v), &exact),
                collect(&|v| oracle.for_each_overlapping_sphere(&sphere, v), &exact),
                "{choice:?}: sphere"
            );
            let exact = |b: &Aabb| b.contains_point(c);
            assert_eq!(
                collect(&|v| index.for_each_containing_point(c, v), &exact),
                collect(&|v| oracle.for_each_containing_point(c, v), &exact),
                "{choice:?}: point"
            );
            let distance = |id: u32| boxes[id as usize].distance_squared_to_point(c);
            assert_eq!(
                index.nearest_k(c, 12, distance),
                oracle.nearest_k(c, 12, distance),
                "{choice:?}: nearest"
            );
            let ray = Ray::new(c, rng.vec3a(-1.0, 1.0).normalize_or(Vec3A::X));
            let hit = |id: u32, r: &Ray| r.intersect_aabb(&boxes[id as usize]);
            let (got, want) = (index.cast_ray(&ray, hit), oracle.cast_ray(&ray, hit));
            assert_eq!(got.map(|h| h.t), want.map(|h| h.t), "{choice:?}: ray");
            let (mut got, mut want) = (Vec::new(), Vec::new());
            index.cast_ray_all(&ray, hit, &mut got);
            oracle.cast_ray_all(&ray, hit, &mut want);
            let ids = |hits: &[spatial_accel::query::RayHit]| {
                sorted(hits.iter().map(|h| h.primitive).collect())
            };
            assert_eq!(ids(&got), ids(&want), "{choice:?}: all hits");
        }
        // A visitor that stops stops every layer: one report, whichever layer holds it.
        let everything = Aabb::new(Vec3A::splat(-1e4), Vec3A::splat(1e4));
        let mut seen = 0;
        index.for_each_overlapping_aabb(&everything, |_| {
            seen += 1;
            ControlFlow::Break(())
        });
        assert_eq!(seen, 1);
    }
}
