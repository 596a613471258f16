//! Spatial queries over the tracked entities' world boxes, in any system:
//! [`AccelSpatialQuery`]. No cargo feature needed; ray casts against meshes are
//! [`AccelRayCast`](crate::AccelRayCast)'s (cargo feature `picking`).

use crate::trees::{AccelTrees, TreeReaderPin};
use bevy::camera::primitives::Frustum;
use bevy::ecs::system::SystemParam;
use bevy::math::bounding::{Aabb3d, BoundingSphere};
use bevy::prelude::*;
use core::ops::ControlFlow;
use spatial_accel::{Aabb, Containment, SpatialQuery};

/// Which entities are where: overlap and nearest-neighbour queries over the world boxes of
/// the entities the trees hold, answered by a walk of the trees rather than a scan of every
/// entity.
///
/// Every answer is exact for the entities' world boxes (the trees hold fattened boxes; each
/// candidate's exact box is tested), and entities are where the sync last placed them: read
/// it after [`AccelSystems::Sync`](crate::AccelSystems::Sync). Overlaps come back sorted by
/// entity, nearest neighbours nearest first; the slices borrow the parameter's own buffers
/// until the next query.
///
/// ```
/// use bevy::math::bounding::{Aabb3d, BoundingSphere};
/// use bevy::prelude::*;
/// use bevy::camera::primitives::Aabb;
/// use bevy::ecs::system::RunSystemOnce;
/// use bevy_accel::prelude::*;
///
/// let mut app = App::new();
/// app.add_plugins((MinimalPlugins, TransformPlugin, AccelPlugin::default()));
/// let unit = Aabb::from_min_max(Vec3::splat(-0.5), Vec3::splat(0.5));
/// let near = app.world_mut().spawn((Transform::from_xyz(1.0, 0.0, 0.0), unit)).id();
/// let far = app.world_mut().spawn((Transform::from_xyz(10.0, 0.0, 0.0), unit)).id();
/// app.update();
///
/// app.world_mut()
///     .run_system_once(move |mut query: AccelSpatialQuery| {
///         assert_eq!(query.overlap_sphere(BoundingSphere::new(Vec3::ZERO, 1.0)), [near]);
///         assert_eq!(query.overlap_aabb(Aabb3d::new(Vec3::X * 10.0, Vec3::ONE)), [far]);
///         let nearest: Vec<Entity> = query.nearest(Vec3::ZERO, 2).iter().map(|&(e, _)| e).collect();
///         assert_eq!(nearest, [near, far]);
///         assert_eq!(query.nearest(Vec3::ZERO, 1)[0].1, 0.5);
///     })
///     .unwrap();
/// ```
#[derive(SystemParam)]
pub struct AccelSpatialQuery<'w, 's> {
    trees: Res<'w, AccelTrees>,
    /// Registers the system as a reader: the trees it reads never step aside (see
    /// [`AccelTrees::stepped_aside`]).
    _reader: Local<'s, TreeReaderPin>,
    entities: Local<'s, Vec<Entity>>,
    nearest: Local<'s, Vec<(Entity, f32)>>,
}

impl AccelSpatialQuery<'_, '_> {
    /// Tracked entities whose world box contains `point`, sorted.
    pub fn overlap_point(&mut self, point: Vec3) -> &[Entity] {
        let p = Vec3A::from(point);
        self.overlap(
            |q, visit| q.for_each_containing_point(p, visit),
            |b| b.contains_point(p),
        )
    }

    /// Tracked entities whose world box overlaps `aabb`, sorted.
    pub fn overlap_aabb(&mut self, aabb: Aabb3d) -> &[Entity] {
        let query = Aabb::new(aabb.min, aabb.max);
        self.overlap(
            |q, visit| q.for_each_overlapping_aabb(&query, visit),
            |b| b.intersects_aabb(&query),
        )
    }

    /// Tracked entities whose world box overlaps `sphere`, sorted.
    pub fn overlap_sphere(&mut self, sphere: BoundingSphere) -> &[Entity] {
        let query = spatial_accel::Sphere::new(sphere.center, sphere.radius());
        let r2 = sphere.radius() * sphere.radius();
        self.overlap(
            |q, visit| q.for_each_overlapping_sphere(&query, visit),
            |b| b.distance_squared_to_point(sphere.center) <= r2,
        )
    }

    /// Tracked entities whose world box is not outside `frustum` (all six planes count,
    /// the far one included), sorted.
    pub fn overlap_frustum(&mut self, frustum: &Frustum) -> &[Entity] {
        let query = spatial_accel::Frustum::from_planes(frustum.half_spaces.map(|h| h.normal_d()));
        let trees = &*self.trees;
        self.entities.clear();
        trees
            .query()
            .for_each_in_frustum(&query, |slot, containment| {
                // `Inside` means the (fattened) tree box is inside, so the exact box is too.
                if (containment == Containment::Inside
                    || query.intersects_aabb(&trees.world_bounds(slot)))
                    && let Some(entity) = trees.entity(slot)
                {
                    self.entities.push(entity);
                }
            });
        self.entities.sort_unstable();
        &self.entities
    }

    /// The `k` tracked entities whose world boxes are nearest to `point`, nearest first, with
    /// the distance from the point to each box (0 for a box that contains it). Entities at
    /// the same distance come in the trees' slot order.
    pub fn nearest(&mut self, point: Vec3, k: usize) -> &[(Entity, f32)] {
        let p = Vec3A::from(point);
        let trees = &*self.trees;
        let found = trees.query().nearest_k(p, k, |slot| {
            trees.world_bounds(slot).distance_squared_to_point(p)
        });
        self.nearest.clear();
        self.nearest.extend(
            found
                .into_iter()
                .filter_map(|(slot, d2)| Some((trees.entity(slot)?, d2.sqrt()))),
        );
        &self.nearest
    }

    /// The trees the queries run on.
    pub fn trees(&self) -> &AccelTrees {
        &self.trees
    }

    /// Runs an overlap traversal and keeps the candidates whose exact world box passes.
    fn overlap(
        &mut self,
        traverse: impl FnOnce(&crate::index::EntityIndex, &mut dyn FnMut(u32) -> ControlFlow<()>),
        exact: impl Fn(&Aabb) -> bool,
    ) -> &[Entity] {
        let trees = &*self.trees;
        let entities = &mut *self.entities;
        entities.clear();
        traverse(trees.query(), &mut |slot| {
            if exact(&trees.world_bounds(slot))
                && let Some(entity) = trees.entity(slot)
            {
                entities.push(entity);
            }
            ControlFlow::Continue(())
        });
        entities.sort_unstable();
        entities
    }
}
