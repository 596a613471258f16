//! The loops of a flat list: every query a test of each `(id, box)` entry in storage order.
//! Shared by [`BruteForceIndex`](super::BruteForceIndex), the oracle, and
//! [`KeyedList`](super::KeyedList), the list of fast movers, so both answer alike.

use super::views::{ViewClassification, ViewMasks};
use crate::geometry::RayLanes;
use crate::{Aabb, Containment, Frustum, Ray, Sphere};
use core::ops::ControlFlow;
use glam::Vec3A;

/// Every entry whose box the ray enters within its current range.
///
/// The boxes are tested four at a time lane-wise ([`RayLanes`]) at the range the ray had
/// before the four, and each box kept is tested again at the current range before it is
/// visited: `visit` may shrink the range (a closest-hit search), and the lanes then kept a
/// box the shrunk ray misses. So the boxes visited, and their order, are the one-by-one
/// loop's.
pub(crate) fn walk_ray<'a, V>(
    entries: impl Iterator<Item = (u32, &'a Aabb)>,
    ray: &mut Ray,
    mut visit: V,
) -> ControlFlow<()>
where
    V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
{
    // Untraceable rays are turned away as the trees turn them away (see `Ray::is_traceable`).
    if !ray.is_traceable() {
        return ControlFlow::Continue(());
    }
    let lanes = RayLanes::new(ray);
    let mut entries = entries.peekable();
    while entries.peek().is_some() {
        let group: [Option<(u32, &Aabb)>; 4] = core::array::from_fn(|_| entries.next());
        let [Some(a), Some(b), Some(c), Some(d)] = group else {
            for (id, b) in group.into_iter().flatten() {
                if ray.intersect_aabb(b).is_some() {
                    visit(id, ray)?;
                }
            }
            break;
        };
        let mut kept = lanes.hits([a.1, b.1, c.1, d.1], ray.t_min, ray.t_max);
        while kept != 0 {
            let (id, b) = [a, b, c, d][kept.trailing_zeros() as usize];
            kept &= kept - 1;
            if ray.intersect_aabb(b).is_some() {
                visit(id, ray)?;
            }
        }
    }
    ControlFlow::Continue(())
}

/// Every entry whose box overlaps `aabb`.
pub(crate) fn overlapping_aabb<'a>(
    entries: impl Iterator<Item = (u32, &'a Aabb)>,
    aabb: &Aabb,
    mut visit: impl FnMut(u32) -> ControlFlow<()>,
) {
    for (id, b) in entries {
        if b.intersects_aabb(aabb) && visit(id).is_break() {
            return;
        }
    }
}

/// Every entry whose box overlaps `sphere`.
pub(crate) fn overlapping_sphere<'a>(
    entries: impl Iterator<Item = (u32, &'a Aabb)>,
    sphere: &Sphere,
    mut visit: impl FnMut(u32) -> ControlFlow<()>,
) {
    for (id, b) in entries {
        if sphere.intersects_aabb(b) && visit(id).is_break() {
            return;
        }
    }
}

/// Every entry whose box contains `point`.
pub(crate) fn containing_point<'a>(
    entries: impl Iterator<Item = (u32, &'a Aabb)>,
    point: Vec3A,
    mut visit: impl FnMut(u32) -> ControlFlow<()>,
) {
    for (id, b) in entries {
        if b.contains_point(point) && visit(id).is_break() {
            return;
        }
    }
}

/// Every entry not outside `frustum`, with its classification.
pub(crate) fn in_frustum<'a>(
    entries: impl Iterator<Item = (u32, &'a Aabb)>,
    frustum: &Frustum,
    mut visit: impl FnMut(u32, Containment),
) {
    for (id, b) in entries {
        match frustum.classify_aabb(b) {
            Containment::Outside => {}
            c => visit(id, c),
        }
    }
}

/// Every entry some of the `views` may see, with its masks.
pub(crate) fn in_views<'a>(
    entries: impl Iterator<Item = (u32, &'a Aabb)>,
    views: u32,
    mut classify: impl FnMut(&Aabb, u32) -> ViewClassification,
    mut visit: impl FnMut(u32, ViewMasks),
) {
    if views == 0 {
        return;
    }
    for (id, b) in entries {
        if let Some(masks) = ViewMasks::undecided(views).below(classify(b, views)) {
            visit(id, masks);
        }
    }
}

/// The `k` entries nearest by the caller's distance, nearest first (ties by id); NaN
/// distances left out.
pub(crate) fn nearest_k(
    ids: impl Iterator<Item = u32>,
    k: usize,
    mut distance_squared: impl FnMut(u32) -> f32,
) -> Vec<(u32, f32)> {
    let mut all: Vec<(u32, f32)> = ids
        .map(|id| (id, distance_squared(id)))
        .filter(|(_, d2)| !d2.is_nan())
        .collect();
    all.sort_unstable_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
    all.truncate(k);
    all
}
