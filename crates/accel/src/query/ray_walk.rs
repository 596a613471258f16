//! Closest, any and all hits, written once over any structure that can walk a ray.

use super::RayHit;
use super::binary::sort_hits;
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
}

/// The closest hit: a hit is kept when it lies in the ray's range and beats the best so far;
/// the range then shrinks to it, which prunes the rest of the walk.
pub fn closest_hit<W, F>(walk: &W, ray: &Ray, mut hit: F) -> Option<RayHit>
where
    W: RayWalk + ?Sized,
    F: FnMut(u32, &Ray) -> Option<f32>,
{
    let mut ray = *ray;
    let mut best: Option<RayHit> = None;
    walk.walk_ray(&mut ray, |p, ray| {
        if let Some(t) = hit(p, ray)
            && t >= ray.t_min
            && t <= ray.t_max
            && best.is_none_or(|b| t < b.t)
        {
            ray.t_max = t;
            best = Some(RayHit { primitive: p, t });
        }
        ControlFlow::Continue(())
    });
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
    walk.walk_ray(&mut ray, |p, ray| {
        if hit(p, ray) {
            found = Some(p);
            return ControlFlow::Break(());
        }
        ControlFlow::Continue(())
    });
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
    walk.walk_ray(&mut ray, |p, ray| {
        if let Some(t) = hit(p, ray)
            && t >= ray.t_min
            && t <= ray.t_max
        {
            out.push(RayHit { primitive: p, t });
        }
        ControlFlow::Continue(())
    });
    sort_hits(&mut out[start..]);
}
