//! The random picking scenes and the comparison with Bevy's `MeshRayCast` that the picking
//! tests share.
#![allow(dead_code)]

use accel_testkit::Rng;
use bevy::camera::primitives::Aabb;
use bevy::camera::visibility::RenderLayers;
use bevy::ecs::system::RunSystemOnce;
use bevy::mesh::Indices;
use bevy::picking::mesh_picking::ray_cast::{
    MeshRayCast, MeshRayCastSettings, RayCastBackfaces, RayCastVisibility, RayMeshHit,
    SimplifiedMesh,
};
use bevy::prelude::*;
use bevy_accel::prelude::*;

/// Entities whose hits stop the ray in the mixed early-exit mode.
#[derive(Component)]
pub struct Blocker;

/// Mesh assets of every kind Bevy's ray cast reads: u32, u16 and no indices, with and without
/// normals and uvs, closed and open, flat.
pub fn test_meshes(meshes: &mut Assets<Mesh>) -> [Handle<Mesh>; TEST_MESHES] {
    let mut u16_sphere = Sphere::new(0.7).mesh().uv(16, 12);
    if let Some(Indices::U32(i)) = u16_sphere.indices() {
        let short = i.iter().map(|&i| i as u16).collect();
        u16_sphere.insert_indices(Indices::U16(short));
    }
    // Every seventh triangle names a vertex the mesh does not have: Bevy skips those
    // triangles and keeps the rest.
    let mut broken_sphere = Sphere::new(0.9).mesh().uv(24, 14);
    if let Some(Indices::U32(i)) = broken_sphere.indices_mut() {
        for triangle in i.chunks_exact_mut(3).step_by(7) {
            triangle[1] = u32::MAX;
        }
    }
    let mut bare_torus = Mesh::from(Torus::new(0.3, 0.8));
    bare_torus.remove_attribute(Mesh::ATTRIBUTE_NORMAL);
    bare_torus.remove_attribute(Mesh::ATTRIBUTE_UV_0);
    [
        Mesh::from(Cuboid::new(1.0, 2.0, 0.5)),
        Sphere::new(1.0).mesh().uv(32, 18),
        Sphere::new(0.8).mesh().ico(3).unwrap(),
        Mesh::from(Torus::new(0.5, 1.0)),
        Mesh::from(Cylinder::new(0.5, 2.0)),
        Mesh::from(Capsule3d::default()),
        Mesh::from(Cone::default()),
        Mesh::from(Plane3d::new(Vec3::Y, Vec2::splat(1.0))),
        u16_sphere,
        Mesh::from(Torus::new(0.3, 0.8)).with_duplicated_vertices(),
        bare_torus,
        broken_sphere,
    ]
    .map(|m| meshes.add(m))
}

/// How many assets [`test_meshes`] makes.
pub const TEST_MESHES: usize = 12;

/// A random scene of `n` mesh entities (some hidden, on other layers, double-sided, with a
/// simplified mesh, blocking) and a few mesh-less entities with bounds only.
pub fn populate(app: &mut App, n: usize, seed: u64) -> Vec<Entity> {
    let mut rng = Rng::from_state(seed);
    let handles = test_meshes(&mut app.world_mut().resource_mut::<Assets<Mesh>>());
    let world = app.world_mut();
    let mut out = Vec::new();
    for _ in 0..n {
        let axis = rng.vec3(-1.0, 1.0).normalize_or(Vec3::Y);
        let scale = Vec3::new(
            rng.range(0.3, 3.0),
            rng.range(0.3, 3.0),
            rng.range(0.3, 3.0),
        );
        let transform = Transform::from_translation(rng.vec3(-50.0, 50.0))
            .with_rotation(Quat::from_axis_angle(axis, rng.range(0.0, 6.3)))
            .with_scale(scale);
        let mesh = handles[rng.next_u32() as usize % handles.len()].clone();
        let mut e = world.spawn((transform, Mesh3d(mesh)));
        if rng.chance(0.1) {
            e.insert(Visibility::Hidden);
        }
        if rng.chance(0.1) {
            e.insert(RenderLayers::layer(1));
        }
        if rng.chance(0.1) {
            e.insert(RayCastBackfaces);
        }
        if rng.chance(0.05) {
            // A smaller stand-in inside the same bounds (the cuboid fits every mesh's box
            // only partly, which Bevy handles by its box test: so must we).
            e.insert(SimplifiedMesh(handles[0].clone()));
        }
        if rng.chance(0.3) {
            e.insert(Blocker);
        }
        out.push(e.id());
    }
    for _ in 0..n / 20 {
        let t = Transform::from_translation(rng.vec3(-50.0, 50.0));
        world.spawn((t, Aabb::from_min_max(Vec3::splat(-1.0), Vec3::splat(1.0))));
    }
    app.update();
    app.update();
    out
}

pub fn random_ray(rng: &mut Rng) -> Ray3d {
    let origin = rng.vec3(-70.0, 70.0);
    let target = rng.vec3(-45.0, 45.0);
    Ray3d::new(origin, Dir3::new(target - origin).unwrap_or(Dir3::X))
}

pub fn close(a: f32, b: f32) -> bool {
    (a - b).abs() <= 1e-5 * b.abs().max(1e-2)
}

/// How one ray's results compare.
pub enum Outcome {
    Equal,
    /// Differ only where a hit lies within 1e-4 (barycentric) of a triangle edge, where
    /// Möller-Trumbore and the watertight test may decide differently.
    Grazing,
    Different(String),
}

pub fn near_edge(hit: &RayMeshHit) -> bool {
    hit.barycentric_coords.min_element() < 1e-4
}

pub fn compare(ours: &[(Entity, RayMeshHit)], theirs: &[(Entity, RayMeshHit)]) -> Outcome {
    let same_entities = ours.len() == theirs.len()
        && ours.iter().zip(theirs).all(|((a, ha), (b, hb))| {
            // Two hits at one distance may come in either order.
            a == b || close(ha.distance, hb.distance)
        });
    if same_entities {
        for ((e, a), (_, b)) in ours.iter().zip(theirs) {
            let scale = 1e-4 * (1.0 + b.point.length());
            if !close(a.distance, b.distance) || a.point.distance(b.point) > scale {
                if near_edge(a) || near_edge(b) {
                    return Outcome::Grazing;
                }
                return Outcome::Different(format!(
                    "{e}: distance {} vs {}, point {} vs {}",
                    a.distance, b.distance, a.point, b.point
                ));
            }
            if a.triangle_index == b.triangle_index
                && a.normal.distance(b.normal) > 1e-3 * (1.0 + b.normal.length())
            {
                return Outcome::Different(format!("{e}: normal {} vs {}", a.normal, b.normal));
            }
        }
        return Outcome::Equal;
    }
    // A hit one side has and the other lacks, on an edge: a grazing ray.
    let only = |x: &[(Entity, RayMeshHit)], y: &[(Entity, RayMeshHit)]| {
        x.iter()
            .filter(|(e, _)| !y.iter().any(|(f, _)| f == e))
            .map(|(_, h)| near_edge(h))
            .collect::<Vec<_>>()
    };
    let differing: Vec<bool> = only(ours, theirs)
        .into_iter()
        .chain(only(theirs, ours))
        .collect();
    if !differing.is_empty() && differing.iter().all(|&edge| edge) {
        return Outcome::Grazing;
    }
    let brief = |x: &[(Entity, RayMeshHit)]| {
        x.iter()
            .take(4)
            .map(|(e, h)| format!("{e}@{}", h.distance))
            .collect::<Vec<_>>()
            .join(", ")
    };
    Outcome::Different(format!(
        "{} hits [{}] vs {} hits [{}]",
        ours.len(),
        brief(ours),
        theirs.len(),
        brief(theirs)
    ))
}

#[derive(Default, Debug)]
pub struct Tally {
    pub rays: usize,
    pub hits: usize,
    pub grazing: usize,
    pub different: usize,
    pub first: Vec<String>,
}

/// Casts `rays` random rays with both ray casts under three settings and tallies the outcomes.
pub fn equivalence(app: &mut App, rays: usize, seed: u64) -> Tally {
    app.world_mut()
        .run_system_once(
            move |mut ours: AccelRayCast,
                  mut bevy: MeshRayCast,
                  layers: Query<&RenderLayers>,
                  blockers: Query<(), With<Blocker>>| {
                let mut rng = Rng::from_state(seed);
                let mut tally = Tally::default();
                let on_layer_0 = |e| {
                    layers
                        .get(e)
                        .map_or(true, |l| l.intersects(&RenderLayers::default()))
                };
                let blocks = |e| blockers.contains(e);
                for i in 0..rays {
                    let ray = random_ray(&mut rng);
                    let base = MeshRayCastSettings::default();
                    let settings = match i % 3 {
                        0 => base
                            .with_visibility(RayCastVisibility::Visible)
                            .with_filter(&on_layer_0),
                        1 => base
                            .with_visibility(RayCastVisibility::Any)
                            .never_early_exit(),
                        _ => base
                            .with_visibility(RayCastVisibility::Visible)
                            .with_early_exit_test(&blocks),
                    };
                    let a = ours.cast_ray(ray, &settings).to_vec();
                    let b = bevy.cast_ray(ray, &settings);
                    tally.rays += 1;
                    tally.hits += b.len();
                    match compare(&a, b) {
                        Outcome::Equal => {}
                        Outcome::Grazing => tally.grazing += 1,
                        Outcome::Different(why) => {
                            tally.different += 1;
                            if tally.first.len() < 5 {
                                tally.first.push(format!("ray {i} {ray:?}: {why}"));
                            }
                        }
                    }
                }
                tally
            },
        )
        .unwrap()
}
