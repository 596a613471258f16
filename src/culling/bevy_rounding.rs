//! Tree verdicts that Bevy's own `f32` tests cannot contradict.
//!
//! A walk drops a subtree whose box lies behind a plane, and accepts one lying in front of
//! every plane, without Bevy's per-entity test. Bevy tests each entity's oriented box from its
//! own `Aabb` and `GlobalTransform`, in `f32`; the tree holds a world box computed from the
//! same numbers by other operations, so the two agree only up to rounding. A box that touches
//! a plane can then be "behind" it for the tree and touching for Bevy: an adversarial search
//! (boxes up to 1e6 from the origin, a third of them flat, planes through their corners,
//! nudged by a few ulps) finds such false negatives. Classifying the tree box grown by a few
//! ulps of its coordinates leaves room for that rounding: the same search finds none (the
//! test below). The planes walked are Bevy's own, made safe for the trees
//! where Bevy's test would read them differently ([`tree_plane`]).

use crate::trees::AccelTrees;
use bevy::math::{Vec3A, Vec4};
use bevy::tasks::ComputeTaskPool;
use core::ops::Range;
use spatial_accel::query::views::ViewClassification;
use spatial_accel::query::{CHUNK_LEN, KeyedList};
use spatial_accel::{Aabb, Containment, Frustum, FrustumLanes};

/// `b` grown by a few ulps of its largest coordinate (and a little more near the origin).
#[inline]
pub(crate) fn grown_past_rounding(b: &Aabb) -> Aabb {
    let slack = b.min.abs().max(b.max.abs()).max_element() * 4e-6 + 1e-6;
    Aabb::new(b.min - Vec3A::splat(slack), b.max + Vec3A::splat(slack))
}

/// How a tree box stands with a frustum, as a verdict Bevy's per-entity test will agree
/// with: `Outside` only if Bevy's test drops every entity in it, `Inside` only if it keeps
/// them. The frustum comes with its side planes laid out lane-wise (made once a walk), which
/// drops a box without a branch per plane.
#[inline]
pub(crate) fn classify_for_bevy(frustum: &FrustumLanes, b: &Aabb) -> Containment {
    frustum.classify_aabb(&grown_past_rounding(b))
}

/// Which of the trees' layers a frustum walk covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum WalkedLayers {
    /// The static tree, the dynamic index and the busy movers.
    All,
    /// The static tree and the dynamic index, not the busy movers: for a walk whose finds
    /// among them would be thrown away (the flat pass gives every busy mover Bevy's test).
    TreesOnly,
    /// The busy movers alone: for a view whose finds in the static tree and the dynamic
    /// index still hold (neither changed since they were walked).
    BusyMoversOnly,
}

/// Where a walk found a slot: the busy movers' finds always come after the trees'.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum FoundIn {
    /// The static tree or the dynamic index.
    Trees,
    /// The busy movers' list.
    BusyMovers,
}

/// Calls `visit(layer, slot, containment)` for each slot whose tree box the frustum does not
/// drop, with `Inside` where a whole subtree was accepted ([`classify_for_bevy`] at every
/// node). The busy movers come last; when they are many and the compute pool has more than
/// one thread, they are tested on the pool while this thread walks the trees.
pub(crate) fn walk_frustum_for_bevy(
    trees: &AccelTrees,
    frustum: &Frustum,
    layers: WalkedLayers,
    mut visit: impl FnMut(FoundIn, u32, Containment),
) {
    let frustum = &FrustumLanes::new(frustum);
    let busy = trees.index().busy_movers();
    let chunks = match layers {
        WalkedLayers::All | WalkedLayers::BusyMoversOnly => busy.chunk_count(),
        WalkedLayers::TreesOnly => 0,
    };
    let walk_trees = layers != WalkedLayers::BusyMoversOnly;
    let pool = ComputeTaskPool::try_get()
        .filter(|pool| pool.thread_num() > 1 && chunks * CHUNK_LEN >= CONCURRENT_BUSY_FROM);
    let Some(pool) = pool else {
        if walk_trees {
            walk_trees_for_bevy(trees, frustum, &mut |slot, c| {
                visit(FoundIn::Trees, slot, c)
            });
        }
        busy_movers_for_bevy(busy, 0..chunks, frustum, &mut |slot, c| {
            visit(FoundIn::BusyMovers, slot, c);
        });
        return;
    };
    // Why: the trees' walk and the busy movers' tests are independent, and each is a serial
    // loop; a view that waits for both in turn does not get faster with threads, where Bevy's
    // own loop does (issue 72). The scope's body walks the trees on this thread while the
    // pool's other threads take the movers' parts.
    let part = chunks
        .div_ceil(pool.thread_num() * 4)
        .max(CONCURRENT_BUSY_FROM / 4 / CHUNK_LEN);
    let parts: Vec<Vec<(u32, Containment)>> = pool.scope(|scope| {
        for from in (0..chunks).step_by(part) {
            scope.spawn(async move {
                let mut found = Vec::new();
                let to = (from + part).min(chunks);
                busy_movers_for_bevy(busy, from..to, frustum, &mut |id, containment| {
                    found.push((id, containment));
                });
                found
            });
        }
        if walk_trees {
            walk_trees_for_bevy(trees, frustum, &mut |slot, c| {
                visit(FoundIn::Trees, slot, c)
            });
        }
    });
    for (slot, containment) in parts.into_iter().flatten() {
        visit(FoundIn::BusyMovers, slot, containment);
    }
}

/// From this many busy movers, with more than one compute thread, a view's test of them runs
/// on the pool beside its walk of the trees.
const CONCURRENT_BUSY_FROM: usize = 4_096;

/// The busy movers of `chunks` the frustum does not drop, as [`walk_frustum_for_bevy`] gives
/// them. A chunk whose bounds the frustum drops is skipped whole: the verdict on a box is
/// monotone (a box inside a dropped box is dropped, in `f32` too), and the growth past
/// rounding only grows with the box.
fn busy_movers_for_bevy(
    busy: &KeyedList,
    chunks: Range<usize>,
    frustum: &FrustumLanes,
    visit: &mut impl FnMut(u32, Containment),
) {
    for c in chunks {
        let chunk = busy.chunk(c);
        if chunk
            .bounds
            .is_some_and(|b| classify_for_bevy(frustum, b) == Containment::Outside)
        {
            continue;
        }
        for entry in chunk.entries {
            match classify_for_bevy(frustum, &entry.bounds) {
                Containment::Outside => {}
                containment => visit(entry.id, containment),
            }
        }
    }
}

/// The static tree and the dynamic index: [`walk_frustum_for_bevy`] without the busy movers.
fn walk_trees_for_bevy(
    trees: &AccelTrees,
    frustum: &FrustumLanes,
    visit: &mut impl FnMut(u32, Containment),
) {
    let classify = |b: &Aabb, _| match classify_for_bevy(frustum, b) {
        Containment::Inside => ViewClassification {
            inside: 1,
            outside: 0,
        },
        Containment::Outside => ViewClassification {
            inside: 0,
            outside: 1,
        },
        Containment::Intersecting => ViewClassification::default(),
    };
    trees
        .index()
        .for_each_in_views_of_trees(1, classify, |slot, masks| {
            let containment = if masks.inside != 0 {
                Containment::Inside
            } else {
                Containment::Intersecting
            };
            visit(slot, containment);
        });
}

/// A half-space of a Bevy frustum as the trees must test it to keep every entity Bevy's
/// oriented-box test keeps. Bevy calls a box outside when `normal_d . (center, 1) + r <= 0`:
/// - with a zero normal (an unset `Frustum`, before a camera's first update) `r` is 0, so
///   every box is outside unless `d > 0`; the trees' plane type would keep everything;
/// - with a NaN or infinite normal the comparison is false or undefined: nothing may be
///   dropped, so such a half-space holds all space.
pub(crate) fn tree_plane(v: Vec4) -> Vec4 {
    const ALL_SPACE: Vec4 = Vec4::new(0.0, 0.0, 0.0, 1.0);
    const NO_SPACE: Vec4 = Vec4::new(0.0, 0.0, 0.0, -1.0);
    let normal = v.truncate();
    if !normal.is_finite() || v.w.is_nan() {
        ALL_SPACE
    } else if normal == bevy::math::Vec3::ZERO {
        if v.w > 0.0 { ALL_SPACE } else { NO_SPACE }
    } else {
        v
    }
}

#[cfg(test)]
mod tests {
    use super::{classify_for_bevy, tree_plane};
    use crate::culling::bevy_rules::bevy_frustum_test;
    use crate::trees::placement;
    use accel_testkit::Rng;
    use bevy::camera::primitives::{Aabb, Frustum};
    use bevy::math::primitives::{HalfSpace, ViewFrustum};
    use bevy::math::{Vec3A, Vec4};
    use bevy::prelude::*;
    use spatial_accel::{Containment, Frustum as AccelFrustum, FrustumLanes};

    /// Entities up to 1e6 from the origin, each with a near plane through the corner of its
    /// world box that the plane's normal points away from (in front) or towards (behind),
    /// nudged by up to 8 ulps, a third of them flat: the tree's verdict must never contradict
    /// Bevy's camera test. Without the growth, some are dropped by the tree and kept by Bevy.
    #[test]
    fn tree_verdicts_never_contradict_bevys_test_at_a_touching_plane() {
        let mut rng = Rng::new(3);
        let all_space = HalfSpace::new(Vec4::new(1.0, 0.0, 0.0, 1e30));
        let (mut dropped, mut accepted) = (0, 0);
        for i in 0..2_000_000 {
            let far = [1.0f32, 1e3, 1e5, 1e6][i % 4];
            let rotation = Quat::from_euler(
                EulerRot::XYZ,
                rng.range(0.0, 6.3),
                rng.range(0.0, 6.3),
                rng.range(0.0, 6.3),
            );
            let transform = GlobalTransform::from(
                Transform::from_translation(rng.vec3(-far, far))
                    .with_rotation(rotation)
                    .with_scale(rng.vec3(0.3, 3.0)),
            );
            let mut aabb = Aabb::from_min_max(rng.vec3(-2.0, 0.0), rng.vec3(0.0, 2.0));
            if i % 3 == 0 {
                // Flat boxes (a quad's): no extent along one local axis.
                aabb.half_extents[i / 3 % 3] = 0.0;
            }
            let Ok(world) = placement(&aabb, &transform).map(|at| at.world) else {
                continue;
            };
            let normal = Vec3A::from(rng.vec3(-1.0, 1.0).normalize());
            // The box's lowest point along the normal.
            let corner = Vec3A::select(normal.cmpgt(Vec3A::ZERO), world.min, world.max);
            let nudge = rng.range(-8.0, 8.0).round() * f32::EPSILON * corner.abs().max_element();
            // Even cases: the box in front of the plane; odd: behind it, touching.
            let normal = if i % 2 == 0 { normal } else { -normal };
            let mut half_spaces = [all_space; 6];
            half_spaces[ViewFrustum::NEAR_PLANE_IDX] =
                HalfSpace::new(normal.extend(-normal.dot(corner) + nudge));
            let frustum = Frustum(ViewFrustum { half_spaces });
            let kept = bevy_frustum_test(&frustum, Some(&aabb), None, &transform);
            let planes = frustum.half_spaces.map(|h| tree_plane(h.normal_d()));
            match classify_for_bevy(
                &FrustumLanes::new(&AccelFrustum::from_planes(planes)),
                &world,
            ) {
                Containment::Outside if kept => dropped += 1,
                Containment::Inside if !kept => accepted += 1,
                _ => {}
            }
        }
        assert_eq!(
            (dropped, accepted),
            (0, 0),
            "tree verdicts contradicting Bevy: dropped but kept, accepted but dropped"
        );
    }
}
