//! The entity scene against the core's brute-force scene over the same objects.

use super::extract::PreviewWorld;
use super::scene::{EntityPreviewScene, PreviewObjects};
use crate::prelude::*;
use accel_testkit::Rng;
use accel_testkit::bevy_apps::plain_bevy_app;
use bevy::ecs::system::RunSystemOnce;
use bevy::platform::collections::HashMap;
use bevy::prelude::*;
use spatial_accel::preview::{
    BruteForcePreviewScene, PreviewCamera, PreviewInstance, PreviewScene,
};
use std::sync::Arc;

fn app() -> App {
    let mut app = plain_bevy_app();
    app.add_plugins((AccelPlugin::default(), AccelPickingPlugin))
        .init_asset::<StandardMaterial>()
        .init_asset::<Image>();
    app.finish();
    app
}

#[test]
fn entity_scene_hits_what_brute_force_hits() {
    let mut app = app();
    let shapes = {
        let mut meshes = app.world_mut().resource_mut::<Assets<Mesh>>();
        [
            meshes.add(Cuboid::new(1.0, 0.5, 2.0)),
            meshes.add(Sphere::new(0.7).mesh().uv(16, 10)),
            meshes.add(Torus::new(0.3, 0.8)),
        ]
    };
    let mut rng = Rng::new(5);
    let mut entities = Vec::new();
    for i in 0..300 {
        let tf = Transform::from_translation(rng.vec3(-20.0, 20.0))
            .with_rotation(Quat::from_rotation_arc(Vec3::Y, rng.unit_vector().into()))
            .with_scale(Vec3::new(
                rng.range(0.3, 2.0),
                rng.range(0.3, 2.0),
                rng.range(0.3, 2.0),
            ));
        let mut e = app
            .world_mut()
            .spawn((Mesh3d(shapes[i % 3].clone()), tf, Visibility::Visible));
        if i % 4 == 0 {
            e.insert(AccelStatic);
        }
        if i % 13 == 0 {
            // Hidden entities are in the trees but not in the preview.
            e.insert(Visibility::Hidden);
        }
        entities.push(e.id());
    }
    app.update();
    app.update();
    let (compared, hits) = app
        .world_mut()
        .run_system_once(|world: PreviewWorld, images: Res<Assets<Image>>| {
            let mut objects = PreviewObjects::default();
            world.objects(&mut objects, &images, &mut HashMap::default());
            let (slots, placed): (Vec<u32>, Vec<_>) = (0u32..)
                .zip(&objects.by_slot)
                .filter_map(|(slot, o)| Some((slot, o.as_ref()?)))
                .unzip();
            let instances: Vec<PreviewInstance> = placed
                .iter()
                .map(|o| PreviewInstance {
                    mesh: Arc::new(o.mesh.surface.build_bvh().unwrap()),
                    surface: Arc::new(o.mesh.surface.clone()),
                    world_from_local: o.world_from_local,
                    material: o.material,
                })
                .collect();
            let brute = BruteForcePreviewScene::new(&instances);
            let ours = EntityPreviewScene {
                trees: &world.trees,
                objects: &objects,
            };
            let eye = Vec3::new(0.0, 5.0, 45.0);
            let view = Mat4::look_at_rh(eye, Vec3::ZERO, Vec3::Y);
            let clip_from_view = Mat4::perspective_infinite_reverse_rh(0.9, 1.6, 0.1);
            let camera = PreviewCamera::new((clip_from_view * view).inverse(), eye);
            let (mut compared, mut hits) = (0, 0);
            for y in 0..60 {
                for x in 0..96 {
                    let ray = camera.pixel_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5), 96, 60);
                    let a = ours.closest(&ray);
                    let b = brute.closest(&ray);
                    let entity_a = a.and_then(|h| world.trees.entity(h.object));
                    let entity_b = b.and_then(|h| world.trees.entity(slots[h.object as usize]));
                    assert_eq!(entity_a, entity_b, "pixel ({x}, {y})");
                    if let (Some(a), Some(b)) = (a, b) {
                        assert_eq!(a.t, b.t, "pixel ({x}, {y})");
                        assert_eq!(a.triangle, b.triangle);
                        hits += 1;
                    }
                    assert_eq!(
                        ours.occluded(&ray, 1e6),
                        brute.occluded(&ray, 1e6),
                        "pixel ({x}, {y})"
                    );
                    compared += 1;
                }
            }
            (compared, hits)
        })
        .unwrap();
    assert!(hits > compared / 10, "{hits} of {compared} rays hit");
}
