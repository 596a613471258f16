//! How rays walk a [`StaticDynamicPair`]: the static tree in its 16-wide form, the dynamic
//! tree in a 16-wide snapshot when one is held (`ray_snapshot`), the nearer tree first.
//!
//! Kept apart from the pair itself because this is a policy that changes on its own: when
//! the snapshot is built, refit, rebuilt in the background, polled and dropped. The pair's
//! other queries walk the binary trees and never see it.

use super::{DynamicBvh, StaticDynamicPair};
use crate::bvh::wide::Bvh16;
use crate::query::RayWalk;
use crate::{Aabb, BuildConfig, Bvh, Ray};
use core::ops::ControlFlow;

impl StaticDynamicPair {
    /// Drops the dynamic tree's ray snapshot (rays walk the binary tree) without touching the
    /// tree: for a caller whose rays are too few to pay for refitting it.
    pub fn drop_dynamic_ray_snapshot(&mut self) {
        self.dynamic_rays.invalidate();
    }

    /// Refits the dynamic tree's ray snapshot (if one is held) along the paths of the leaves
    /// updated since its last refit, so that rays walk it again.
    ///
    /// Why not drop it: in a world where a few entities move every frame, a dropped snapshot
    /// would leave rays on the binary tree for good, much slower per ray (BENCHMARKS.md,
    /// Picking). The snapshot's shape ages with the motion, as any refit
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
    /// use spatial_accel::{Aabb, BuildConfig, Bvh, Ray, SpatialQuery};
    /// use spatial_accel::dynamic::{DynamicBvh, StaticDynamicPair};
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
    /// as through a wide one (BENCHMARKS.md, Picking). Rebuilding the wide form after every change
    /// would cost more than the rays save, so call this when the dynamic tree has stopped
    /// changing: it costs one build over the leaves, and then nothing until the tree changes.
    ///
    /// The snapshot is built with `config` over the leaves' tight boxes (not the fat ones,
    /// and not in the dynamic tree's shape, which are both made for motion): rays through it
    /// are as fast as through a static tree built with `config` over the same boxes.
    ///
    /// ```
    /// use spatial_accel::{Aabb, BuildConfig, Bvh, Ray, SpatialQuery};
    /// use spatial_accel::dynamic::{DynamicBvh, StaticDynamicPair};
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
    /// use spatial_accel::{Aabb, BuildConfig, Bvh, Ray, SpatialQuery};
    /// use spatial_accel::dynamic::{DynamicBvh, StaticDynamicPair};
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

    /// Whether a snapshot made on another thread is done, so that
    /// [`Self::poll_dynamic_ray_snapshot`] would install or drop it. An engine that polls
    /// only then touches the pair mutably once per build, not every frame of it.
    pub fn dynamic_ray_snapshot_finished(&self) -> bool {
        self.dynamic_rays.is_finished()
    }

    /// Whether rays walk a snapshot of the dynamic tree (see
    /// [`Self::snapshot_dynamic_for_rays`]).
    pub fn has_dynamic_ray_snapshot(&self) -> bool {
        self.dynamic_rays.wide().is_some()
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
/// levels than the 8-wide one (faster rays, the more so with its node test 8 lanes at a
/// time: BENCHMARKS.md, Picking). The collapse costs more than the 8-wide one
/// (BENCHMARKS.md, Static BVH builds).
pub(super) fn wide_for_rays(static_tree: &Bvh) -> Bvh16 {
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
