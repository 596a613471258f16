//! Skinned meshes picked where Bevy draws them: `AccelRayCast` against a brute force that
//! skins every vertex on the CPU as Bevy's shader does and tests every posed triangle, on
//! characters whose joints take random poses (non-uniform scales, mirrored joints) and whose
//! weights need not sum to one. The same rays through Bevy's `MeshRayCast`, which tests the
//! bind pose, are shown to be wrong, so the test can fail.

use accel_testkit::Rng;
use accel_testkit::skinned::{Detail, JOINT_COUNT, JOINT_PARENTS, SkinnedCharacter, character};
use bevy::asset::RenderAssetUsages;
use bevy::camera::primitives::{Aabb, MeshAabb};
use bevy::ecs::system::RunSystemOnce;
use bevy::mesh::morph::{MeshMorphWeights, MorphAttributes};
use bevy::mesh::skinning::{SkinnedMesh, SkinnedMeshInverseBindposes};
use bevy::mesh::{Indices, PrimitiveTopology, VertexAttributeValues};
use bevy::picking::mesh_picking::ray_cast::{MeshRayCast, MeshRayCastSettings, RayCastVisibility};
use bevy::prelude::*;
use bevy_accel::prelude::*;
use spatial_accel::geometry::Triangle;
use spatial_accel::{Backfaces, Ray};

mod common;

/// One character in the world: its mesh entity and joints.
struct Character {
    mesh: Entity,
    joints: Vec<Entity>,
}

/// The character mesh with the given joint weights and the character's morph target.
fn bevy_mesh(c: &SkinnedCharacter, weights: &[[f32; 4]]) -> Mesh {
    let mut mesh = Mesh::new(PrimitiveTopology::TriangleList, RenderAssetUsages::all())
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, c.positions.clone())
        .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, c.normals.clone())
        .with_inserted_attribute(
            Mesh::ATTRIBUTE_JOINT_INDEX,
            VertexAttributeValues::Uint16x4(c.joints.clone()),
        )
        .with_inserted_attribute(Mesh::ATTRIBUTE_JOINT_WEIGHT, weights.to_vec())
        .with_inserted_indices(Indices::U32(c.indices.clone()));
    // The character's one morph target (its chest breathing), as Bevy's glTF loader stores
    // targets: position displacements, target-major.
    mesh.set_morph_targets(
        c.breathe
            .iter()
            .map(|&position| MorphAttributes {
                position,
                ..default()
            })
            .collect(),
    );
    mesh
}

/// A random local transform for a joint: a rotation, a non-uniform scale, mirrored on one
/// axis now and then, around its rest translation.
fn random_local(rng: &mut Rng, rest: Vec3) -> Transform {
    let axis = Vec3::new(
        rng.range(-1.0, 1.0),
        rng.range(-1.0, 1.0),
        rng.range(-1.0, 1.0),
    )
    .normalize_or(Vec3::Y);
    let mut scale = Vec3::new(
        rng.range(0.6, 1.4),
        rng.range(0.6, 1.4),
        rng.range(0.6, 1.4),
    );
    if rng.below(6) == 0 {
        scale.x = -scale.x;
    }
    Transform {
        translation: rest,
        rotation: Quat::from_axis_angle(axis, rng.range(-1.2, 1.2)),
        scale,
    }
}

fn spawn_characters(
    app: &mut App,
    c: &SkinnedCharacter,
    rng: &mut Rng,
    dynamic_bounds: bool,
) -> Vec<Character> {
    let rest = accel_testkit::skinned::rest_pose();
    let bindposes = app
        .world_mut()
        .resource_mut::<Assets<SkinnedMeshInverseBindposes>>()
        .add(SkinnedMeshInverseBindposes::from(c.inverse_bind.clone()));
    let mut out = Vec::new();
    for i in 0..8 {
        // Half the characters with weights that do not sum to one, as Bevy stores them.
        let weights: Vec<[f32; 4]> = if i % 2 == 0 {
            c.weights.clone()
        } else {
            c.weights
                .iter()
                .map(|w| w.map(|w| w * rng.range(0.7, 1.3)))
                .collect()
        };
        let mut asset = bevy_mesh(c, &weights);
        if dynamic_bounds {
            // As Bevy's glTF loader makes them: skinned bounds, no morph targets (Bevy's box
            // leaves morphs out, so those characters keep the plugin's own broad phase).
            asset.set_morph_targets(Vec::new());
            asset.generate_skinned_mesh_bounds().unwrap();
        }
        let mesh = app.world_mut().resource_mut::<Assets<Mesh>>().add(asset);
        let root = app
            .world_mut()
            .spawn(Transform::from_xyz(
                (i % 4) as f32 * 3.0,
                0.0,
                (i / 4) as f32 * 3.0,
            ))
            .id();
        let mut joints: Vec<Entity> = Vec::with_capacity(JOINT_COUNT);
        for (k, parent) in JOINT_PARENTS.iter().enumerate() {
            let parent = parent.map_or(root, |p| joints[p]);
            let local = Transform {
                translation: rest[k].translation,
                rotation: rest[k].rotation,
                scale: rest[k].scale,
            };
            joints.push(app.world_mut().spawn((local, ChildOf(parent))).id());
        }
        let mesh = app
            .world_mut()
            .spawn((
                Mesh3d(mesh),
                SkinnedMesh {
                    inverse_bindposes: bindposes.clone(),
                    joints: joints.clone(),
                },
                Transform::IDENTITY,
                Visibility::Visible,
                ChildOf(root),
                // Scaled far past a breath, so that a wrong morph shows.
                MeshMorphWeights::Value { weights: vec![0.0] },
            ))
            .id();
        if dynamic_bounds {
            app.world_mut()
                .entity_mut(mesh)
                .insert(bevy::camera::visibility::DynamicSkinnedMeshBounds);
        }
        out.push(Character { mesh, joints });
    }
    out
}

/// Every character's posed triangles, skinned on the CPU from the world's joint transforms
/// exactly as Bevy's shader: `Σ w_k (J_k p)`, `J_k = joint global * inverse bindpose`.
fn posed_triangles(
    app: &App,
    c: &SkinnedCharacter,
    chars: &[Character],
) -> Vec<(Entity, Vec<[Vec3; 3]>)> {
    chars
        .iter()
        .map(|ch| {
            let mesh = app.world().get::<Mesh3d>(ch.mesh).unwrap();
            let asset = app.world().resource::<Assets<Mesh>>().get(&mesh.0).unwrap();
            let Some(VertexAttributeValues::Float32x4(weights)) =
                asset.attribute(Mesh::ATTRIBUTE_JOINT_WEIGHT)
            else {
                panic!("weights")
            };
            let matrices: Vec<Mat4> = ch
                .joints
                .iter()
                .zip(&c.inverse_bind)
                .map(|(&j, ib)| {
                    Mat4::from(app.world().get::<GlobalTransform>(j).unwrap().affine()) * *ib
                })
                .collect();
            let breath = match app.world().get::<MeshMorphWeights>(ch.mesh) {
                Some(MeshMorphWeights::Value { weights }) => weights[0],
                _ => 0.0,
            };
            let posed: Vec<Vec3> = c
                .positions
                .iter()
                .zip(&c.breathe)
                .zip(c.joints.iter().zip(weights))
                .map(|((&p, &d), (j, w))| {
                    let p = if breath != 0.0 { p + breath * d } else { p };
                    let m = matrices[j[0] as usize] * w[0]
                        + matrices[j[1] as usize] * w[1]
                        + matrices[j[2] as usize] * w[2]
                        + matrices[j[3] as usize] * w[3];
                    (m * p.extend(1.0)).truncate()
                })
                .collect();
            let tris = c
                .indices
                .chunks_exact(3)
                .map(|t| {
                    [
                        posed[t[0] as usize],
                        posed[t[1] as usize],
                        posed[t[2] as usize],
                    ]
                })
                .collect();
            (ch.mesh, tris)
        })
        .collect()
}

/// The nearest front-facing hit of `ray` over every posed triangle.
fn brute_force(ray: Ray3d, posed: &[(Entity, Vec<[Vec3; 3]>)]) -> Option<(Entity, f32)> {
    let r = Ray::new(ray.origin, *ray.direction);
    let mut best: Option<(Entity, f32)> = None;
    for (entity, tris) in posed {
        for t in tris {
            let tri = Triangle::new(t[0], t[1], t[2]);
            if let Some(hit) = tri.intersect(&r, Backfaces::Cull)
                && best.is_none_or(|(_, d)| hit.t < d)
            {
                best = Some((*entity, hit.t));
            }
        }
    }
    best
}

/// A ray from `distance` away, in a random direction whose upward part lies in `rise`, at a
/// random point of triangle `t` (barycentrics each below `reach`, clipped to the triangle).
fn ray_at(
    rng: &mut Rng,
    t: [Vec3; 3],
    reach: f32,
    rise: (f32, f32),
    distance: f32,
) -> Option<Ray3d> {
    let (a, b) = (rng.f32() * reach, rng.f32() * reach);
    let (a, b) = if a + b > 1.0 {
        (1.0 - a, 1.0 - b)
    } else {
        (a, b)
    };
    let target = t[0] + (t[1] - t[0]) * a + (t[2] - t[0]) * b;
    let away = Vec3::new(
        rng.range(-1.0, 1.0),
        rng.range(rise.0, rise.1),
        rng.range(-1.0, 1.0),
    )
    .normalize_or(Vec3::Y);
    let from = target + away * distance;
    Some(Ray3d::new(from, Dir3::new(target - from).ok()?))
}

/// The nearest hit of `ray` through `AccelRayCast` (any visibility).
fn ours(app: &mut App, ray: Ray3d) -> Option<(Entity, f32)> {
    app.world_mut()
        .run_system_once(move |mut ours: AccelRayCast| {
            let any = MeshRayCastSettings::default().with_visibility(RayCastVisibility::Any);
            ours.cast_ray(ray, &any)
                .first()
                .map(|(e, h)| (*e, h.distance))
        })
        .unwrap()
}

/// The same first hit: the same entity at the same distance (within rounding).
fn same(got: Option<(Entity, f32)>, want: Option<(Entity, f32)>) -> bool {
    match (got, want) {
        (None, None) => true,
        (Some((e, d)), Some((we, wd))) => e == we && (d - wd).abs() <= 1e-4 * wd.max(1.0),
        _ => false,
    }
}

#[test]
fn posed_skinned_meshes_are_picked_where_they_are_drawn() {
    check_posed_picking(false, Change::None);
}

/// With Bevy's `DynamicSkinnedMeshBounds`, characters whose weights are glTF's are found by
/// the trees through Bevy's posed box and posed only when reached; the others (weights not
/// summing to one) keep the plugin's own broad phase. Both answer as the brute force.
#[test]
fn characters_with_bevys_posed_bounds_are_found_by_the_trees() {
    check_posed_picking(true, Change::None);
}

/// Characters that lose Bevy's `DynamicSkinnedMeshBounds` mid-run (their `Aabb` back to the
/// bind pose's) go back to the plugin's own broad phase from the next ray: the list of
/// entities a ray poses itself is made again.
#[test]
fn characters_that_lose_bevys_posed_bounds_keep_being_picked() {
    check_posed_picking(true, Change::DropBevyBounds(3));
}

/// What changes on every character at a frame of [`check_posed_picking`].
#[derive(Clone, Copy, PartialEq)]
enum Change {
    None,
    /// `DynamicSkinnedMeshBounds` removed, the `Aabb` back to the bind pose's.
    DropBevyBounds(usize),
}

fn check_posed_picking(dynamic_bounds: bool, change: Change) {
    let mut app = common::app();
    let c = character(Detail::for_triangles(2_000));
    let mut rng = Rng::new(73);
    let chars = spawn_characters(&mut app, &c, &mut rng, dynamic_bounds);
    let rest = accel_testkit::skinned::rest_pose();
    let (mut rays, mut ours_wrong, mut bevy_wrong, mut hits) = (0, 0, 0, 0);
    for frame in 0..6 {
        // A new random pose for every joint of every character (the first frame: rest).
        if frame > 0 {
            for ch in &chars {
                // Every other frame a large breath, on some characters.
                let breath =
                    if !dynamic_bounds && (frame + ch.joints.len()) % 2 == 0 && rng.below(2) == 0 {
                        rng.range(-8.0, 8.0)
                    } else {
                        0.0
                    };
                *app.world_mut()
                    .get_mut::<MeshMorphWeights>(ch.mesh)
                    .unwrap() = MeshMorphWeights::Value {
                    weights: vec![breath],
                };
                for (k, &joint) in ch.joints.iter().enumerate() {
                    let local = random_local(&mut rng, rest[k].translation);
                    *app.world_mut().get_mut::<Transform>(joint).unwrap() = local;
                }
            }
        }
        if change == Change::DropBevyBounds(frame) {
            for ch in &chars {
                let handle = app.world().get::<Mesh3d>(ch.mesh).unwrap().0.clone();
                let bind_pose = app
                    .world()
                    .resource::<Assets<Mesh>>()
                    .get(&handle)
                    .and_then(Mesh::compute_aabb)
                    .unwrap();
                app.world_mut()
                    .entity_mut(ch.mesh)
                    .remove::<bevy::camera::visibility::DynamicSkinnedMeshBounds>()
                    .insert(bind_pose);
            }
        }
        app.update();
        let posed = posed_triangles(&app, &c, &chars);
        for _ in 0..60 {
            // A ray aimed at a random point of a random posed triangle.
            let (_, tris) = &posed[rng.below(posed.len())];
            let t = tris[rng.below(tris.len())];
            let Some(ray) = ray_at(&mut rng, t, 1.0, (-0.3, 1.0), 12.0) else {
                continue;
            };
            let want = brute_force(ray, &posed);
            let ours = ours(&mut app, ray);
            let bevys = app
                .world_mut()
                .run_system_once(move |mut bevy: MeshRayCast| {
                    let any =
                        MeshRayCastSettings::default().with_visibility(RayCastVisibility::Any);
                    bevy.cast_ray(ray, &any)
                        .first()
                        .map(|(e, h)| (*e, h.distance))
                })
                .unwrap();
            rays += 1;
            hits += want.is_some() as usize;
            if !same(ours, want) {
                ours_wrong += 1;
                eprintln!("frame {frame}: ours {ours:?}, want {want:?}");
            }
            bevy_wrong += !same(bevys, want) as usize;
        }
    }
    assert!(hits * 2 > rays, "too few rays hit: {hits} of {rays}");
    assert_eq!(ours_wrong, 0, "{ours_wrong} of {rays} rays wrong");
    // Bevy's bind-pose test is wrong on most rays of posed frames: the oracle tells poses
    // apart.
    assert!(
        bevy_wrong * 3 > rays,
        "Bevy wrong on only {bevy_wrong} of {rays}"
    );
    let posed = app
        .world()
        .resource::<bevy_accel::picking::AccelPosedMeshes>()
        .len();
    assert!(posed <= chars.len() && posed > 0, "{posed} posed");
}

#[test]
fn a_skin_without_bindposes_is_picked_on_its_bind_pose_without_panicking() {
    let mut app = common::app();
    let c = character(Detail::for_triangles(2_000));
    let mesh = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(bevy_mesh(&c, &c.weights));
    let joint = app.world_mut().spawn(Transform::IDENTITY).id();
    // A handle to bindposes that were never added, and a single joint for a 15-joint mesh.
    let entity = app
        .world_mut()
        .spawn((
            Mesh3d(mesh),
            SkinnedMesh {
                inverse_bindposes: Handle::default(),
                joints: vec![joint],
            },
            Transform::IDENTITY,
            Visibility::Visible,
            Aabb::from_min_max(Vec3::splat(-2.0), Vec3::splat(2.0)),
        ))
        .id();
    app.update();
    let ray = Ray3d::new(Vec3::new(0.0, 1.0, 10.0), Dir3::NEG_Z);
    let hit = app
        .world_mut()
        .run_system_once(move |mut ours: AccelRayCast| {
            let any = MeshRayCastSettings::default().with_visibility(RayCastVisibility::Any);
            ours.cast_ray(ray, &any).first().map(|(e, _)| *e)
        })
        .unwrap();
    let tracked = app.world().resource::<AccelTrees>().len();
    let bevys = app
        .world_mut()
        .run_system_once(move |mut bevy: MeshRayCast| {
            let any = MeshRayCastSettings::default().with_visibility(RayCastVisibility::Any);
            bevy.cast_ray(ray, &any).first().map(|(e, _)| *e)
        })
        .unwrap();
    assert_eq!(
        hit,
        Some(entity),
        "the bind pose is hit ({tracked} tracked; Bevy: {bevys:?})"
    );
}

#[test]
fn morph_only_meshes_are_picked_at_their_morphed_vertices() {
    let mut app = common::app();
    let c = character(Detail::for_triangles(2_000));
    let mesh = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(bevy_mesh(&c, &c.weights));
    let transform = Transform::from_xyz(1.0, -0.5, 2.0)
        .with_rotation(Quat::from_rotation_y(0.7))
        .with_scale(Vec3::new(1.3, 0.8, -1.1));
    let mut rng = Rng::new(74);
    let entity = app
        .world_mut()
        .spawn((
            Mesh3d(mesh),
            transform,
            Visibility::Visible,
            MeshMorphWeights::Value { weights: vec![0.0] },
        ))
        .id();
    let (mut rays, mut hits, mut unmorphed_wrong) = (0, 0, 0);
    for frame in 0..4 {
        let breath = if frame == 0 {
            0.0
        } else {
            rng.range(-8.0, 8.0)
        };
        *app.world_mut().get_mut::<MeshMorphWeights>(entity).unwrap() = MeshMorphWeights::Value {
            weights: vec![breath],
        };
        app.update();
        let world = Mat4::from(app.world().get::<GlobalTransform>(entity).unwrap().affine());
        let pose = |w: f32| -> Vec<(Entity, Vec<[Vec3; 3]>)> {
            let tris = c
                .indices
                .chunks_exact(3)
                .map(|t| {
                    [0, 1, 2].map(|k| {
                        let v = t[k] as usize;
                        world.transform_point3(c.positions[v] + w * c.breathe[v])
                    })
                })
                .collect();
            vec![(entity, tris)]
        };
        let (posed, unmorphed) = (pose(breath), pose(0.0));
        for _ in 0..80 {
            let t = posed[0].1[rng.below(posed[0].1.len())];
            let Some(ray) = ray_at(&mut rng, t, 0.5, (-1.0, 1.0), 10.0) else {
                continue;
            };
            let want = brute_force(ray, &posed);
            let ours = ours(&mut app, ray);
            rays += 1;
            hits += want.is_some() as usize;
            assert!(
                same(ours, want),
                "frame {frame}: ours {ours:?}, want {want:?}"
            );
            unmorphed_wrong += !same(brute_force(ray, &unmorphed), want) as usize;
        }
    }
    assert!(hits * 2 > rays, "too few rays hit: {hits} of {rays}");
    // The unmorphed mesh answers many of the same rays otherwise: the test tells them apart.
    assert!(
        unmorphed_wrong > 10,
        "unmorphed wrong on only {unmorphed_wrong} of {rays}"
    );
}
