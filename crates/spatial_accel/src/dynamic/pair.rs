//! A static tree and a dynamic tree, queried as one.
//!
//! Level geometry never moves; entities do. Keeping them in one dynamic tree makes every
//! refit and rebuild pay for the level too, and keeping them in two makes every query run
//! twice by hand. [`StaticDynamicPair`] presents both as one [`BoundingTree`] under a virtual
//! root, so every query is one traversal through the shared code of [`crate::query::walks`]
//! (a closest hit found in one tree prunes the other), while the static tree is never refit.
//! Rays, the hottest query (picking, the preview), walk the static tree in its 16-wide form
//! instead, then the dynamic tree, the nearer first so its hits prune the other. Rays can walk
//! a 16-wide snapshot of the dynamic tree too
//! ([`StaticDynamicPair::snapshot_dynamic_for_rays`]), kept through motion by refits and
//! dropped at insertions and removals; how rays walk the pair, and the snapshot's upkeep, are
//! in `pair_rays`.

use super::PreparedStatic;
use super::pair_rays::wide_for_rays;
use super::ray_snapshot::RaySnapshot;
use super::{DynamicBvh, DynamicBvhError, LeafHandle, MaintainReport};
use crate::bvh::wide::Bvh16;
use crate::query::BoundingTree;
use crate::{Aabb, Bvh};

/// Static node ids are tagged with the top bit (dynamic node ids stay below 2^31).
const STATIC_TAG: u32 = 1 << 31;
/// The virtual root above the two trees.
const VIRTUAL_ROOT: u32 = u32::MAX;

/// A static [`Bvh`] and a [`DynamicBvh`] answering [`SpatialQuery`](crate::SpatialQuery) as
/// one tree.
///
/// Queries report the primitive ids each tree holds, as they are: give the two trees
/// disjoint id ranges (for example static ids from `1 << 31` up, or a lookup the callback
/// can tell apart) when the callback must know which tree a primitive came from. As with
/// the dynamic tree alone, call [`DynamicBvh::maintain`] (or `refit`) after updates and
/// before querying.
///
/// ```
/// use spatial_accel::{Aabb, BuildConfig, Bvh, Ray, SpatialQuery};
/// use spatial_accel::dynamic::{DynamicBvh, StaticDynamicPair};
/// use glam::Vec3A;
///
/// // Level walls: ids 0..10, static.
/// let walls: Vec<Aabb> = (0..10)
///     .map(|i| Aabb::new(Vec3A::new(10.0 * i as f32, 0.0, 0.0), Vec3A::new(10.0 * i as f32 + 1.0, 5.0, 5.0)))
///     .collect();
/// let mut pair = StaticDynamicPair::new(Bvh::build(&walls, &BuildConfig::default()), DynamicBvh::new());
/// // A moving crate: id 100, dynamic, in front of the first wall.
/// let crate_box = Aabb::new(Vec3A::new(-3.0, 1.0, 1.0), Vec3A::new(-2.0, 2.0, 2.0));
/// pair.dynamic_mut().insert(100, crate_box).unwrap();
/// pair.dynamic_mut().maintain();
///
/// let boxes = |id: u32| if id == 100 { crate_box } else { walls[id as usize] };
/// let ray = Ray::new(Vec3A::new(-10.0, 1.5, 1.5), Vec3A::X);
/// let hit = pair.cast_ray(&ray, |id, r| r.intersect_aabb(&boxes(id))).unwrap();
/// assert_eq!(hit.primitive, 100);
/// ```
#[derive(Clone, Debug, Default)]
pub struct StaticDynamicPair {
    // The fields the ray half of the pair reads are `pub(super)` for `pair_rays`.
    static_tree: Bvh,
    /// The static tree collapsed to 16-wide nodes, for rays (same primitive ids), with its
    /// single-primitive leaves' ids in the nodes ([`Bvh16::inline_single_leaves`]).
    pub(super) static_wide: Bvh16,
    /// [`Bvh::subtree_ranges`] of the static tree: a frustum walk emits each subtree it
    /// proves inside with one read instead of two walks down the subtree's edges.
    static_ranges: Vec<[u32; 2]>,
    pub(super) dynamic: DynamicBvh,
    /// A 16-wide tree over the dynamic tree's leaves, for rays. Refit by
    /// [`Self::maintain_dynamic`] after [`Self::update_dynamic`]s; dropped by
    /// [`Self::dynamic_mut`], the only other way to change the dynamic tree, so it never
    /// holds other leaves than the tree's.
    pub(super) dynamic_rays: RaySnapshot,
    /// Updates made through [`Self::update_dynamic`].
    dynamic_updates: u64,
}

impl StaticDynamicPair {
    /// The pair of a static tree and a dynamic one.
    pub fn new(static_tree: Bvh, dynamic: DynamicBvh) -> Self {
        Self {
            static_wide: wide_for_rays(&static_tree),
            static_ranges: static_tree.subtree_ranges(),
            static_tree,
            dynamic,
            dynamic_rays: RaySnapshot::default(),
            dynamic_updates: 0,
        }
    }

    /// The static tree (read-only: it is never refit; replace it with
    /// [`set_static`](Self::set_static) when the level changes).
    pub fn static_tree(&self) -> &Bvh {
        &self.static_tree
    }

    /// Replaces the static tree, returning the old one. Derives the tree's ray form and
    /// spans here, O(n); [`Self::set_static_prepared`] takes them made elsewhere.
    pub fn set_static(&mut self, static_tree: Bvh) -> Bvh {
        self.set_static_prepared(PreparedStatic::new(static_tree))
            .tree
    }

    /// Replaces the static tree with one prepared ahead (on another thread, say), returning
    /// the old one with its tables: O(1). Why whole: freeing a large tree's arrays is work of
    /// its own, which a caller may rather do off the frame too.
    pub fn set_static_prepared(&mut self, prepared: PreparedStatic) -> PreparedStatic {
        PreparedStatic {
            wide: core::mem::replace(&mut self.static_wide, prepared.wide),
            ranges: core::mem::replace(&mut self.static_ranges, prepared.ranges),
            tree: core::mem::replace(&mut self.static_tree, prepared.tree),
        }
    }

    /// The dynamic tree.
    pub fn dynamic(&self) -> &DynamicBvh {
        &self.dynamic
    }

    /// The dynamic tree, for insertions, removals and anything else. Drops the dynamic tree's
    /// ray snapshot, if any (see [`Self::snapshot_dynamic_for_rays`]); updates and
    /// maintenance through [`Self::update_dynamic`] and [`Self::maintain_dynamic`] keep it.
    pub fn dynamic_mut(&mut self) -> &mut DynamicBvh {
        self.dynamic_rays.invalidate();
        &mut self.dynamic
    }

    /// [`DynamicBvh::update`], keeping the dynamic tree's ray snapshot: the leaf is listed,
    /// and the snapshot is refit along its path at the next [`Self::maintain_dynamic`] (or
    /// [`Self::refit_dynamic_ray_snapshot`]). Rays walk the binary tree until then.
    pub fn update_dynamic(
        &mut self,
        handle: LeafHandle,
        bounds: Aabb,
    ) -> Result<bool, DynamicBvhError> {
        let changed = self.dynamic.update(handle, bounds)?;
        self.dynamic_rays
            .note_moved(handle.index(), self.dynamic.len());
        self.dynamic_updates += 1;
        Ok(changed)
    }

    /// How many updates [`Self::update_dynamic`] has made so far: a caller that compares it
    /// frame to frame knows how much moved, including motion inside the fat boxes, which
    /// [`DynamicBvh::update`] reports as no change.
    pub fn dynamic_update_count(&self) -> u64 {
        self.dynamic_updates
    }

    /// [`DynamicBvh::maintain`], then [`Self::refit_dynamic_ray_snapshot`]: the once-per-frame
    /// call after [`Self::update_dynamic`]s.
    pub fn maintain_dynamic(&mut self) -> MaintainReport {
        let report = self.dynamic.maintain();
        self.dynamic_rays.refit(&self.dynamic);
        report
    }

    /// Both trees, by value.
    pub fn into_parts(self) -> (Bvh, DynamicBvh) {
        (self.static_tree, self.dynamic)
    }

    /// Bounds of everything in either tree.
    pub fn bounds(&self) -> Aabb {
        self.static_tree.bounds().union(&self.dynamic.bounds())
    }
}

impl BoundingTree for StaticDynamicPair {
    type Volume = Aabb;
    type Children<'a>
        = [u32; 2]
    where
        Self: 'a;

    #[inline]
    fn root(&self) -> Option<u32> {
        match (self.static_tree.root(), self.dynamic.root()) {
            (Some(_), Some(_)) => Some(VIRTUAL_ROOT),
            (Some(s), None) => Some(s | STATIC_TAG),
            (None, d) => d,
        }
    }

    #[inline]
    fn node_bounds(&self, node: u32) -> Aabb {
        if node == VIRTUAL_ROOT {
            self.bounds()
        } else if node & STATIC_TAG != 0 {
            self.static_tree.node_bounds(node & !STATIC_TAG)
        } else {
            self.dynamic.node_bounds(node)
        }
    }

    #[inline]
    fn node_children(&self, node: u32) -> Option<[u32; 2]> {
        if node == VIRTUAL_ROOT {
            let s = self.static_tree.root()?;
            let d = self.dynamic.root()?;
            Some([s | STATIC_TAG, d])
        } else if node & STATIC_TAG != 0 {
            self.static_tree
                .node_children(node & !STATIC_TAG)
                .map(|c| c.map(|c| c | STATIC_TAG))
        } else {
            self.dynamic.node_children(node)
        }
    }

    #[inline]
    fn prefetch_node(&self, node: u32) {
        if node == VIRTUAL_ROOT {
            return;
        }
        if node & STATIC_TAG != 0 {
            let i = node & !STATIC_TAG;
            self.static_tree.prefetch_node(i);
            // A walk that finds the node inside the view reads its span next.
            if let Some(range) = self.static_ranges.get(i as usize) {
                crate::prefetch::prefetch_node(range);
            }
        } else {
            self.dynamic.prefetch_node(node);
        }
    }

    #[inline]
    fn node_primitives(&self, node: u32) -> &[u32] {
        if node == VIRTUAL_ROOT {
            &[]
        } else if node & STATIC_TAG != 0 {
            self.static_tree.node_primitives(node & !STATIC_TAG)
        } else {
            self.dynamic.node_primitives(node)
        }
    }

    #[inline]
    fn subtree_primitives(&self, node: u32) -> Option<&[u32]> {
        if node == VIRTUAL_ROOT || node & STATIC_TAG == 0 {
            return None;
        }
        let [first, end] = *self.static_ranges.get((node & !STATIC_TAG) as usize)?;
        self.static_tree
            .primitive_indices()
            .get(first as usize..end as usize)
    }
}

crate::impl_spatial_query_for_tree!(@queries StaticDynamicPair);
