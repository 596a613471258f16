//! The skinned suite's apps: a crowd of the test kit's walking characters on a grid, every
//! joint animated every frame, and one app per contender over the very same crowd; the
//! pointer ray of each frame and the three ways to cast it (ours, Bevy's `MeshRayCast`, and
//! the peer that bakes the posed mesh per cast as Bevy PR 23583 does).

use crate::suites::headless_app;
use accel_testkit::Rng;
use accel_testkit::bevy_apps::plain_bevy_app;
use accel_testkit::skinned::{
    Detail, JOINT_COUNT, JOINT_PARENTS, SkinnedCharacter, character, rest_pose, walk_pose,
};
use bevy::asset::RenderAssetUsages;
use bevy::camera::primitives::Aabb;
use bevy::camera::visibility::DynamicSkinnedMeshBounds;
use bevy::math::bounding::Aabb3d;
use bevy::math::{Affine3A, Mat3A, Vec3A};
use bevy::mesh::skinning::{SkinnedMesh, SkinnedMeshInverseBindposes};
use bevy::mesh::{Indices, PrimitiveTopology, VertexAttributeValues};
use bevy::picking::mesh_picking::ray_cast::{
    Backfaces, MeshRayCast, MeshRayCastSettings, RayCastVisibility, ray_aabb_intersection_3d,
    ray_mesh_intersection,
};
use bevy::prelude::*;
use bevy_accel::prelude::*;
use std::time::Instant;

/// Metres between neighbouring characters of the grid.
const SPACING: f32 = 2.5;

/// Seconds of walk per frame (60 frames a second).
const FRAME_SECONDS: f32 = 1.0 / 60.0;

/// Height of the torso's middle above a character's feet (the chest joint is at 1.32 m in
/// the rest pose, the hips at 0.95 m).
const TORSO_HEIGHT: f32 = 1.15;

/// One scene: how many characters, how finely tessellated, and Bevy's bounds for them.
#[derive(Clone, Copy, Debug)]
pub struct Scene {
    /// Characters on the grid.
    pub characters: usize,
    /// Triangles of each character (the test kit's nearest detail).
    pub triangles: u32,
    /// Every skinned entity with Bevy's `DynamicSkinnedMeshBounds` (what Bevy's glTF loader
    /// gives skinned meshes by default): its `Aabb` follows the pose every frame. Without
    /// it the `Aabb` is the bind pose's, as for a mesh built in code.
    pub dynamic_bounds: bool,
}

impl Scene {
    /// Its name in the report.
    pub fn name(self, triangles: usize) -> String {
        format!(
            "{} characters of {triangles} triangles, {} Aabb",
            self.characters,
            if self.dynamic_bounds {
                "posed (DynamicSkinnedMeshBounds)"
            } else {
                "bind-pose"
            }
        )
    }
}

/// One app of a scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Contender {
    /// Plain Bevy, no bevy_accel, no ray.
    Plain,
    /// `AccelPlugin` without `AccelPickingPlugin` (skinned picking off), no ray.
    PickingOff,
    /// `AccelPlugin` and `AccelPickingPlugin`, no ray.
    Picking,
    /// The same with one `AccelRayCast::cast_ray` a frame.
    Ours,
    /// Plain Bevy with one `MeshRayCast::cast_ray` a frame.
    Bevy,
    /// Plain Bevy with one ray a frame through the baking peer.
    Baking,
}

impl Contender {
    /// Every contender, in the order the apps are updated.
    pub const ALL: [Self; 6] = [
        Self::Plain,
        Self::PickingOff,
        Self::Picking,
        Self::Ours,
        Self::Bevy,
        Self::Baking,
    ];

    /// Its name in the report.
    pub fn label(self) -> &'static str {
        match self {
            Self::Plain => "bevy, no bevy_accel, no ray",
            Self::PickingOff => "AccelPlugin, picking off, no ray",
            Self::Picking => "AccelPlugin + AccelPickingPlugin, no ray",
            Self::Ours => "AccelRayCast",
            Self::Bevy => "MeshRayCast",
            Self::Baking => "baking per cast (PR 23583)",
        }
    }

    /// Whether the app casts the pointer ray.
    pub fn casts(self) -> bool {
        matches!(self, Self::Ours | Self::Bevy | Self::Baking)
    }
}

/// Frames run so far (counted in `First`): the walk and the pointer ray follow it, so every
/// app of a scene poses and casts alike.
#[derive(Resource, Default)]
struct Clock(u32);

/// A character's root: its phase in the walk and its joints, parents first.
#[derive(Component)]
struct Walker {
    phase: f32,
    joints: [Entity; JOINT_COUNT],
}

/// A joint of a walker (the animation writes only these transforms).
#[derive(Component)]
struct Joint;

/// Which character a skinned mesh entity is, to compare hits across apps.
#[derive(Component)]
struct CharacterIndex(u32);

/// The pointer rays, one per frame (the `k`th frame, counted from 1, casts `rays[k - 1]`,
/// repeating after the last).
#[derive(Resource)]
struct PointerRays(Vec<Ray3d>);

impl PointerRays {
    fn at(&self, clock: &Clock) -> Ray3d {
        self.0[(clock.0 as usize).saturating_sub(1) % self.0.len()]
    }
}

/// What the cast of each frame gave: its time, the character it hit first, and (ours) the
/// posed trees refit for it.
#[derive(Resource, Default)]
pub struct Picks {
    /// Microseconds of the cast, one per frame.
    pub us: Vec<f64>,
    /// The character hit first and the hit's distance along the ray, one per frame.
    pub hits: Vec<Option<(u32, f32)>>,
    /// Posed trees built or refit by the cast (ours only), one per frame.
    pub refits: Vec<usize>,
    /// With [`Breakdown`] on (ours only): per frame, microseconds of a ray that reaches no
    /// character (the joints' read at the run's first ray), then of the pointer ray (the
    /// refit and the walk), then of the pointer ray again (the walk alone).
    pub breakdown: Vec<[f64; 3]>,
}

impl Picks {
    /// Forgets the warm-up's casts.
    pub fn clear(&mut self) {
        *self = Self::default();
    }
}

/// Ours only: cast a ray that misses every character before the pointer ray, and the pointer
/// ray twice, to see where the time of a pick goes (see [`Picks::breakdown`]).
#[derive(Resource, Default)]
pub struct Breakdown(pub bool);

/// What every cast is asked for: every entity whatever its visibility (the headless apps
/// have no camera), the nearest hit.
fn settings() -> MeshRayCastSettings<'static> {
    MeshRayCastSettings::default().with_visibility(RayCastVisibility::Any)
}

fn count_frame(mut clock: ResMut<Clock>) {
    clock.0 += 1;
}

/// Writes `walk_pose(t + phase)` into every joint of every character.
fn walk(
    clock: Res<Clock>,
    walkers: Query<&Walker>,
    mut joints: Query<&mut Transform, With<Joint>>,
) {
    let t = clock.0 as f32 * FRAME_SECONDS;
    for walker in &walkers {
        let pose = walk_pose(t + walker.phase);
        for (&joint, local) in walker.joints.iter().zip(&pose) {
            if let Ok(mut transform) = joints.get_mut(joint) {
                *transform = Transform {
                    translation: local.translation,
                    rotation: local.rotation,
                    scale: local.scale,
                };
            }
        }
    }
}

fn micros(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e6
}

/// The character hit first and the distance, if any.
fn first_character(
    hit: Option<(Entity, f32)>,
    index: &Query<&CharacterIndex>,
) -> Option<(u32, f32)> {
    hit.and_then(|(e, d)| index.get(e).ok().map(|i| (i.0, d)))
}

fn cast_ours(
    mut cast: AccelRayCast,
    (clock, rays, breakdown): (Res<Clock>, Res<PointerRays>, Res<Breakdown>),
    index: Query<&CharacterIndex>,
    mut picks: ResMut<Picks>,
) {
    let ray = rays.at(&clock);
    let settings = settings();
    if breakdown.0 {
        // Straight up from the pointer's origin, above every character: the run's first ray
        // reads every skinned entity's joints and reaches none.
        let sky = Ray3d::new(ray.origin, Dir3::Y);
        let start = Instant::now();
        std::hint::black_box(cast.cast_ray(sky, &settings).len());
        let joints = micros(start);
        let start = Instant::now();
        std::hint::black_box(cast.cast_ray(ray, &settings).len());
        let refit_and_walk = micros(start);
        let start = Instant::now();
        std::hint::black_box(cast.cast_ray(ray, &settings).len());
        let walk = micros(start);
        picks.breakdown.push([joints, refit_and_walk, walk]);
        cast.take_posed_refits();
        return;
    }
    let start = Instant::now();
    let hit = cast
        .cast_ray(ray, &settings)
        .first()
        .map(|h| (h.0, h.1.distance));
    let us = micros(start);
    picks.us.push(us);
    picks.hits.push(first_character(hit, &index));
    picks.refits.push(cast.take_posed_refits());
}

fn cast_bevy(
    mut cast: MeshRayCast,
    (clock, rays): (Res<Clock>, Res<PointerRays>),
    index: Query<&CharacterIndex>,
    mut picks: ResMut<Picks>,
) {
    let ray = rays.at(&clock);
    let settings = settings();
    let start = Instant::now();
    let hit = cast
        .cast_ray(ray, &settings)
        .first()
        .map(|h| (h.0, h.1.distance));
    let us = micros(start);
    picks.us.push(us);
    picks.hits.push(first_character(hit, &index));
}

/// A skinned entity as Bevy's broad phase and the baking peer read it.
type SkinnedCandidate = (
    Entity,
    &'static Aabb,
    &'static GlobalTransform,
    &'static Mesh3d,
    &'static SkinnedMesh,
);

/// The baking peer: Bevy's `MeshRayCast` with PR 23583's skinned path. Bevy's broad phase
/// (the ray against every entity's `Aabb` under its `GlobalTransform`, candidates by entry
/// distance, none entered beyond the nearest hit so far), then for each candidate a posed
/// `Mesh` baked from the joints ([`bake_posed_mesh`]) and Bevy's `ray_mesh_intersection` over
/// its triangles, as `MeshRayCast` runs over any mesh.
#[allow(clippy::too_many_arguments)]
fn cast_baking(
    (clock, rays): (Res<Clock>, Res<PointerRays>),
    meshes: Res<Assets<Mesh>>,
    bindposes: Res<Assets<SkinnedMeshInverseBindposes>>,
    candidates: Query<SkinnedCandidate>,
    joints: Query<&GlobalTransform>,
    index: Query<&CharacterIndex>,
    mut culled: Local<Vec<(f32, Entity)>>,
    mut picks: ResMut<Picks>,
) {
    let ray = rays.at(&clock);
    let start = Instant::now();
    culled.clear();
    culled.extend(
        candidates
            .iter()
            .filter_map(|(entity, aabb, transform, ..)| {
                let bounds = Aabb3d::new(aabb.center, aabb.half_extents);
                ray_aabb_intersection_3d(ray, &bounds, &transform.affine()).map(|d| (d, entity))
            }),
    );
    culled.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut nearest: Option<(f32, Entity)> = None;
    for &(entry, entity) in culled.iter() {
        if nearest.is_some_and(|(d, _)| entry > d) {
            continue;
        }
        let Ok((_, _, transform, mesh, skin)) = candidates.get(entity) else {
            continue;
        };
        let (Some(mesh), Some(bindposes)) =
            (meshes.get(mesh), bindposes.get(&skin.inverse_bindposes))
        else {
            continue;
        };
        let Some(posed) = bake_posed_mesh(mesh, transform, skin, bindposes, &joints) else {
            continue;
        };
        if let Some(hit) = cast_over_mesh(&posed, &transform.affine(), ray)
            && nearest.is_none_or(|(d, _)| hit < d)
        {
            nearest = Some((hit, entity));
        }
    }
    let us = micros(start);
    picks.us.push(us);
    picks
        .hits
        .push(first_character(nearest.map(|(d, e)| (e, d)), &index));
}

/// PR 23583's `skin_mesh_entity`: the skin's joints as `mesh_from_world * world_from_joint *
/// inverse_bindpose`, then [`skin_mesh`]. `None` where the skin cannot be read.
fn bake_posed_mesh(
    input: &Mesh,
    world_from_mesh: &GlobalTransform,
    skin: &SkinnedMesh,
    inverse_bindposes: &SkinnedMeshInverseBindposes,
    joints: &Query<&GlobalTransform>,
) -> Option<Mesh> {
    if skin.joints.len() != inverse_bindposes.len() {
        return None;
    }
    let mesh_from_world = world_from_mesh.affine().inverse();
    let matrices: Vec<Affine3A> = skin
        .joints
        .iter()
        .zip(inverse_bindposes.iter())
        .map(|(&joint, inverse_bind)| {
            let world_from_joint = joints.get(joint).ok()?.affine();
            Some(mesh_from_world * world_from_joint * Affine3A::from_mat4(*inverse_bind))
        })
        .collect::<Option<_>>()?;
    skin_mesh(input, &matrices)
}

/// PR 23583's `skin_mesh`: a new `Mesh`, in the input's own space, whose positions and
/// normals are skinned by `mesh_from_mesh_bindpose` (each vertex by the weighted sum of its
/// joints' matrices, as Bevy's skinning shader; normals by that sum's inverse transpose), with
/// the input's indices and its other attributes copied, the joint indices and weights left
/// out. `None` where the skin cannot be read.
pub fn skin_mesh(input: &Mesh, mesh_from_mesh_bindpose: &[Affine3A]) -> Option<Mesh> {
    let Some(VertexAttributeValues::Uint16x4(joint_indices)) =
        input.attribute(Mesh::ATTRIBUTE_JOINT_INDEX)
    else {
        return None;
    };
    let Some(VertexAttributeValues::Float32x4(joint_weights)) =
        input.attribute(Mesh::ATTRIBUTE_JOINT_WEIGHT)
    else {
        return None;
    };
    let float3 = |id| match input.attribute(id) {
        Some(VertexAttributeValues::Float32x3(values)) => Some(values.clone()),
        _ => None,
    };
    let mut positions = float3(Mesh::ATTRIBUTE_POSITION)?;
    let mut normals = float3(Mesh::ATTRIBUTE_NORMAL);
    for (v, (indices, weights)) in joint_indices.iter().zip(joint_weights).enumerate() {
        let mut matrix3 = Mat3A::ZERO;
        let mut translation = Vec3A::ZERO;
        for (&j, &w) in indices.iter().zip(weights) {
            let m = mesh_from_mesh_bindpose.get(usize::from(j))?;
            matrix3 += m.matrix3 * w;
            translation += m.translation * w;
        }
        let skin = Affine3A {
            matrix3,
            translation,
        };
        let p = positions.get_mut(v)?;
        *p = skin.transform_point3a(Vec3A::from(*p)).into();
        if let Some(n) = normals.as_mut().and_then(|n| n.get_mut(v)) {
            let skinned = matrix3.inverse().transpose() * Vec3A::from(*n);
            *n = skinned.normalize_or_zero().into();
        }
    }
    let mut output = Mesh::new(input.primitive_topology(), input.asset_usage);
    if let Some(indices) = input.indices() {
        output.insert_indices(indices.clone());
    }
    for (attribute, values) in input.attributes() {
        if ![
            Mesh::ATTRIBUTE_POSITION.id,
            Mesh::ATTRIBUTE_NORMAL.id,
            Mesh::ATTRIBUTE_TANGENT.id,
            Mesh::ATTRIBUTE_JOINT_INDEX.id,
            Mesh::ATTRIBUTE_JOINT_WEIGHT.id,
        ]
        .contains(&attribute.id)
        {
            output.insert_attribute(*attribute, values.clone());
        }
    }
    output.insert_attribute(Mesh::ATTRIBUTE_POSITION, positions);
    if let Some(normals) = normals {
        output.insert_attribute(Mesh::ATTRIBUTE_NORMAL, normals);
    }
    Some(output)
}

/// The nearest front-facing hit distance of `ray` on `mesh` under `transform`, by Bevy's
/// `ray_mesh_intersection` (what `MeshRayCast` runs over every candidate's mesh).
pub fn cast_over_mesh(mesh: &Mesh, transform: &Affine3A, ray: Ray3d) -> Option<f32> {
    let positions = mesh.attribute(Mesh::ATTRIBUTE_POSITION)?.as_float3()?;
    let normals = mesh
        .attribute(Mesh::ATTRIBUTE_NORMAL)
        .and_then(VertexAttributeValues::as_float3);
    let uvs = match mesh.attribute(Mesh::ATTRIBUTE_UV_0) {
        Some(VertexAttributeValues::Float32x2(uvs)) => Some(uvs.as_slice()),
        _ => None,
    };
    let hit = match mesh.indices() {
        Some(Indices::U16(i)) => ray_mesh_intersection(
            ray,
            transform,
            positions,
            normals,
            Some(i),
            uvs,
            Backfaces::Cull,
        ),
        Some(Indices::U32(i)) => ray_mesh_intersection(
            ray,
            transform,
            positions,
            normals,
            Some(i),
            uvs,
            Backfaces::Cull,
        ),
        None => ray_mesh_intersection::<usize>(
            ray,
            transform,
            positions,
            normals,
            None,
            uvs,
            Backfaces::Cull,
        ),
    };
    hit.map(|h| h.distance)
}

/// The character mesh as Bevy holds it.
pub fn bevy_mesh(c: &SkinnedCharacter) -> Mesh {
    Mesh::new(PrimitiveTopology::TriangleList, RenderAssetUsages::all())
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, c.positions.clone())
        .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, c.normals.clone())
        .with_inserted_attribute(
            Mesh::ATTRIBUTE_JOINT_INDEX,
            VertexAttributeValues::Uint16x4(c.joints.clone()),
        )
        .with_inserted_attribute(Mesh::ATTRIBUTE_JOINT_WEIGHT, c.weights.clone())
        .with_inserted_indices(Indices::U32(c.indices.clone()))
}

/// Characters per row of the grid.
fn per_row(n: usize) -> usize {
    (n as f32).sqrt().ceil() as usize
}

/// Where character `i` stands (its feet).
fn home(i: usize, n: usize) -> Vec3 {
    let row = per_row(n);
    Vec3::new((i % row) as f32, 0.0, (i / row) as f32) * SPACING
}

/// `frames` pointer rays, from a camera above the grid's front edge (the characters face it)
/// towards a character's torso: the first `n` through every character in turn (the warm-up:
/// each character's posed tree is built at the first ray that reaches it), then each
/// towards a character drawn at random (seeded).
fn pointer_rays(n: usize, frames: usize) -> Vec<Ray3d> {
    let side = per_row(n) as f32 * SPACING;
    let eye = Vec3::new(side / 2.0, 6.0 + side * 0.3, side + 8.0);
    let mut rng = Rng::new(0x5c1d);
    (0..frames.max(1))
        .map(|k| {
            let i = if k < n { k } else { rng.below(n) };
            let target = home(i, n) + Vec3::Y * TORSO_HEIGHT;
            Ray3d::new(eye, Dir3::new(target - eye).unwrap_or(Dir3::NEG_Y))
        })
        .collect()
}

/// The character mesh of `triangles` (the nearest the test kit makes).
pub fn character_of(triangles: u32) -> SkinnedCharacter {
    character(Detail::for_triangles(triangles))
}

/// The app of `contender` over `scene`, finished and updated once (that frame casts the first
/// ray). Every app spawns the same crowd in the same order from the same seed, so all of a
/// scene's apps hold the same world; `frames` pointer rays are drawn for it (see
/// [`pointer_rays`]; they repeat after that).
pub fn build_app(contender: Contender, scene: Scene, c: &SkinnedCharacter, frames: usize) -> App {
    let mut app = match contender {
        Contender::Plain | Contender::Bevy | Contender::Baking => plain_bevy_app(),
        Contender::PickingOff | Contender::Picking | Contender::Ours => headless_app(),
    };
    if matches!(contender, Contender::Picking | Contender::Ours) {
        app.add_plugins(AccelPickingPlugin);
    }
    app.init_resource::<Clock>()
        .init_resource::<Picks>()
        .init_resource::<Breakdown>()
        .insert_resource(PointerRays(pointer_rays(scene.characters, frames)))
        .add_systems(First, count_frame)
        .add_systems(Update, walk);
    // In `PreUpdate`, as the picking backends cast: the joints posed by the last frame's
    // `Update` and propagated in its `PostUpdate`.
    match contender {
        Contender::Ours => {
            app.add_systems(PreUpdate, cast_ours);
        }
        Contender::Bevy => {
            app.add_systems(PreUpdate, cast_bevy);
        }
        Contender::Baking => {
            app.add_systems(PreUpdate, cast_baking);
        }
        _ => {}
    }
    app.finish();
    spawn_crowd(app.world_mut(), scene, c);
    app.update();
    app
}

/// The crowd: every character a root at its grid point (turned a little at random), its 15
/// joints under it as `JOINT_PARENTS` says, and the skinned mesh entity under the root, all
/// characters sharing one mesh and one set of inverse bindposes.
fn spawn_crowd(world: &mut World, scene: Scene, c: &SkinnedCharacter) {
    let mut mesh = bevy_mesh(c);
    if scene.dynamic_bounds {
        mesh.generate_skinned_mesh_bounds()
            .expect("the character's skin has bounds");
    }
    let mesh = world.resource_mut::<Assets<Mesh>>().add(mesh);
    let bindposes = world
        .resource_mut::<Assets<SkinnedMeshInverseBindposes>>()
        .add(SkinnedMeshInverseBindposes::from(c.inverse_bind.clone()));
    let rest = rest_pose();
    let mut rng = Rng::new(0x7a1c);
    let n = scene.characters;
    for i in 0..n {
        let phase = rng.f32();
        let turn = rng.range(-0.4, 0.4);
        let root = world
            .spawn(
                Transform::from_translation(home(i, n)).with_rotation(Quat::from_rotation_y(turn)),
            )
            .id();
        let mut joints = [Entity::PLACEHOLDER; JOINT_COUNT];
        for (k, parent) in JOINT_PARENTS.iter().enumerate() {
            let parent = parent.map_or(root, |p| joints[p]);
            let local = Transform {
                translation: rest[k].translation,
                rotation: rest[k].rotation,
                scale: rest[k].scale,
            };
            joints[k] = world.spawn((local, Joint, ChildOf(parent))).id();
        }
        world.entity_mut(root).insert(Walker { phase, joints });
        let mut entity = world.spawn((
            Mesh3d(mesh.clone()),
            SkinnedMesh {
                inverse_bindposes: bindposes.clone(),
                joints: joints.to_vec(),
            },
            Transform::IDENTITY,
            Visibility::Visible,
            ChildOf(root),
            CharacterIndex(i as u32),
        ));
        if scene.dynamic_bounds {
            entity.insert(DynamicSkinnedMeshBounds);
        }
    }
}
