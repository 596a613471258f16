//! Closest, any and all hits, written once over any structure that can walk a ray.

use super::RayHit;
use super::walks::sort_hits;
use crate::Ray;
use core::ops::ControlFlow;

/// A structure that visits the primitives a ray may hit, nearer regions first, skipping
/// regions that start beyond `ray.t_max` (which the visitor may shrink as hits are found).
///
/// Each structure writes only this walk; the three ray queries of
/// [`SpatialQuery`](super::SpatialQuery) are built on it by [`closest_hit`], [`any_hit`] and
/// [`all_hits`], so their acceptance rules cannot drift apart between structures.
pub trait RayWalk {
    /// Calls `visit(primitive, ray)` for each candidate until it breaks or none are left.
    fn walk_ray<V>(&self, ray: &mut Ray, visit: V)
    where
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>;

    /// As [`RayWalk::walk_ray`], but regions in any order (still skipping those that start
    /// beyond `ray.t_max`): for visitors that stop at the first hit whatever its distance
    /// ([`any_hit`]), which gain nothing from the sorting. The default walks in order.
    fn walk_ray_any_order<V>(&self, ray: &mut Ray, visit: V)
    where
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        self.walk_ray(ray, visit);
    }

    /// As [`RayWalk::walk_ray`], and where a node's test finds several leaves in range, first
    /// calls `announce(primitive)` for every primitive in them, before visiting any.
    ///
    /// Why: a visitor whose test reads records of its own at scattered places (an entity's
    /// transform, a mesh) waits on one cache miss per primitive, in turn. Told the next few
    /// primitives at once, it can ask for all their records together, and the misses overlap.
    /// Structures without wide nodes announce nothing (the default).
    fn walk_ray_announcing<A, V>(&self, ray: &mut Ray, announce: A, visit: V)
    where
        A: FnMut(u32),
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        let _ = announce;
        self.walk_ray(ray, visit);
    }
}

/// The closest hit: a hit is kept when it lies in the ray's range and beats the best so far;
/// the range then shrinks to it, which prunes the rest of the walk.
pub fn closest_hit<W, F>(walk: &W, ray: &Ray, hit: F) -> Option<RayHit>
where
    W: RayWalk + ?Sized,
    F: FnMut(u32, &Ray) -> Option<f32>,
{
    closest_hit_announcing(walk, ray, |_| {}, hit)
}

/// [`closest_hit`] over [`RayWalk::walk_ray_announcing`]: `announce` hears of candidates
/// before `hit` tests them, so it can start loading what `hit` will read.
pub fn closest_hit_announcing<W, A, F>(
    walk: &W,
    ray: &Ray,
    announce: A,
    mut hit: F,
) -> Option<RayHit>
where
    W: RayWalk + ?Sized,
    A: FnMut(u32),
    F: FnMut(u32, &Ray) -> Option<f32>,
{
    let mut ray = *ray;
    let mut best: Option<RayHit> = None;
    walk.walk_ray_announcing(
        &mut ray,
        announce,
        // Inlined into the walk, so that `hit` is compiled with it (see `visit_ray`).
        #[inline(always)]
        |p, ray| {
            if let Some(t) = hit(p, ray)
                && t >= ray.t_min
                && t <= ray.t_max
                && best.is_none_or(|b| t < b.t)
            {
                ray.t_max = t;
                best = Some(RayHit { primitive: p, t });
            }
            ControlFlow::Continue(())
        },
    );
    best
}

/// The first primitive for which `hit` says yes (occlusion).
pub fn any_hit<W, F>(walk: &W, ray: &Ray, mut hit: F) -> Option<u32>
where
    W: RayWalk + ?Sized,
    F: FnMut(u32, &Ray) -> bool,
{
    let mut ray = *ray;
    let mut found = None;
    walk.walk_ray_any_order(
        &mut ray,
        // Inlined into the walk, so that `hit` is compiled with it (see `visit_ray`).
        #[inline(always)]
        |p, ray| {
            if hit(p, ray) {
                found = Some(p);
                return ControlFlow::Break(());
            }
            ControlFlow::Continue(())
        },
    );
    found
}

/// Every hit in the ray's range, appended to `out` sorted by distance, then id.
pub fn all_hits<W, F>(walk: &W, ray: &Ray, mut hit: F, out: &mut Vec<RayHit>)
where
    W: RayWalk + ?Sized,
    F: FnMut(u32, &Ray) -> Option<f32>,
{
    let start = out.len();
    let mut ray = *ray;
    walk.walk_ray(
        &mut ray,
        // Inlined into the walk, so that `hit` is compiled with it (see `visit_ray`).
        #[inline(always)]
        |p, ray| {
            if let Some(t) = hit(p, ray)
                && t >= ray.t_min
                && t <= ray.t_max
            {
                out.push(RayHit { primitive: p, t });
            }
            ControlFlow::Continue(())
        },
    );
    sort_hits(&mut out[start..]);
}
