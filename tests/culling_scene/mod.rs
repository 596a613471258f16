//! What the culling equivalence tests share: the two apps (Bevy's own culling and the
//! plugin's), the test entities' visibility class, hand-made frusta, and the visible sets
//! and `ViewVisibility` changes compared between the apps. Each test file uses part of it.
#![allow(dead_code)]

use bevy::camera::primitives::{Aabb, Frustum};
use bevy::camera::visibility::{VisibilityClass, VisibleEntities};
use bevy::math::primitives::ViewFrustum;
use bevy::prelude::*;
use bevy_accel::AccelCullingPlugin;
use std::any::TypeId;

use crate::common::{grid_point, headless_app};

/// Which of the test's cameras a view is (query order differs between the two apps).
#[derive(Component)]
pub struct ViewIndex(pub usize);

/// The visibility class the test entities belong to (stands for `Mesh3d`).
#[derive(Component, Default)]
pub struct Drawable;

pub fn app(ours: bool) -> App {
    let mut app = headless_app();
    if ours {
        app.add_plugins(AccelCullingPlugin);
    }
    app.finish();
    app
}

pub fn frustum(eye: Vec3, target: Vec3, fov: f32) -> Frustum {
    let view = Mat4::look_at_rh(eye, target, Vec3::Y);
    let proj = Mat4::perspective_infinite_reverse_rh(fov, 1.5, 0.1);
    Frustum(ViewFrustum::from_clip_from_world(&(proj * view)))
}

/// Per view, the visible entities as indices into the spawn order (entity ids differ between
/// the two apps: plugins spawn observers), and each entity's `ViewVisibility`.
/// Despawned entities have no flag.
pub fn visible_sets(app: &mut App, entities: &[Entity]) -> (Vec<Vec<usize>>, Vec<Option<bool>>) {
    let index: std::collections::HashMap<Entity, usize> =
        entities.iter().enumerate().map(|(i, e)| (*e, i)).collect();
    let world = app.world_mut();
    let mut views = world.query::<(&ViewIndex, &VisibleEntities)>();
    let mut views: Vec<(&ViewIndex, &VisibleEntities)> = views.iter(world).collect();
    views.sort_by_key(|(i, _)| i.0);
    let lists = views
        .into_iter()
        .map(|(_, v)| {
            let mut l: Vec<usize> = v
                .get(TypeId::of::<Drawable>())
                .iter()
                .map(|e| index[e])
                .collect();
            l.sort_unstable();
            l
        })
        .collect();
    let flags = entities
        .iter()
        .map(|&e| world.get::<ViewVisibility>(e).map(|v| v.get()))
        .collect();
    (lists, flags)
}

/// The visibility class of `Drawable` entities.
pub fn drawable_class() -> VisibilityClass {
    let mut class = VisibilityClass::default();
    class.push(TypeId::of::<Drawable>());
    class
}

/// A visible `Drawable` cube of half side `half` at `at`.
pub fn spawn_drawable<'w>(
    world: &'w mut World,
    class: &VisibilityClass,
    at: Vec3,
    half: f32,
) -> EntityWorldMut<'w> {
    world.spawn((
        Transform::from_translation(at),
        Visibility::Inherited,
        class.clone(),
        Drawable,
        Aabb::from_min_max(Vec3::splat(-half), Vec3::splat(half)),
    ))
}

/// A marker that moves an entity to another table when inserted or removed.
#[derive(Component)]
pub struct Moved;

/// The entities whose `ViewVisibility` changed in the frame, as change detection reports them.
#[derive(Resource, Default)]
pub struct ChangedVisibility(pub Vec<Entity>);

pub fn record_changed_visibility(
    changed: Query<Entity, Changed<ViewVisibility>>,
    mut record: ResMut<ChangedVisibility>,
) {
    record.0 = changed.iter().collect();
}

/// [`ChangedVisibility`] as sorted indices into the spawn order.
pub fn changed_indices(app: &App, entities: &[Entity]) -> Vec<usize> {
    let index: std::collections::HashMap<Entity, usize> =
        entities.iter().enumerate().map(|(i, e)| (*e, i)).collect();
    let mut changed: Vec<usize> = app
        .world()
        .resource::<ChangedVisibility>()
        .0
        .iter()
        .filter_map(|e| index.get(e).copied())
        .collect();
    changed.sort_unstable();
    changed
}

/// A cube of `side`³ visible `Drawable` cubes of half side `half` on the test kit's grid, in
/// spawn order, each given its test's extras by `decorate` (its index, its entity).
pub fn spawn_grid(
    world: &mut World,
    side: usize,
    half: f32,
    mut decorate: impl FnMut(usize, &mut EntityWorldMut),
) -> Vec<Entity> {
    let class = drawable_class();
    (0..side * side * side)
        .map(|i| {
            let mut e = spawn_drawable(world, &class, grid_point(i, side), half);
            decorate(i, &mut e);
            e.id()
        })
        .collect()
}

/// Asserts that both apps culled alike this frame: the same visible sets, `ViewVisibility`
/// flags and changes of them. Returns Bevy's visible sets, for the test's own checks.
pub fn assert_culled_alike(
    (bevy, a): (&mut App, &[Entity]),
    (accel, b): (&mut App, &[Entity]),
    frame: usize,
) -> Vec<Vec<usize>> {
    let (bevy_lists, bevy_flags) = visible_sets(bevy, a);
    let (accel_lists, accel_flags) = visible_sets(accel, b);
    assert_eq!(bevy_lists, accel_lists, "frame {frame}");
    assert_eq!(bevy_flags, accel_flags, "frame {frame}");
    assert_eq!(
        changed_indices(bevy, a),
        changed_indices(accel, b),
        "frame {frame}: entities whose ViewVisibility changed"
    );
    bevy_lists
}
