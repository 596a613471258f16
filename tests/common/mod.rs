//! What the plugin's tests share. Each uses part of it. The plain headless Bevy app, the grid
//! and bevy_light's plugin in the app come from `accel_testkit::bevy_apps` (which the bench
//! tool uses too); what needs the plugin is here.
#![allow(dead_code, unused_imports)]

#[cfg(feature = "light_culling")]
pub use accel_testkit::bevy_apps::add_lights;
pub use accel_testkit::bevy_apps::{grid_point, plain_bevy_app};
use bevy::camera::primitives::Aabb;
use bevy::ecs::entity::EntityHashSet;
use bevy::prelude::*;
use bevy_accel::TreeSlot;
use bevy_accel::prelude::*;
use bevy_accel::spatial_accel::SpatialQuery;
use bevy_accel::spatial_accel::dynamic::DynamicBvh;
use bevy_accel::spatial_accel::query::AnyHandle;
use core::ops::ControlFlow;

/// A headless app with the trees and what Bevy's visibility needs: no window, no renderer
/// ([`plain_bevy_app`] with `AccelPlugin`). Not finished: add the plugins under test, then
/// call `App::finish`. The trees are kept current at every size
/// (`AccelSettings::step_aside_below` 0, `step_aside_when_slower` and
/// `skip_unread_mover_upkeep` off): the tests' worlds would otherwise hand their culling to
/// Bevy's own pass after a few frames, when small or when Bevy's pass is timed cheaper, or
/// leave the busy movers' boxes unwritten under wide views (`tests/step_aside.rs` tests all
/// three).
pub fn headless_app() -> App {
    let mut app = plain_bevy_app();
    app.add_plugins(AccelPlugin {
        settings: AccelSettings {
            step_aside_below: 0,
            step_aside_when_slower: false,
            skip_unread_mover_upkeep: false,
            ..default()
        },
    });
    app
}

/// [`headless_app`] with the picking backend, finished.
#[cfg(feature = "picking")]
pub fn app() -> App {
    let mut app = headless_app();
    app.add_plugins(AccelPickingPlugin);
    app.finish();
    app
}

/// A unit cube's `Aabb`, centred on the entity.
pub fn unit_aabb() -> Aabb {
    Aabb::from_min_max(Vec3::splat(-0.5), Vec3::splat(0.5))
}

/// An app with the trees only (`MinimalPlugins`, `TransformPlugin`, `AccelPlugin` with
/// `settings`) and `n` unit cubes scattered over a 200-unit cube from `seed`, in spawn order;
/// with the generator, for the test's next draws.
pub fn trees_app_with_cubes(
    settings: AccelSettings,
    n: usize,
    seed: u64,
) -> (App, Vec<Entity>, accel_testkit::Rng) {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, TransformPlugin, AccelPlugin { settings }));
    let mut rng = accel_testkit::Rng::from_state(seed);
    let entities = (0..n)
        .map(|_| {
            let t = Transform::from_translation(rng.vec3(-100.0, 100.0));
            app.world_mut().spawn((t, unit_aabb())).id()
        })
        .collect();
    (app, entities, rng)
}

/// The tracked entities whose exact world box passes `keep`, sorted: the brute force that
/// every overlap query is compared with.
pub fn entities_whose_box(
    trees: &AccelTrees,
    keep: impl Fn(&bevy_accel::spatial_accel::Aabb) -> bool,
) -> Vec<Entity> {
    let mut found: Vec<Entity> = trees
        .iter()
        .filter(|&(_, slot)| keep(&trees.world_bounds(slot)))
        .map(|(entity, _)| entity)
        .collect();
    found.sort_unstable();
    found
}

/// The dynamic BVH, where the automatic choice (the default) keeps a scene this small.
pub fn bvh(trees: &AccelTrees) -> &DynamicBvh {
    trees.dynamic_bvh().expect("the BVH is the default index")
}

/// Every entity that should be tracked is, with a tree box containing its world box; nothing
/// else is; the trees are valid.
pub fn check_consistency(app: &mut App) {
    let world = app.world_mut();
    let mut q = world.query_filtered::<(Entity, &Aabb, &GlobalTransform), Without<AccelIgnore>>();
    let mut expected = EntityHashSet::default();
    let boxes: Vec<(Entity, bevy_accel::spatial_accel::Aabb)> = q
        .iter(world)
        .filter_map(|(e, aabb, gt)| {
            let a = gt.affine();
            let ok = a.matrix3.determinant().is_finite()
                && a.matrix3.determinant() != 0.0
                && a.translation.is_finite();
            ok.then(|| {
                (
                    e,
                    bevy_accel::spatial_accel::Aabb::from_center_half_extents(
                        aabb.center,
                        aabb.half_extents,
                    )
                    .transformed(&a),
                )
            })
        })
        .collect();
    for (e, _) in &boxes {
        expected.insert(*e);
    }
    let trees = world.resource::<AccelTrees>();
    let tracked: EntityHashSet = trees.iter().map(|(e, _)| e).collect();
    assert_eq!(tracked.len(), trees.len());
    assert_eq!(tracked, expected, "tracked set differs from the ECS");
    if let Some(tree) = trees.dynamic_bvh() {
        tree.validate().unwrap();
    }
    for (e, world_box) in boxes {
        let (slot, tree) = trees.location(e).unwrap();
        assert_eq!(trees.entity(slot), Some(e));
        match tree {
            TreeSlot::Dynamic(AnyHandle::DynamicBvh(h))
            | TreeSlot::StaticWaiting(AnyHandle::DynamicBvh(h)) => {
                let fat = bvh(trees).fat_bounds(h).unwrap();
                assert!(
                    fat.contains_aabb(&world_box),
                    "{e}: fat box {fat:?} misses {world_box:?}"
                );
            }
            TreeSlot::Dynamic(_) | TreeSlot::StaticWaiting(_) | TreeSlot::Static => {
                assert_eq!(trees.world_bounds(slot), world_box)
            }
            TreeSlot::Busy => {
                assert!(trees.is_busy(slot));
                assert!(trees.local_frame(slot).is_none());
                assert_eq!(trees.world_bounds(slot), world_box);
                let entry = trees
                    .query()
                    .busy_movers()
                    .get(e.index_u32(), e.generation().to_bits())
                    .expect("a busy mover has its entry");
                assert_eq!(entry.id, slot);
            }
        }
        // Whatever the index, a query over the entity's box reports its slot, once.
        let mut seen = 0;
        trees.query().for_each_overlapping_aabb(&world_box, |s| {
            seen += usize::from(s == slot);
            ControlFlow::Continue(())
        });
        assert_eq!(seen, 1, "{e}: its own box query saw it {seen} times");
    }
    // Every slot the static tree returns is a tracked static entity's, or a cleared slot (a
    // static entity that left since the tree was built), and holds every static entity.
    let mut held_static = 0;
    for &slot in trees.static_tree().primitive_indices() {
        if let Some(e) = trees.entity(slot) {
            assert_eq!(trees.location(e), Some((slot, TreeSlot::Static)), "{e}");
            held_static += 1;
        } else {
            assert_eq!(
                trees.world_bounds(slot),
                bevy_accel::spatial_accel::Aabb::EMPTY
            );
        }
    }
    trees.query().busy_movers().validate().unwrap();
    let busy = trees
        .iter()
        .filter(|(e, _)| trees.location(*e).unwrap().1 == TreeSlot::Busy)
        .count();
    assert_eq!(
        trees.busy_len(),
        busy,
        "busy movers listed but not tracked as such"
    );
    let n_static = trees
        .iter()
        .filter(|(e, _)| trees.location(*e).unwrap().1 == TreeSlot::Static)
        .count();
    let n_waiting = trees
        .iter()
        .filter(|(e, _)| matches!(trees.location(*e).unwrap().1, TreeSlot::StaticWaiting(_)))
        .count();
    assert_eq!(held_static, n_static);
    assert_eq!(trees.static_len(), n_static + n_waiting);
    assert_eq!(trees.static_waiting_len(), n_waiting);
}
