//! A static tree and a dynamic tree, queried as one.
//!
//! Level geometry never moves; entities do. Keeping them in one dynamic tree makes every
//! refit and rebuild pay for the level too, and keeping them in two makes every query run
//! twice by hand. [`StaticDynamicPair`] presents both as one [`BoundingTree`] under a virtual
//! root, so every query is one traversal through the shared code of [`crate::query::binary`]
//! (a closest hit found in one tree prunes the other), while the static tree is never refit.
//! Rays, the hottest query (picking, the preview), walk the static tree in its 16-wide form
//! instead, then the dynamic tree, the nearer first so its hits prune the other. Rays can walk
//! a 16-wide snapshot of the dynamic tree too
//! ([`StaticDynamicPair::snapshot_dynamic_for_rays`]), kept through motion by refits and
//! dropped at insertions and removals.

use super::ray_snapshot::RaySnapshot;
use super::{DynamicBvh, DynamicBvhError, LeafHandle, MaintainReport};
use crate::bvh::wide::Bvh16;
use crate::query::{BoundingTree, RayWalk};
use crate::{Aabb, BuildConfig, Bvh, Ray};
use core::ops::ControlFlow;

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
/// use accel::{Aabb, BuildConfig, Bvh, Ray, SpatialQuery};
/// use accel::dynamic::{DynamicBvh, StaticDynamicPair};
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
    static_tree: Bvh,
    /// The static tree collapsed to 16-wide nodes, for rays (same primitive ids), with its
    /// single-primitive leaves' ids in the nodes ([`Bvh16::inline_single_leaves`]).
    static_wide: Bvh16,
    /// [`Bvh::subtree_ranges`] of the static tree: a frustum walk emits each subtree it
    /// proves inside with one read instead of two walks down the subtree's edges.
    static_ranges: Vec<[u32; 2]>,
    dynamic: DynamicBvh,
    /// A 16-wide tree over the dynamic tree's leaves, for rays. Refit by
    /// [`Self::maintain_dynamic`] after [`Self::update_dynamic`]s; dropped by
    /// [`Self::dynamic_mut`], the only other way to change the dynamic tree, so it never
    /// holds other leaves than the tree's.
    dynamic_rays: RaySnapshot,
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

    /// Replaces the static tree, returning the old one.
    pub fn set_static(&mut self, static_tree: Bvh) -> Bvh {
        self.static_wide = wide_for_rays(&static_tree);
        self.static_ranges = static_tree.subtree_ranges();
        core::mem::replace(&mut self.static_tree, static_tree)
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

    /// Drops the dynamic tree's ray snapshot (rays walk the binary tree) without touching the
    /// tree: for a caller whose rays are too few to pay for refitting it.
    pub fn drop_dynamic_ray_snapshot(&mut self) {
        self.dynamic_rays.invalidate();
    }

    /// [`DynamicBvh::maintain`], then [`Self::refit_dynamic_ray_snapshot`]: the once-per-frame
    /// call after [`Self::update_dynamic`]s.
    pub fn maintain_dynamic(&mut self) -> MaintainReport {
        let report = self.dynamic.maintain();
        self.dynamic_rays.refit(&self.dynamic);
        report
    }

    /// Refits the dynamic tree's ray snapshot (if one is held) along the paths of the leaves
    /// updated since its last refit, so that rays walk it again.
    ///
    /// Why not drop it: in a world where a few entities move every frame, a dropped snapshot
    /// would leave rays on the binary tree for good (on the picking bench at 100,000 entities,
    /// 2-3 times slower per ray). The snapshot's shape ages with the motion, as any refit
    /// tree's does; [`Self::refresh_dynamic_ray_snapshot`] rebuilds it.
    pub fn refit_dynamic_ray_snapshot(&mut self) {
        self.dynamic_rays.refit(&self.dynamic);
    }

    /// Whether a ray snapshot is held with updates not yet refit (rays walk the binary tree
    /// until [`Self::refit_dynamic_ray_snapshot`] or [`Self::maintain_dynamic`]).
    pub fn dynamic_ray_snapshot_needs_refit(&self) -> bool {
        self.dynamic_rays.needs_refit()
    }

    /// How many refits found moved leaves since the held ray snapshot was built (`None`
    /// without one): what a caller weighs to [`Self::refresh_dynamic_ray_snapshot`].
    pub fn dynamic_ray_snapshot_moving_refits(&self) -> Option<u32> {
        self.dynamic_rays.moving_refits()
    }

    /// Rebuilds the dynamic tree's ray snapshot over the leaves' current boxes, now or (with
    /// `in_background`) on another thread, installed by
    /// [`Self::poll_dynamic_ray_snapshot`] while the held one keeps serving rays. Returns
    /// whether a snapshot is held or being made.
    ///
    /// ```
    /// use accel::{Aabb, BuildConfig, Bvh, Ray, SpatialQuery};
    /// use accel::dynamic::{DynamicBvh, StaticDynamicPair};
    /// use glam::Vec3A;
    ///
    /// let mut pair = StaticDynamicPair::new(Bvh::default(), DynamicBvh::new());
    /// let config = BuildConfig::default();
    /// let mut b = Aabb::new(Vec3A::splat(1.0), Vec3A::splat(2.0));
    /// let handle = pair.dynamic_mut().insert(7, b).unwrap();
    /// pair.maintain_dynamic();
    /// pair.snapshot_dynamic_for_rays(&config);
    /// // Motion keeps the snapshot: it is refit by `maintain_dynamic`.
    /// b = Aabb::new(Vec3A::splat(5.0), Vec3A::splat(6.0));
    /// pair.update_dynamic(handle, b).unwrap();
    /// pair.maintain_dynamic();
    /// assert!(pair.has_dynamic_ray_snapshot());
    /// assert_eq!(pair.dynamic_ray_snapshot_moving_refits(), Some(1));
    /// let ray = Ray::new(Vec3A::ZERO, Vec3A::ONE.normalize());
    /// assert_eq!(pair.cast_ray(&ray, |_, r| r.intersect_aabb(&b)).unwrap().primitive, 7);
    /// // Once it has aged, rebuild it.
    /// pair.refresh_dynamic_ray_snapshot(&config, false);
    /// assert_eq!(pair.dynamic_ray_snapshot_moving_refits(), Some(0));
    /// ```
    pub fn refresh_dynamic_ray_snapshot(
        &mut self,
        config: &BuildConfig,
        in_background: bool,
    ) -> bool {
        if in_background {
            self.dynamic_rays.start(&self.dynamic, config, true)
        } else {
            self.dynamic_rays.make(&self.dynamic, config, true)
        }
    }

    /// Builds a 16-wide tree over the dynamic tree's leaves that rays walk instead of the
    /// binary tree, until the next [`Self::dynamic_mut`] (updates through
    /// [`Self::update_dynamic`] refit it instead). Returns whether a snapshot is held
    /// afterwards (none is made of an empty tree). It reads only the leaves' ids and tight
    /// boxes, so it does not wait for a refit of the inner boxes.
    ///
    /// Why: a binary tree is deep, and a ray through one visits several times as many nodes
    /// as through a wide one (on the picking bench, 52 binary nodes per ray at 10,000
    /// entities, against about 10 wide ones). Rebuilding the wide form after every change
    /// would cost more than the rays save, so call this when the dynamic tree has stopped
    /// changing: it costs one build over the leaves, and then nothing until the tree changes.
    ///
    /// The snapshot is built with `config` over the leaves' tight boxes (not the fat ones,
    /// and not in the dynamic tree's shape, which are both made for motion): rays through it
    /// are as fast as through a static tree built with `config` over the same boxes.
    ///
    /// ```
    /// use accel::{Aabb, BuildConfig, Bvh, Ray, SpatialQuery};
    /// use accel::dynamic::{DynamicBvh, StaticDynamicPair};
    /// use glam::Vec3A;
    ///
    /// let mut pair = StaticDynamicPair::new(Bvh::default(), DynamicBvh::new());
    /// let b = Aabb::new(Vec3A::splat(1.0), Vec3A::splat(2.0));
    /// pair.dynamic_mut().insert(7, b).unwrap();
    /// pair.dynamic_mut().maintain();
    /// assert!(pair.snapshot_dynamic_for_rays(&BuildConfig::default()));
    /// let ray = Ray::new(Vec3A::ZERO, Vec3A::ONE.normalize());
    /// assert_eq!(pair.cast_ray(&ray, |_, r| r.intersect_aabb(&b)).unwrap().primitive, 7);
    /// pair.dynamic_mut(); // any change of the dynamic tree drops the snapshot
    /// assert!(!pair.has_dynamic_ray_snapshot());
    /// ```
    pub fn snapshot_dynamic_for_rays(&mut self, config: &BuildConfig) -> bool {
        self.dynamic_rays.make(&self.dynamic, config, false)
    }

    /// [`Self::snapshot_dynamic_for_rays`] on another thread, for trees whose snapshot would
    /// take too long for one frame: the caller's cost is one pass over the dynamic tree's
    /// nodes, collecting the leaves' ids and tight boxes.
    /// [`Self::poll_dynamic_ray_snapshot`] installs the result when it is done, unless the
    /// dynamic tree changed meanwhile. Returns whether a snapshot is held or being made.
    ///
    /// ```
    /// use accel::{Aabb, BuildConfig, Bvh, Ray, SpatialQuery};
    /// use accel::dynamic::{DynamicBvh, StaticDynamicPair};
    /// use glam::Vec3A;
    ///
    /// let mut pair = StaticDynamicPair::new(Bvh::default(), DynamicBvh::new());
    /// let b = Aabb::new(Vec3A::splat(1.0), Vec3A::splat(2.0));
    /// pair.dynamic_mut().insert(7, b).unwrap();
    /// pair.dynamic_mut().maintain();
    /// assert!(pair.start_dynamic_ray_snapshot(&BuildConfig::default()));
    /// while !pair.poll_dynamic_ray_snapshot() {
    ///     std::thread::yield_now();
    /// }
    /// let ray = Ray::new(Vec3A::ZERO, Vec3A::ONE.normalize());
    /// assert_eq!(pair.cast_ray(&ray, |_, r| r.intersect_aabb(&b)).unwrap().primitive, 7);
    /// ```
    pub fn start_dynamic_ray_snapshot(&mut self, config: &BuildConfig) -> bool {
        self.dynamic_rays.start(&self.dynamic, config, false)
    }

    /// Installs a snapshot finished on another thread (see
    /// [`Self::start_dynamic_ray_snapshot`]) if the dynamic tree has not changed since it was
    /// started; drops it otherwise. Never waits. Returns whether a snapshot is held.
    pub fn poll_dynamic_ray_snapshot(&mut self) -> bool {
        self.dynamic_rays.poll(&self.dynamic)
    }

    /// Whether a snapshot of the dynamic tree is being made on another thread.
    pub fn dynamic_ray_snapshot_pending(&self) -> bool {
        self.dynamic_rays.is_pending()
    }

    /// Whether rays walk a snapshot of the dynamic tree (see
    /// [`Self::snapshot_dynamic_for_rays`]).
    pub fn has_dynamic_ray_snapshot(&self) -> bool {
        self.dynamic_rays.wide().is_some()
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
    fn leaf_primitives(&self, node: u32) -> &[u32] {
        if node == VIRTUAL_ROOT {
            &[]
        } else if node & STATIC_TAG != 0 {
            self.static_tree.leaf_primitives(node & !STATIC_TAG)
        } else {
            self.dynamic.leaf_primitives(node)
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

impl RayWalk for StaticDynamicPair {
    fn walk_ray<V>(&self, ray: &mut Ray, visit: V)
    where
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        self.walk_ray_announcing(ray, |_| {}, visit);
    }

    fn walk_ray_announcing<A, V>(&self, ray: &mut Ray, mut announce: A, mut visit: V)
    where
        A: FnMut(u32),
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        let entry = |bounds: Aabb| ray.intersect_aabb(&bounds).unwrap_or(f32::INFINITY);
        let static_first = entry(self.static_wide.bounds()) <= entry(self.dynamic.bounds());
        let dynamic_wide = self.dynamic_rays.wide();
        // A visitor that stops the walk must stop the second tree's walk too.
        let stopped = core::cell::Cell::new(false);
        let mut visit = |p: u32, r: &mut Ray| {
            let flow = visit(p, r);
            stopped.set(flow.is_break());
            flow
        };
        if static_first {
            self.static_wide
                .walk_ray_announcing(ray, &mut announce, &mut visit);
            if !stopped.get() {
                walk_dynamic(dynamic_wide, &self.dynamic, ray, &mut announce, &mut visit);
            }
        } else {
            walk_dynamic(dynamic_wide, &self.dynamic, ray, &mut announce, &mut visit);
            if !stopped.get() {
                self.static_wide
                    .walk_ray_announcing(ray, &mut announce, &mut visit);
            }
        }
    }
}

/// The static tree as rays walk it: 16-wide, ids inlined. Why 16: a ray through a large
/// static world waits on each level's node in turn, and the 16-wide tree has a quarter fewer
/// levels than the 8-wide one (rays at 10^5 entities ran 3-5% faster, paired, before its node
/// test ran 8 lanes at a time, which took about 4% more off: BENCHMARKS.md). The collapse
/// costs about a third more than the 8-wide one (176 against 134 ms after a build over 10^6
/// entities).
fn wide_for_rays(static_tree: &Bvh) -> Bvh16 {
    let mut wide = Bvh16::from_bvh(static_tree);
    wide.inline_single_leaves();
    wide
}

/// Walks the dynamic tree's ray snapshot when there is one, else the binary tree.
fn walk_dynamic<A, V>(
    wide: Option<&Bvh16>,
    dynamic: &DynamicBvh,
    ray: &mut Ray,
    announce: A,
    visit: V,
) where
    A: FnMut(u32),
    V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
{
    match wide {
        Some(wide) => wide.walk_ray_announcing(ray, announce, visit),
        None => dynamic.walk_ray_announcing(ray, announce, visit),
    }
}

crate::impl_spatial_query_for_binary_tree!(@queries StaticDynamicPair);
