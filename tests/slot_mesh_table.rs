//! The slot mesh table against Bevy's `MeshRayCast` while meshes change under it: handles
//! mutated in place and replaced, simplified meshes and `RayCastBackfaces` added and removed,
//! meshes removed, visibility components removed and added back, entities despawned and
//! spawned into reused slots, entities moved between the trees, assets edited, and the table
//! switched off and on.

use bevy::ecs::system::RunSystemOnce;
use bevy::picking::mesh_picking::ray_cast::{
    MeshRayCast, MeshRayCastSettings, RayCastBackfaces, RayCastVisibility, SimplifiedMesh,
};
use bevy::prelude::*;
use bevy_accel::picking::{AccelPickingSettings, SlotMeshTable, SlotMeshTableMode};
use bevy_accel::prelude::*;

mod common;
mod picking_scene;
use accel_testkit::Rng;
use common::app;
use picking_scene::*;

fn set_mode(app: &mut App, mode: SlotMeshTableMode) {
    app.world_mut()
        .resource_mut::<AccelPickingSettings>()
        .slot_mesh_table = mode;
}

fn table_active(app: &App) -> bool {
    app.world().resource::<SlotMeshTable>().is_active()
}

/// Checks 2,000 random rays against `MeshRayCast`; `step` names the check in failures.
fn assert_equivalent(app: &mut App, seed: u64, step: &str) {
    let tally = equivalence(app, 2_000, seed);
    assert!(tally.hits > 150, "{step}: too few hits ({})", tally.hits);
    assert_eq!(
        tally.different, 0,
        "{step}: {} of {} rays differ (first: {:?})",
        tally.different, tally.rays, tally.first
    );
}

/// One random edit of the mesh components of `entity`, as a game would make it.
fn edit(app: &mut App, entity: Entity, handles: &[Handle<Mesh>], rng: &mut Rng) {
    let other = handles[rng.next_u32() as usize % handles.len()].clone();
    let world = app.world_mut();
    let Ok(mut e) = world.get_entity_mut(entity) else {
        return;
    };
    match rng.next_u32() % 10 {
        // In place: no hook fires, only the change tick moves.
        0 => {
            if let Some(mut mesh) = e.get_mut::<Mesh3d>() {
                mesh.0 = other;
            }
        }
        1 => {
            e.insert(Mesh3d(other));
        }
        2 => {
            e.insert(SimplifiedMesh(other));
        }
        3 => {
            e.remove::<SimplifiedMesh>();
        }
        4 => {
            e.insert(RayCastBackfaces);
        }
        5 => {
            e.remove::<RayCastBackfaces>();
        }
        // The entity keeps its `Aabb`, so it stays in the trees with no mesh.
        6 => {
            e.remove::<Mesh3d>();
        }
        // Bevy's ray cast hits only entities with both visibility components, whatever
        // the visibility setting. (Half as often as they come back, so that enough entities
        // keep them for the rays to hit.)
        7 => match rng.next_u32() % 4 {
            0 => {
                e.remove::<InheritedVisibility>();
            }
            1 => {
                e.remove::<ViewVisibility>();
            }
            _ => {}
        },
        8 => {
            e.insert((InheritedVisibility::VISIBLE, ViewVisibility::default()));
        }
        _ => {
            if e.contains::<AccelStatic>() {
                e.remove::<AccelStatic>();
            } else {
                e.insert(AccelStatic);
            }
        }
    }
}

/// Every kind of edit, over many frames, with the table on: each frame's rays see each
/// entity's mesh as Bevy's ray cast does.
#[test]
fn the_table_follows_every_kind_of_mesh_edit() {
    let mut app = app();
    // A mesh edit changes the entity's `Aabb`, which the trees see for static entities only
    // when they watch static motion.
    app.insert_resource(AccelSettings {
        watch_static_motion: true,
        ..default()
    });
    set_mode(&mut app, SlotMeshTableMode::Always);
    let mut entities = populate(&mut app, 400, 11);
    assert!(table_active(&app));
    assert_equivalent(&mut app, 1, "populated");
    let handles: Vec<Handle<Mesh>> = app
        .world_mut()
        .query::<&Mesh3d>()
        .iter(app.world())
        .map(|m| m.0.clone())
        .collect();
    let mut rng = Rng::from_state(23);
    for frame in 0..12 {
        // Out of the trees for a frame and back: slots handed over with no mesh change.
        let away: Vec<Entity> = (0..5)
            .map(|_| entities[rng.next_u32() as usize % entities.len()])
            .collect();
        for &entity in &away {
            app.world_mut().entity_mut(entity).insert(AccelIgnore);
        }
        app.update();
        for &entity in &away {
            app.world_mut().entity_mut(entity).remove::<AccelIgnore>();
        }
        for _ in 0..40 {
            let entity = entities[rng.next_u32() as usize % entities.len()];
            edit(&mut app, entity, &handles, &mut rng);
        }
        // Despawns and spawns, so slots are handed to new entities.
        for _ in 0..10 {
            let i = rng.next_u32() as usize % entities.len();
            app.world_mut().despawn(entities.swap_remove(i));
        }
        for _ in 0..10 {
            let mesh = handles[rng.next_u32() as usize % handles.len()].clone();
            let at = Transform::from_translation(rng.vec3(-45.0, 45.0));
            entities.push(app.world_mut().spawn((at, Mesh3d(mesh))).id());
        }
        app.update();
        assert_equivalent(&mut app, 100 + frame, &format!("frame {frame}"));
        let trees = app.world().resource::<AccelTrees>();
        let table = app.world().resource::<SlotMeshTable>();
        for (entity, slot) in trees.iter() {
            assert!(
                table.has_entry(slot, entity),
                "frame {frame}: {entity} not known"
            );
        }
    }

    // An asset edited in place: the table's built shape goes with the cache's.
    let edited = handles[0].id();
    app.world_mut()
        .resource_mut::<Assets<Mesh>>()
        .insert(edited, Mesh::from(Sphere::new(0.4)))
        .unwrap();
    app.update();
    assert_equivalent(&mut app, 200, "asset edited");

    // Off, edited while off, on again: refilled, not stale.
    set_mode(&mut app, SlotMeshTableMode::Never);
    app.update();
    assert!(!table_active(&app));
    for _ in 0..60 {
        let entity = entities[rng.next_u32() as usize % entities.len()];
        edit(&mut app, entity, &handles, &mut rng);
    }
    app.update();
    assert_equivalent(&mut app, 300, "table off");
    set_mode(&mut app, SlotMeshTableMode::Always);
    app.update();
    assert!(table_active(&app));
    assert_equivalent(&mut app, 400, "table on again");
}

/// Casts `rays_per_frame` rays in every frame's `Update`.
#[derive(Resource)]
struct RaysPerFrame(usize);

fn cast_rays(mut ray_cast: AccelRayCast, rays: Res<RaysPerFrame>) {
    let settings = MeshRayCastSettings::default().with_visibility(RayCastVisibility::Any);
    for i in 0..rays.0 {
        let x = i as f32 / 10.0;
        ray_cast.cast_ray(Ray3d::new(Vec3::new(x, 0.0, 100.0), Dir3::NEG_Z), &settings);
    }
}

/// By default the table is kept while rays per frame reach the set share of the entities,
/// and dropped when they fall well below it.
#[test]
fn auto_keeps_the_table_while_rays_are_many() {
    let mut app = app();
    app.insert_resource(RaysPerFrame(1))
        .add_systems(Update, cast_rays);
    populate(&mut app, 600, 5);
    let ratio = app
        .world()
        .resource::<AccelPickingSettings>()
        .slot_mesh_table_rays_per_entity;
    let entities = app.world().resource::<AccelTrees>().len();
    for _ in 0..60 {
        app.update();
    }
    assert!(!table_active(&app), "a ray per frame does not pay for it");
    app.insert_resource(RaysPerFrame((ratio * entities as f32).ceil() as usize * 2));
    for _ in 0..60 {
        app.update();
    }
    assert!(table_active(&app), "twice the ratio's rays keep it");
    assert_equivalent(&mut app, 7, "switched on by traffic");
    app.insert_resource(RaysPerFrame(0));
    for _ in 0..60 {
        app.update();
    }
    assert!(!table_active(&app), "no rays: dropped");
}

/// A mesh asset edited while the plugin is off: the trees stand still, but rays must not test
/// the old triangles through the table. The new mesh has the old one's bounds, so only the
/// triangles tell the two apart.
#[test]
fn an_asset_edited_while_the_plugin_is_off_is_seen() {
    let mut app = app();
    set_mode(&mut app, SlotMeshTableMode::Always);
    let cube = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(Cuboid::from_length(2.0));
    app.world_mut().spawn(Mesh3d(cube.clone()));
    app.update();
    app.update();
    assert!(table_active(&app));
    let ray = Ray3d::new(Vec3::new(0.5, 0.5, 5.0), Dir3::NEG_Z);
    let cast = |app: &mut App| {
        app.world_mut()
            .run_system_once(move |mut ours: AccelRayCast, mut bevy: MeshRayCast| {
                let settings =
                    MeshRayCastSettings::default().with_visibility(RayCastVisibility::Any);
                let ours = ours.cast_ray(ray, &settings).first().map(|h| h.1.distance);
                let bevy = bevy.cast_ray(ray, &settings).first().map(|h| h.1.distance);
                (ours, bevy)
            })
            .unwrap()
    };
    assert_eq!(cast(&mut app), (Some(4.0), Some(4.0)));
    app.world_mut().resource_mut::<AccelSettings>().enabled = false;
    // A tetrahedron spanning the cube's corners (-1, -1, -1) and (1, 1, 1).
    let mut tetrahedron = Mesh::new(
        bevy::mesh::PrimitiveTopology::TriangleList,
        bevy::asset::RenderAssetUsages::default(),
    );
    tetrahedron.insert_attribute(
        Mesh::ATTRIBUTE_POSITION,
        vec![
            [-1.0f32, -1.0, -1.0],
            [1.0, 1.0, -1.0],
            [1.0, -1.0, 1.0],
            [-1.0, 1.0, 1.0],
        ],
    );
    tetrahedron.insert_indices(bevy::mesh::Indices::U32(vec![
        0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3,
    ]));
    app.world_mut()
        .resource_mut::<Assets<Mesh>>()
        .insert(cube.id(), tetrahedron)
        .unwrap();
    app.update();
    let (ours, bevy) = cast(&mut app);
    assert!(
        bevy.is_some_and(|d| d > 4.1),
        "the new faces are farther: {bevy:?}"
    );
    assert_eq!(ours, bevy);
}
