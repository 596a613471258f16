//! [`AccelSelection`]: selection by rectangle, frustum or sphere, for any system.

use super::box_query::{
    box_faces_touch, candidates_in_frustum, candidates_in_sphere, frame_of, rect_frustum,
};
use super::settings::{AccelSelectionSettings, SelectionOrder};
use crate::meshes::{AccelMeshCache, MeshShape, ray_cast_mesh};
use crate::trees::{AccelTrees, TreeReaderPin};
use bevy::camera::primitives::Aabb as BevyAabb;
use bevy::camera::visibility::{InheritedVisibility, RenderLayers, ViewVisibility};
use bevy::ecs::system::SystemParam;
use bevy::ecs::system::lifetimeless::Read;
use bevy::math::bounding::BoundingSphere;
use bevy::mesh::{Mesh2d, Mesh3d};
use bevy::picking::Pickable;
use bevy::picking::mesh_picking::ray_cast::{RayCastVisibility, SimplifiedMesh};
use bevy::prelude::*;
use spatial_accel::sort::sort_keys;
use spatial_accel::{Frustum, SelectionMode, Sphere};

/// Why a selection could not be made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SelectionError {
    /// The entity is not a camera (or has no `GlobalTransform`).
    NotACamera(Entity),
    /// The camera's viewport has no size yet (its render target is not known: the first
    /// frame, or a window that is gone).
    NoViewportSize(Entity),
}

impl core::fmt::Display for SelectionError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NotACamera(e) => write!(f, "{e} is not a camera with a GlobalTransform"),
            Self::NoViewportSize(e) => write!(f, "camera {e} has no viewport size yet"),
        }
    }
}

impl core::error::Error for SelectionError {}

/// What the rules read of a candidate: those of the picking backend.
type RuleData = (
    Option<Read<Pickable>>,
    Option<Read<RenderLayers>>,
    Option<Read<InheritedVisibility>>,
    Option<Read<ViewVisibility>>,
);

/// What a rectangle reads of its camera.
type CameraData = (
    Read<Camera>,
    Read<GlobalTransform>,
    Option<Read<RenderLayers>>,
);

/// What the touching test reads of a candidate: the mesh a ray cast would test.
type ShapeData = (
    Option<Read<Mesh3d>>,
    Option<Read<Mesh2d>>,
    Option<Read<SimplifiedMesh>>,
);

/// Selection in code: the tracked entities in a rectangle of a camera's view, in a frustum or
/// in a sphere, by any [`SelectionMode`], found through the trees (no entity is projected).
///
/// Every method honours the rules of [`AccelSelectionSettings`], as the picking backend does
/// its own: `Pickable` (an entity that is not hoverable is never selected; with
/// `require_pickable`, only entities with one are) and the visibility setting; the rectangle
/// methods also the camera's `RenderLayers` (an entity without layers is on layer 0) and its
/// viewport (the part of the rectangle outside it selects nothing). Entities are where the
/// sync last placed them, as for [`AccelSpatialQuery`](crate::AccelSpatialQuery). Results
/// borrow the parameter's buffer until the next call.
///
/// - [`SelectionMode::Center`]: the centre of the entity's world box is inside;
/// - [`SelectionMode::Enclosed`]: the whole world box is inside;
/// - [`SelectionMode::Touching`]: a triangle of the entity's mesh meets the volume (through
///   the mesh's BVH; an entity without a readable mesh, a sprite for instance, by the faces of
///   its `Aabb`), whatever hides it. A sphere judges touching on the world box.
///
/// ```
/// use bevy::prelude::*;
/// use bevy::camera::primitives::Aabb;
/// use bevy::ecs::system::RunSystemOnce;
/// use bevy::math::bounding::BoundingSphere;
/// use bevy_accel::prelude::*;
///
/// let mut app = App::new();
/// app.add_plugins((MinimalPlugins, TransformPlugin, AccelPlugin::default()))
///     .add_plugins(AccelSelectionPlugin);
/// let unit = Aabb::from_min_max(Vec3::splat(-0.5), Vec3::splat(0.5));
/// let near = app.world_mut().spawn((Transform::from_xyz(1.0, 0.0, 0.0), unit)).id();
/// let far = app.world_mut().spawn((Transform::from_xyz(3.0, 0.0, 0.0), unit)).id();
/// app.update();
///
/// app.world_mut()
///     .run_system_once(move |mut selection: AccelSelection| {
///         let ball = BoundingSphere::new(Vec3::ZERO, 3.2);
///         // Centre mode: both centres are within 3.2; enclosed: only the near box is whole.
///         let both = selection.in_sphere(ball, SelectionMode::Center, SelectionOrder::ByDistance);
///         assert_eq!(both, [near, far]);
///         assert_eq!(selection.in_sphere(ball, SelectionMode::Enclosed, SelectionOrder::ByEntity), [near]);
///     })
///     .unwrap();
/// ```
#[derive(SystemParam)]
pub struct AccelSelection<'w, 's> {
    trees: Res<'w, AccelTrees>,
    /// Registers the system as a reader: the trees it reads never step aside (see
    /// [`AccelTrees::stepped_aside`]).
    _reader: Local<'s, TreeReaderPin>,
    settings: Option<Res<'w, AccelSelectionSettings>>,
    cameras: Query<'w, 's, CameraData>,
    rules: Query<'w, 's, RuleData>,
    /// Whether any entity has a `Pickable` or `RenderLayers`: where none has, their rules need
    /// no read of each candidate.
    with_pickable: Query<'w, 's, (), With<Pickable>>,
    with_layers: Query<'w, 's, (), With<RenderLayers>>,
    shapes: Query<'w, 's, ShapeData>,
    /// Busy movers' rows: their own space is not kept in the trees.
    busy_rows: Query<'w, 's, (Read<BevyAabb>, Read<GlobalTransform>)>,
    meshes: Option<Res<'w, Assets<Mesh>>>,
    cache: Option<Res<'w, AccelMeshCache>>,
    /// Each candidate with its slot, and whether its mesh must decide.
    candidates: Local<'s, Vec<(Entity, u32, bool)>>,
    /// The slots a frustum walk reached; the entities found, as sort keys.
    keys: Local<'s, Vec<u64>>,
    found: Local<'s, Vec<(Entity, f32)>>,
    output: Local<'s, Vec<Entity>>,
}

impl AccelSelection<'_, '_> {
    /// The entities in the rectangle between the corners `a` and `b` (any order) of the
    /// camera's view, in logical pixels of its render target (as pointer positions and
    /// `Camera::viewport_to_ndc` give them), seen through the camera (perspective or
    /// orthographic, any viewport).
    pub fn in_rect(
        &mut self,
        camera: Entity,
        a: Vec2,
        b: Vec2,
        mode: SelectionMode,
        order: SelectionOrder,
    ) -> Result<&[Entity], SelectionError> {
        let (cam, _, _) = self
            .cameras
            .get(camera)
            .map_err(|_| SelectionError::NotACamera(camera))?;
        let to_ndc = |p| cam.viewport_to_ndc(p).ok();
        let (Some(a), Some(b)) = (to_ndc(a), to_ndc(b)) else {
            return Err(SelectionError::NoViewportSize(camera));
        };
        self.in_ndc_rect(camera, a, b, mode, order)
    }

    /// [`AccelSelection::in_rect`] with the corners in normalised device coordinates of the
    /// camera's viewport (`[-1, 1]`, y up).
    pub fn in_ndc_rect(
        &mut self,
        camera: Entity,
        a: Vec2,
        b: Vec2,
        mode: SelectionMode,
        order: SelectionOrder,
    ) -> Result<&[Entity], SelectionError> {
        let (cam, transform, layers) = self
            .cameras
            .get(camera)
            .map_err(|_| SelectionError::NotACamera(camera))?;
        let layers = layers.cloned().unwrap_or_default();
        let eye = transform.translation();
        self.found.clear();
        if let Some(frustum) = rect_frustum(cam.clip_from_view(), transform, a, b) {
            self.collect_in_frustum(&frustum, mode, Some(&layers));
        }
        Ok(self.finish(order, eye))
    }

    /// The entities in a world-space frustum (the core's: build one with
    /// [`Frustum::from_clip_rect`] or from planes), nearest to `origin` first with
    /// [`SelectionOrder::ByDistance`]. No render layers apply: no camera is involved.
    pub fn in_frustum(
        &mut self,
        frustum: &Frustum,
        origin: Vec3,
        mode: SelectionMode,
        order: SelectionOrder,
    ) -> &[Entity] {
        self.found.clear();
        self.collect_in_frustum(frustum, mode, None);
        self.finish(order, origin)
    }

    /// The entities in a sphere, nearest to its centre first with
    /// [`SelectionOrder::ByDistance`]: judged on the world boxes (touching: any point of the
    /// box within the sphere). No render layers apply.
    pub fn in_sphere(
        &mut self,
        sphere: BoundingSphere,
        mode: SelectionMode,
        order: SelectionOrder,
    ) -> &[Entity] {
        self.found.clear();
        if sphere.center.is_finite() && sphere.radius().is_finite() {
            let ball = Sphere::new(sphere.center, sphere.radius());
            let mut candidates = core::mem::take(&mut *self.candidates);
            candidates.clear();
            candidates_in_sphere(&self.trees, &ball, mode, |slot, entity| {
                candidates.push((entity, slot, false));
            });
            let all_pass = self.rules_pass_all(None);
            for &(entity, _, _) in &candidates {
                if all_pass || self.passes(entity, None) {
                    self.found.push((entity, 0.0));
                }
            }
            *self.candidates = candidates;
        }
        self.finish(order, sphere.center.into())
    }

    /// Whether an entity may be selected by the rules (see [`AccelSelection`]); `camera_layers`
    /// `None` skips the layer rule.
    pub fn passes(&self, entity: Entity, camera_layers: Option<&RenderLayers>) -> bool {
        let Ok((pickable, layers, inherited, view)) = self.rules.get(entity) else {
            return false;
        };
        let (require, visibility) = self.rule_settings();
        if (require && pickable.is_none()) || pickable.is_some_and(|p| !p.is_hoverable) {
            return false;
        }
        let visible = match visibility {
            RayCastVisibility::Any => true,
            RayCastVisibility::Visible => inherited.is_none_or(|v| v.get()),
            RayCastVisibility::VisibleInView => view.is_none_or(|v| v.get()),
        };
        visible
            && camera_layers
                .is_none_or(|c| c.intersects(layers.unwrap_or(&RenderLayers::default())))
    }

    /// `require_pickable` and the visibility rule of the settings (the defaults without them).
    fn rule_settings(&self) -> (bool, RayCastVisibility) {
        self.settings
            .as_ref()
            .map_or((false, RayCastVisibility::VisibleInView), |s| {
                (s.require_pickable, s.visibility)
            })
    }

    /// Whether every entity passes the rules without a read of its components: no visibility
    /// rule, no `Pickable` on any entity (and none required), and, where a camera's layers
    /// apply, no `RenderLayers` on any entity while the camera sees layer 0. Decided over the
    /// archetypes, once a selection: a read of each candidate's components costs it a few
    /// cache misses.
    fn rules_pass_all(&self, camera_layers: Option<&RenderLayers>) -> bool {
        let (require, visibility) = self.rule_settings();
        matches!(visibility, RayCastVisibility::Any)
            && !require
            && self.with_pickable.is_empty()
            && camera_layers.is_none_or(|c| {
                self.with_layers.is_empty() && c.intersects(&RenderLayers::default())
            })
    }

    /// A camera's render layers (layer 0 without a `RenderLayers`), as the rectangle methods
    /// apply them.
    pub fn camera_layers(&self, camera: Entity) -> RenderLayers {
        self.cameras
            .get(camera)
            .ok()
            .and_then(|(_, _, layers)| layers.cloned())
            .unwrap_or_default()
    }

    /// The trees the selections run on.
    pub fn trees(&self) -> &AccelTrees {
        &self.trees
    }

    /// Fills `found` with the entities the mode selects in the frustum and the rules allow.
    fn collect_in_frustum(
        &mut self,
        frustum: &Frustum,
        mode: SelectionMode,
        layers: Option<&RenderLayers>,
    ) {
        let mut candidates = core::mem::take(&mut *self.candidates);
        candidates.clear();
        candidates_in_frustum(
            &self.trees,
            frustum,
            mode,
            &mut self.keys,
            |slot, entity, verdict| {
                candidates.push((entity, slot, verdict.is_none()));
            },
        );
        let all_pass = self.rules_pass_all(layers);
        for &(entity, slot, undecided) in &candidates {
            if (all_pass || self.passes(entity, layers))
                && (!undecided || self.touches(slot, entity, frustum))
            {
                self.found.push((entity, 0.0));
            }
        }
        *self.candidates = candidates;
    }

    /// Whether a triangle of the entity's mesh (or of its box's faces) meets the frustum.
    fn touches(&self, slot: u32, entity: Entity, frustum: &Frustum) -> bool {
        let Some(frame) = frame_of(&self.trees, slot, self.busy_rows.get(entity).ok()) else {
            return false;
        };
        let local = frustum.transformed(&Mat4::from(frame.world_from_local()));
        let shape = self
            .shapes
            .get(entity)
            .ok()
            .and_then(|(m3, m2, simplified)| {
                let (handle, _) = ray_cast_mesh(m3, m2, simplified, false)?;
                self.cache
                    .as_ref()?
                    .get_or_build(handle.id(), self.meshes.as_ref()?)
            });
        match shape {
            Some(MeshShape::Triangles(mesh)) => mesh.bvh.any_triangle_in_frustum(&local),
            _ => box_faces_touch(&local, &frame.local_bounds),
        }
    }

    /// Sorts `found` as asked and returns the entities.
    fn finish(&mut self, order: SelectionOrder, origin: Vec3) -> &[Entity] {
        let trees = &*self.trees;
        let found = &mut *self.found;
        self.output.clear();
        match order {
            SelectionOrder::ByEntity => {
                // Entities order by their bits; a radix sort of the bits costs a fraction of
                // a comparison sort at the tens of thousands a box holds.
                let keys = &mut *self.keys;
                keys.clear();
                keys.extend(found.iter().map(|(e, _)| e.to_bits()));
                sort_keys(keys);
                self.output
                    .extend(keys.iter().map(|&k| Entity::from_bits(k)));
                return &self.output;
            }
            SelectionOrder::ByDistance => {
                let p = Vec3A::from(origin);
                for (entity, distance) in found.iter_mut() {
                    *distance = trees
                        .tracked_location(*entity)
                        .map_or(f32::INFINITY, |(slot, _)| {
                            trees.world_bounds(slot).distance_squared_to_point(p)
                        });
                }
                found.sort_unstable_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
            }
        }
        self.output.extend(found.iter().map(|&(e, _)| e));
        &self.output
    }
}
