//! `AccelSpritePickingPlugin`'s backend against Bevy's own sprite backend, on random sprites:
//! sizes, anchors, rotations (tilted out of the plane too), scales, depths, render layers,
//! hidden sprites, sprites kept out of the trees, non-blocking sprites, and images whose
//! transparent pixels must not pick; then again after the sprites moved.

use bevy::asset::RenderAssetUsages;
use bevy::camera::primitives::Frustum;
use bevy::camera::visibility::{NoAutoAabb, RenderLayers, VisibilitySystems};
use bevy::camera::{CameraProjection, ImageRenderTarget, RenderTarget};
use bevy::ecs::system::RunSystemOnce;
use bevy::image::TextureAtlasLayout;
use bevy::math::primitives::ViewFrustum;
use bevy::picking::Pickable;
use bevy::picking::backend::ray::{RayId, RayMap};
use bevy::picking::backend::{HitData, PointerHits};
use bevy::picking::pointer::{Location, PointerId, PointerLocation};
use bevy::prelude::*;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};
use bevy::sprite::{Anchor, SpritePickingMode, SpritePickingPlugin, SpritePickingSettings};
use bevy_accel::picking::{AccelSpritePickingMode, AccelSpritePickingSettings, update_sprite_hits};
use bevy_accel::prelude::*;

mod common;
use accel_testkit::Rng;

const HALF: f32 = 500.0;

/// A 4x4 image whose left half is transparent.
fn half_transparent_image() -> Image {
    let mut data = Vec::new();
    for _y in 0..4 {
        for x in 0..4 {
            data.extend_from_slice(&[200, 100, 50, if x < 2 { 0 } else { 255 }]);
        }
    }
    Image::new(
        Extent3d {
            width: 4,
            height: 4,
            depth_or_array_layers: 1,
        },
        TextureDimension::D2,
        data,
        TextureFormat::Rgba8UnormSrgb,
        RenderAssetUsages::default(),
    )
}

struct Scene {
    app: App,
    camera: Entity,
    target: bevy::camera::NormalizedRenderTarget,
    sprites: Vec<Entity>,
}

fn scene(seed: u64, count: usize) -> Scene {
    let mut app = common::headless_app();
    app.init_asset::<Image>()
        .init_asset::<TextureAtlasLayout>()
        .add_message::<PointerHits>()
        .init_resource::<RayMap>()
        .add_plugins(SpritePickingPlugin)
        .init_resource::<AccelSpritePickingSettings>()
        .insert_resource(AccelSettings {
            index: IndexChoice::Quadtree,
            static_rebuild_in_frame_up_to: usize::MAX,
            ..default()
        })
        .add_systems(
            PostUpdate,
            bevy::sprite::calculate_bounds_2d.in_set(VisibilitySystems::CalculateBounds),
        );
    app.finish();
    let image = app
        .world_mut()
        .resource_mut::<Assets<Image>>()
        .add(half_transparent_image());
    let target_image = app
        .world_mut()
        .resource_mut::<Assets<Image>>()
        .add(half_transparent_image());
    let render_target = RenderTarget::Image(ImageRenderTarget::from(target_image));
    let target = render_target.normalize(None).expect("an image target");
    let projection = OrthographicProjection {
        area: Rect::new(-HALF, -HALF, HALF, HALF),
        ..OrthographicProjection::default_2d()
    };
    let clip_from_world = projection.get_clip_from_view();
    let camera = app
        .world_mut()
        .spawn((
            Camera::default(),
            render_target,
            Projection::Orthographic(projection),
            Frustum(ViewFrustum::from_clip_from_world(&clip_from_world)),
            RenderLayers::from_layers(&[0, 2]),
        ))
        .id();
    let mut rng = Rng::new(seed);
    let anchors = [
        Anchor::CENTER,
        Anchor::TOP_LEFT,
        Anchor::BOTTOM_RIGHT,
        Anchor(Vec2::new(0.3, -0.45)),
    ];
    let mut sprites = Vec::new();
    for i in 0..count {
        let size = Vec2::new(rng.range(2.0, 60.0), rng.range(2.0, 60.0));
        let mut sprite = Sprite::from_color(Color::WHITE, size);
        if i % 5 == 0 {
            sprite.image = image.clone();
        }
        let position = Vec3::new(
            rng.range(-HALF, HALF),
            rng.range(-HALF, HALF),
            // Distinct depths: Bevy orders sprites of equal depth by its tables.
            i as f32 * 0.01 - 100.0,
        );
        let rotation = match i % 4 {
            0 => Quat::IDENTITY,
            1 => Quat::from_rotation_z(rng.range(0.0, 6.3)),
            2 => Quat::from_rotation_x(rng.range(-1.2, 1.2)) * Quat::from_rotation_z(1.0),
            _ => Quat::from_rotation_y(rng.range(-1.2, 1.2)),
        };
        let scale = Vec3::new(rng.range(0.5, 2.0), rng.range(0.5, 2.0), 1.0);
        let mut e = app.world_mut().spawn((
            sprite,
            Pickable::default(),
            anchors[i % anchors.len()],
            Transform::from_translation(position)
                .with_rotation(rotation)
                .with_scale(scale),
        ));
        match i % 11 {
            0 => {
                e.insert(Pickable {
                    should_block_lower: false,
                    is_hoverable: true,
                });
            }
            1 => {
                e.insert(Visibility::Hidden);
            }
            2 => {
                e.insert(RenderLayers::layer(1));
            }
            3 => {
                e.insert(AccelIgnore);
            }
            4 => {
                e.insert(NoAutoAabb);
            }
            5 => {
                e.insert(AccelStatic);
            }
            _ => {}
        }
        sprites.push(e.id());
    }
    app.update();
    Scene {
        app,
        camera,
        target,
        sprites,
    }
}

/// Sets up `rays` pointers at random positions, and returns each backend's hits.
fn both_backends(
    s: &mut Scene,
    rng: &mut Rng,
    rays: usize,
) -> (Vec<PointerHits>, Vec<PointerHits>) {
    let world = s.app.world_mut();
    let old: Vec<Entity> = world
        .query_filtered::<Entity, With<PointerLocation>>()
        .iter(world)
        .collect();
    for e in old {
        world.despawn(e);
    }
    let mut map = RayMap::default();
    for k in 0..rays {
        let at = Vec2::new(rng.range(-HALF, HALF), rng.range(-HALF, HALF));
        let pointer = PointerId::Touch(k as u64);
        world.spawn((
            pointer,
            PointerLocation::new(Location {
                target: s.target.clone(),
                position: at,
            }),
        ));
        // The camera's ray: from the near plane (1000 in front of the camera at z = 0) down
        // the view direction.
        map.map.insert(
            RayId::new(s.camera, pointer),
            Ray3d::new(at.extend(1000.0), Dir3::NEG_Z),
        );
    }
    world.insert_resource(map);
    let drain = |world: &mut World| {
        let mut hits: Vec<PointerHits> = world
            .resource_mut::<Messages<PointerHits>>()
            .drain()
            .collect();
        hits.sort_by_key(|h| match h.pointer {
            PointerId::Touch(k) => k,
            _ => u64::MAX,
        });
        hits
    };
    drain(world);
    world.run_system_once(update_sprite_hits).unwrap();
    let ours = drain(world);
    world.run_schedule(PreUpdate);
    let theirs = drain(world);
    (ours, theirs)
}

fn picks(h: &PointerHits) -> Vec<(Entity, f32, Option<Vec3>)> {
    h.picks
        .iter()
        .map(|(e, d): &(Entity, HitData)| (*e, d.depth, d.position))
        .collect()
}

fn assert_same(ours: &[PointerHits], theirs: &[PointerHits]) -> usize {
    assert_eq!(ours.len(), theirs.len(), "pointer hit messages");
    let mut hits = 0;
    for (a, b) in ours.iter().zip(theirs) {
        assert_eq!(a.pointer, b.pointer);
        assert_eq!(a.order, b.order);
        assert_eq!(picks(a), picks(b), "pointer {:?}", a.pointer);
        hits += b.picks.len();
    }
    hits
}

#[test]
fn sprite_hits_equal_bevys_backend() {
    for (seed, mode) in [
        (1, AccelSpritePickingMode::AlphaThreshold(0.1)),
        (2, AccelSpritePickingMode::BoundingBox),
    ] {
        let mut s = scene(seed, 3000);
        s.app.insert_resource(AccelSpritePickingSettings {
            picking_mode: mode,
            ..default()
        });
        s.app.insert_resource(SpritePickingSettings {
            require_markers: false,
            picking_mode: match mode {
                AccelSpritePickingMode::BoundingBox => SpritePickingMode::BoundingBox,
                AccelSpritePickingMode::AlphaThreshold(a) => SpritePickingMode::AlphaThreshold(a),
            },
        });
        let mut rng = Rng::new(seed + 100);
        let mut hits = 0;
        for round in 0..4 {
            let (ours, theirs) = both_backends(&mut s, &mut rng, 200);
            hits += assert_same(&ours, &theirs);
            // Move a third of the sprites, so that the next round reads moved trees (not the
            // static ones: the trees do not watch those for motion, by default).
            for (i, &e) in s.sprites.iter().enumerate() {
                if (i + round) % 3 == 0
                    && i % 11 != 5
                    && let Some(mut tf) = s.app.world_mut().get_mut::<Transform>(e)
                {
                    tf.translation.x = (tf.translation.x + 37.0 + HALF) % (2.0 * HALF) - HALF;
                }
            }
            s.app.update();
        }
        assert!(hits > 400, "seed {seed}: only {hits} hits to compare");
    }
}

#[test]
fn stale_trees_fall_back_to_every_sprite() {
    let mut s = scene(3, 800);
    s.app.world_mut().resource_mut::<AccelSettings>().enabled = false;
    // Moved while the trees do not follow: the backend must not trust them.
    for &e in &s.sprites {
        if let Some(mut tf) = s.app.world_mut().get_mut::<Transform>(e) {
            tf.translation.y = -tf.translation.y;
        }
    }
    s.app.update();
    let mut rng = Rng::new(7);
    let (ours, theirs) = both_backends(&mut s, &mut rng, 300);
    assert!(assert_same(&ours, &theirs) > 50);
}
