//! `AccelSpatialQuery` against a scan of every tracked entity's exact world box, on random
//! scenes of moving, static and busy entities, for every index choice. Needs no cargo
//! feature.

use bevy::camera::primitives::{Aabb, Frustum};
use bevy::ecs::system::RunSystemOnce;
use bevy::math::bounding::{Aabb3d, BoundingSphere};
use bevy::math::primitives::ViewFrustum;
use bevy::prelude::*;
use bevy_accel::prelude::*;
use bevy_accel::spatial_accel;

mod common;
use accel_testkit::Rng;

fn app(index: IndexChoice, busy: BusyMovers) -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, TransformPlugin))
        .add_plugins(AccelPlugin {
            settings: AccelSettings {
                index,
                busy_movers: BusyMoverSettings {
                    mode: busy,
                    ..default()
                },
                ..default()
            },
        });
    app
}

fn random_transform(rng: &mut Rng) -> Transform {
    Transform::from_translation(rng.vec3(-50.0, 50.0))
        .with_rotation(Quat::from_scaled_axis(rng.vec3(-3.0, 3.0)))
        .with_scale(Vec3::new(
            rng.range(0.2, 3.0),
            rng.range(0.2, 3.0),
            rng.range(0.2, 3.0),
        ))
}

/// Spawns `n` boxes of random sizes, a quarter of them static.
fn populate(app: &mut App, rng: &mut Rng, n: usize) -> Vec<Entity> {
    (0..n)
        .map(|_| {
            let half = Vec3::new(
                rng.range(0.05, 2.0),
                rng.range(0.05, 2.0),
                rng.range(0.05, 2.0),
            );
            let mut entity = app
                .world_mut()
                .spawn((random_transform(rng), Aabb::from_min_max(-half, half)));
            if rng.chance(0.25) {
                entity.insert(AccelStatic);
            }
            entity.id()
        })
        .collect()
}

/// Checks every query against a scan of the trees' entities and their exact boxes.
fn check_queries(app: &mut App, rng: &mut Rng) -> usize {
    let seed = rng.next_u64();
    app.world_mut()
        .run_system_once(
            move |mut query: AccelSpatialQuery,
                  trees: Res<AccelTrees>,
                  tracked: Query<Entity, With<Aabb>>| {
                let mut rng = Rng::new(seed);
                assert_eq!(trees.len(), tracked.iter().len());
                let scan = |keep: &dyn Fn(&spatial_accel::Aabb) -> bool| {
                    common::entities_whose_box(&trees, keep)
                };
                let mut found = 0;
                for _ in 0..50 {
                    let p = rng.vec3(-60.0, 60.0);
                    let got = query.overlap_point(p).to_vec();
                    assert_eq!(got, scan(&|b| b.contains_point(p)));
                    found += got.len();

                    let half = Vec3::splat(rng.range(0.0, 15.0));
                    let q = spatial_accel::Aabb::new(p - half, p + half);
                    let got = query.overlap_aabb(Aabb3d::new(p, half)).to_vec();
                    assert_eq!(got, scan(&|b| b.intersects_aabb(&q)));
                    found += got.len();

                    let r = rng.range(0.0, 15.0);
                    let got = query.overlap_sphere(BoundingSphere::new(p, r)).to_vec();
                    assert_eq!(got, scan(&|b| b.distance_squared_to_point(p) <= r * r));
                    found += got.len();

                    let view = Mat4::look_at_rh(p, rng.vec3(-60.0, 60.0), Vec3::Y);
                    let proj = Mat4::perspective_rh(0.8, 1.5, 0.1, rng.range(5.0, 80.0));
                    let frustum = Frustum(ViewFrustum::from_clip_from_world(&(proj * view)));
                    let f = spatial_accel::Frustum::from_planes(
                        frustum.half_spaces.map(|h| h.normal_d()),
                    );
                    let got = query.overlap_frustum(&frustum).to_vec();
                    assert_eq!(got, scan(&|b| f.intersects_aabb(b)));
                    found += got.len();

                    // Nearest first; ties in slot order, as the trees break them.
                    let k = rng.below(12);
                    let pa = Vec3A::from(p);
                    let mut all: Vec<(f32, u32, Entity)> = trees
                        .iter()
                        .map(|(e, slot)| {
                            (
                                trees.world_bounds(slot).distance_squared_to_point(pa),
                                slot,
                                e,
                            )
                        })
                        .collect();
                    all.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                    let want: Vec<(Entity, f32)> = all
                        .iter()
                        .take(k)
                        .map(|&(d2, _, e)| (e, d2.sqrt()))
                        .collect();
                    assert_eq!(query.nearest(p, k), want.as_slice(), "k {k} from {p}");
                }
                found
            },
        )
        .unwrap()
}

#[test]
fn overlaps_and_nearest_equal_a_scan_on_every_index() {
    let mut choices: Vec<(IndexChoice, BusyMovers)> = IndexChoice::ALL
        .into_iter()
        .map(|choice| (choice, BusyMovers::Off))
        .collect();
    choices.push((IndexChoice::Automatic, BusyMovers::On));
    for (choice, busy) in choices {
        let mut rng = Rng::new(7);
        let mut app = app(choice, busy);
        let entities = populate(&mut app, &mut rng, 400);
        let mut found = 0;
        for frame in 0..6 {
            // Some move every frame (busy movers with `On`), some jump, some leave.
            for &entity in &entities {
                let Ok(mut e) = app.world_mut().get_entity_mut(entity) else {
                    continue;
                };
                if e.contains::<AccelStatic>() {
                    continue;
                }
                if rng.chance(0.3) {
                    if let Some(mut t) = e.get_mut::<Transform>() {
                        t.translation += Vec3::from(rng.vec3a(-1.0, 1.0));
                    }
                } else if rng.chance(0.02) {
                    e.insert(random_transform(&mut rng));
                } else if frame == 3 && rng.chance(0.05) {
                    e.despawn();
                }
            }
            app.update();
            found += check_queries(&mut app, &mut rng);
        }
        assert!(found > 1000, "{choice:?}: only {found} entities found");
    }
}
