//! A `bevy_picking` backend for sprites on the trees (cargo feature `sprite_picking`).
//!
//! Bevy's sprite backend sorts every pickable sprite by depth each frame and tests each
//! pointer against them in turn, so its cost follows the number of sprites, on screen or
//! not. Here each pointer's ray is cast through the trees, which hold each sprite's box
//! (Bevy's `calculate_bounds_2d` gives a sprite the box of its rectangle); only the sprites
//! whose box the ray crosses are sorted and tested, with Bevy's own rectangle and alpha tests.

use super::AccelPickingCamera;
use crate::{AccelIgnore, AccelSettings, AccelTracked, AccelTrees};
use bevy::asset::Assets;
use bevy::camera::primitives::Aabb;
use bevy::camera::visibility::RenderLayers;
use bevy::camera::{Projection, RenderTarget};
use bevy::color::Alpha;
use bevy::ecs::system::SystemParam;
use bevy::image::{Image, TextureAccessError, TextureAtlasLayout};
use bevy::math::FloatExt;
use bevy::picking::backend::ray::RayMap;
use bevy::picking::backend::{HitData, PointerHits};
use bevy::picking::pointer::{PointerId, PointerLocation};
use bevy::picking::{Pickable, PickingSystems};
use bevy::prelude::*;
use bevy::sprite::{Anchor, Sprite};
use bevy::window::PrimaryWindow;
use spatial_accel::{Ray, SpatialQuery};

/// Which part of a sprite a pointer must be over, as Bevy's `SpritePickingMode`.
#[derive(Debug, Clone, Copy, PartialEq, Reflect)]
#[reflect(Debug, Clone)]
pub enum AccelSpritePickingMode {
    /// Anywhere in the sprite's rectangle.
    BoundingBox,
    /// Only pixels whose alpha is above the threshold (a sprite without a loaded image, such
    /// as `Sprite::from_color`, is opaque everywhere).
    AlphaThreshold(f32),
}

/// Runtime settings of [`AccelSpritePickingPlugin`]: Bevy's `SpritePickingSettings`, and a
/// switch.
#[derive(Resource, Reflect, Clone, Debug)]
#[reflect(Resource, Default)]
pub struct AccelSpritePickingSettings {
    /// The backend casts pointer rays at sprites.
    pub enabled: bool,
    /// Only cameras with [`AccelPickingCamera`] cast.
    pub require_markers: bool,
    /// Rectangle or opaque pixels; by default an alpha above 0.1, as Bevy.
    pub picking_mode: AccelSpritePickingMode,
}

impl Default for AccelSpritePickingSettings {
    fn default() -> Self {
        Self {
            enabled: true,
            require_markers: false,
            picking_mode: AccelSpritePickingMode::AlphaThreshold(0.1),
        }
    }
}

/// Picks sprites through the trees: hits and their order are those of Bevy's sprite
/// backend (orthographic cameras, topmost sprite first, blocking by `Pickable`), with the
/// candidates found by one ray cast per pointer instead of a sort of every sprite.
/// Sprites the trees do not hold (no `Aabb`, [`AccelIgnore`], or no [`AccelTracked`] under
/// [`AccelSettings::require_marker`]) are tested one by one, and
/// every sprite is while [`AccelSettings::enabled`] is off (the trees are then stale).
///
/// Bevy's `SpritePlugin` adds Bevy's own sprite backend whenever Bevy's `sprite_picking`
/// feature is on, and it cannot be taken out again: build Bevy without that feature to have
/// this backend alone (with both, each sprite is reported by both, which picking merges).
/// Needs [`AccelPlugin`](crate::AccelPlugin) and Bevy's `PickingPlugin`.
///
/// Sprites of equal depth come in entity order here; Bevy's order among them follows its
/// archetype tables.
///
/// ```no_run
/// use bevy::prelude::*;
/// use bevy_accel::prelude::*;
///
/// App::new()
///     .add_plugins((DefaultPlugins, AccelPlugin::default(), AccelSpritePickingPlugin))
///     .add_systems(Startup, |mut commands: Commands| {
///         commands.spawn(Camera2d);
///         commands
///             .spawn(Sprite::from_color(Color::WHITE, Vec2::splat(64.0)))
///             .observe(|over: On<Pointer<Over>>| info!("over {}", over.entity));
///     })
///     .run();
/// ```
#[derive(Default)]
pub struct AccelSpritePickingPlugin;

impl Plugin for AccelSpritePickingPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<AccelSpritePickingSettings>()
            .register_type::<AccelSpritePickingSettings>()
            .add_systems(
                PreUpdate,
                update_sprite_hits
                    .in_set(PickingSystems::Backend)
                    .in_set(super::AccelPickingSystems)
                    .run_if(resource_exists::<AccelTrees>)
                    .run_if(resource_exists::<RayMap>)
                    .run_if(resource_exists::<Assets<Image>>)
                    .run_if(resource_exists::<Assets<TextureAtlasLayout>>)
                    .run_if(resource_exists::<Messages<PointerHits>>),
            );
    }

    fn finish(&self, app: &mut App) {
        crate::trees::step_aside::register_reader_plugin(app);
    }
}

type SpriteItem = (
    &'static Sprite,
    &'static GlobalTransform,
    &'static Anchor,
    &'static Pickable,
    &'static ViewVisibility,
    Option<&'static RenderLayers>,
);

/// Sprites the trees never hold.
type Untracked = (With<Sprite>, Or<(Without<Aabb>, With<AccelIgnore>)>);

/// What the backend reads of each camera.
type CameraItem = (
    Entity,
    &'static Camera,
    &'static RenderTarget,
    &'static GlobalTransform,
    &'static Projection,
    Has<AccelPickingCamera>,
    Option<&'static RenderLayers>,
);

/// The sprites a ray may reach: those the trees hold, found by a cast, and those they do not.
#[derive(SystemParam)]
#[doc(hidden)]
pub struct SpriteCandidates<'w, 's> {
    trees: Res<'w, AccelTrees>,
    settings: Option<Res<'w, AccelSettings>>,
    sprites: Query<'w, 's, SpriteItem>,
    untracked: Query<'w, 's, Entity, Untracked>,
    unmarked: Query<'w, 's, Entity, (With<Sprite>, Without<AccelTracked>)>,
    all: Query<'w, 's, Entity, With<Sprite>>,
}

impl SpriteCandidates<'_, '_> {
    /// Entities of pickable, visible sprites the segment from `start` along `dir` (length
    /// `len`) may hit, topmost (largest z) first, ties by entity.
    fn along(&self, start: Vec3, dir: Vec3, len: f32, out: &mut Vec<(f32, Entity)>) {
        out.clear();
        let mut keep = |entity: Entity| {
            if let Ok((_, tf, _, _, vis, _)) = self.sprites.get(entity)
                && vis.get()
                && !tf.affine().is_nan()
            {
                out.push((tf.translation().z, entity));
            }
        };
        let settings = self.settings.as_deref();
        if settings.is_some_and(|s| s.enabled) {
            let ray = Ray::new(start, dir).with_t_max(len);
            let mut hits = Vec::new();
            let trees = &*self.trees;
            trees.query().cast_ray_all(
                &ray,
                |slot, r| r.intersect_aabb(&trees.world_bounds(slot)),
                &mut hits,
            );
            trees.count_rays(1);
            hits.iter()
                .filter_map(|h| trees.entity(h.primitive))
                .for_each(&mut keep);
            self.untracked.iter().for_each(&mut keep);
            if settings.is_some_and(|s| s.require_marker) {
                self.unmarked.iter().for_each(&mut keep);
            }
        } else {
            self.all.iter().for_each(&mut keep);
        }
        // A sprite can be reached by the cast and also be untracked only if its box came
        // back this frame; keep one of each.
        out.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        out.dedup_by_key(|c| c.1);
    }
}

/// Casts each pointer's ray at the sprites and writes its [`PointerHits`]: Bevy's sprite
/// backend, with the candidates found through the trees.
// A system's parameters are its dependencies; bundling them would only hide them.
#[allow(clippy::too_many_arguments)]
pub fn update_sprite_hits(
    settings: Res<AccelSpritePickingSettings>,
    pointers: Query<(&PointerId, &PointerLocation)>,
    cameras: Query<CameraItem>,
    primary_window: Query<Entity, With<PrimaryWindow>>,
    images: Res<Assets<Image>>,
    atlases: Res<Assets<TextureAtlasLayout>>,
    candidates: SpriteCandidates,
    ray_map: Res<RayMap>,
    mut writer: MessageWriter<PointerHits>,
    mut found: Local<Vec<(f32, Entity)>>,
) {
    if !settings.enabled {
        return;
    }
    let primary_window = primary_window.single().ok();
    for (ray_id, ray) in ray_map.iter() {
        let Ok((
            cam_entity,
            camera,
            target,
            cam_tf,
            Projection::Orthographic(ortho),
            marked,
            cam_layers,
        )) = cameras.get(ray_id.camera)
        else {
            continue;
        };
        if !camera.is_active || (settings.require_markers && !marked) {
            continue;
        }
        let Some(location) = pointers
            .iter()
            .find_map(|(id, loc)| (*id == ray_id.pointer).then_some(loc.location.as_ref())?)
        else {
            continue;
        };
        if target
            .normalize(primary_window)
            .is_none_or(|t| t != location.target)
        {
            continue;
        }
        if camera
            .logical_viewport_rect()
            .is_some_and(|v| !v.contains(location.position))
        {
            continue;
        }
        // Bevy's segment: from the ray's origin (on the near plane) to the far plane.
        let len = ortho.far - ortho.near;
        let end = ray.origin + ray.direction * len;
        candidates.along(ray.origin, *ray.direction, len, &mut found);
        let cam_layers = cam_layers.cloned().unwrap_or_default();
        let cam_from_world = cam_tf.affine().inverse();
        let mut picks = Vec::new();
        for &(_, entity) in found.iter() {
            let Ok((sprite, tf, anchor, pickable, _, layers)) = candidates.sprites.get(entity)
            else {
                continue;
            };
            if !cam_layers.intersects(layers.unwrap_or_default()) {
                continue;
            }
            let Some(point) = sprite_point(tf, ray.origin, end) else {
                continue;
            };
            let Ok(pixel) = sprite.compute_pixel_space_point(point, *anchor, &images, &atlases)
            else {
                continue;
            };
            if !opaque_at(sprite, pixel, settings.picking_mode, &images, entity) {
                continue;
            }
            let world = tf.transform_point(point.extend(0.0));
            let depth = -ortho.near - cam_from_world.transform_point3(world).z;
            picks.push((
                entity,
                HitData::new(cam_entity, depth, Some(world), Some(*tf.back())),
            ));
            if pickable.should_block_lower {
                break;
            }
        }
        writer.write(PointerHits::new(ray_id.pointer, picks, camera.order as f32));
    }
}

/// Where the segment meets the sprite's plane (z = 0 in its own space), in its own xy; the
/// same arithmetic as Bevy's backend, so that both agree on points at a rectangle's edge.
fn sprite_point(tf: &GlobalTransform, start: Vec3, end: Vec3) -> Option<Vec2> {
    let sprite_from_world = tf.affine().inverse();
    let a = sprite_from_world.transform_point3(start);
    let b = sprite_from_world.transform_point3(end);
    if a.z == b.z {
        return None;
    }
    let s = f32::inverse_lerp(a.z, b.z, 0.0);
    (0.0..=1.0).contains(&s).then(|| a.lerp(b, s).xy())
}

/// Bevy's alpha test: a sprite without a loaded image is opaque everywhere; a texture format
/// that cannot be read warns and never picks.
fn opaque_at(
    sprite: &Sprite,
    pixel: Vec2,
    mode: AccelSpritePickingMode,
    images: &Assets<Image>,
    entity: Entity,
) -> bool {
    let AccelSpritePickingMode::AlphaThreshold(cutoff) = mode else {
        return true;
    };
    let Some(image) = images.get(&sprite.image) else {
        return true;
    };
    match image.get_color_at(pixel.x as u32, pixel.y as u32) {
        Ok(color) => color.alpha() > cutoff,
        Err(TextureAccessError::UnsupportedTextureFormat(format)) => {
            warn_once!(
                "sprite picking on {entity}: unsupported texture format {format:?}; use \
                 AccelSpritePickingMode::BoundingBox"
            );
            false
        }
        Err(_) => false,
    }
}
