//! Every box query of a structure against `spatial_accel::query::BruteForceIndex` over the same
//! entries, after the exact test on each candidate (as the conformance suite compares).

use super::{Failure, Tally};
use core::ops::ControlFlow;
use glam::Vec3A;
use spatial_accel::query::BruteForceIndex;
use spatial_accel::{Aabb, Frustum, Ray, RayHit, SpatialQuery, Sphere};
use std::collections::HashMap;

/// The queries of [`SpatialQuery`] with their callbacks fixed, so that structures of every
/// type sit in one list (`SpatialQuery`'s generic methods are not object safe).
pub trait Queries {
    /// Closest hit, the exact test the ray/box test of the entry's box.
    fn closest(&self, ray: &Ray, live: &HashMap<u32, Aabb>, stale: &mut u64) -> Option<RayHit>;
    /// Any hit.
    fn any(&self, ray: &Ray, live: &HashMap<u32, Aabb>) -> bool;
    /// Every hit.
    fn all(&self, ray: &Ray, live: &HashMap<u32, Aabb>) -> Vec<RayHit>;
    /// The candidates of a box, sphere, point or frustum query.
    fn candidates(&self, q: &Volume) -> Vec<u32>;
    /// The k nearest, exact distances from the entries' boxes.
    fn nearest(&self, p: Vec3A, k: usize, live: &HashMap<u32, Aabb>) -> Vec<(u32, f32)>;
}

/// A volume query.
#[derive(Clone, Copy, Debug)]
pub enum Volume {
    /// Boxes overlapping a box.
    Box(Aabb),
    /// Boxes overlapping a sphere.
    Sphere(Sphere),
    /// Boxes holding a point.
    Point(Vec3A),
    /// Boxes not outside a frustum.
    Frustum(Frustum),
}

impl Volume {
    /// The query's name in the tally.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Box(_) => "aabb overlap",
            Self::Sphere(_) => "sphere overlap",
            Self::Point(_) => "point",
            Self::Frustum(_) => "frustum",
        }
    }

    /// The exact test on an entry's box.
    pub fn accepts(&self, b: &Aabb) -> bool {
        match self {
            Self::Box(q) => b.intersects_aabb(q),
            // An invalid sphere (non-finite centre, NaN or negative radius) holds nothing:
            // `Sphere::intersects_aabb` says no for it, as every structure does.
            Self::Sphere(s) => s.intersects_aabb(b),
            Self::Point(p) => b.contains_point(*p),
            Self::Frustum(f) => f.intersects_aabb(b),
        }
    }
}

impl<T: SpatialQuery> Queries for T {
    fn closest(&self, ray: &Ray, live: &HashMap<u32, Aabb>, stale: &mut u64) -> Option<RayHit> {
        // An entry with invalid bounds is never hit (the oracle refuses it); a static tree
        // built over it may still offer it as a candidate.
        self.cast_ray(ray, |id, r| match live.get(&id) {
            Some(b) => valid(b).and_then(|b| r.intersect_aabb(b)),
            None => {
                *stale += 1;
                None
            }
        })
    }
    fn any(&self, ray: &Ray, live: &HashMap<u32, Aabb>) -> bool {
        self.cast_ray_any(ray, |id, r| {
            live.get(&id)
                .and_then(valid)
                .is_some_and(|b| r.hits_aabb(b))
        })
        .is_some()
    }
    fn all(&self, ray: &Ray, live: &HashMap<u32, Aabb>) -> Vec<RayHit> {
        let mut out = Vec::new();
        self.cast_ray_all(
            ray,
            |id, r| {
                live.get(&id)
                    .and_then(valid)
                    .and_then(|b| r.intersect_aabb(b))
            },
            &mut out,
        );
        out
    }
    fn candidates(&self, q: &Volume) -> Vec<u32> {
        let mut out = Vec::new();
        let mut push = |id| {
            out.push(id);
            ControlFlow::Continue(())
        };
        match q {
            Volume::Box(b) => self.for_each_overlapping_aabb(b, &mut push),
            Volume::Sphere(s) => self.for_each_overlapping_sphere(s, &mut push),
            Volume::Point(p) => self.for_each_containing_point(*p, &mut push),
            Volume::Frustum(f) => self.for_each_in_frustum(f, |id, _| {
                let _ = push(id);
            }),
        }
        out
    }
    fn nearest(&self, p: Vec3A, k: usize, live: &HashMap<u32, Aabb>) -> Vec<(u32, f32)> {
        self.nearest_k(p, k, |id| {
            live.get(&id)
                .and_then(valid)
                .map_or(f32::INFINITY, |b| b.distance_squared_to_point(p))
        })
    }
}

/// The box, if the oracle admits it: valid and finite (`BruteForceIndex` refuses the rest,
/// as every dynamic index does; a static tree holds them, and the exact test passes over).
fn valid(b: &Aabb) -> Option<&Aabb> {
    (b.is_valid() && b.is_finite()).then_some(b)
}

/// The oracle over `live` (its valid entries: the oracle refuses the others).
pub fn oracle_of(live: &HashMap<u32, Aabb>) -> BruteForceIndex {
    use spatial_accel::query::DynamicIndex;
    let mut o = BruteForceIndex::new();
    let mut ids: Vec<_> = live.iter().collect();
    ids.sort_by_key(|(id, _)| **id);
    for (&id, &b) in ids {
        let _ = o.insert(id, b);
    }
    o
}

/// Runs one ray through `s` and the oracle, closest, any and all, counting what differs.
pub fn check_ray(
    tally: &mut Tally,
    name: &str,
    s: &dyn Queries,
    oracle: &BruteForceIndex,
    live: &HashMap<u32, Aabb>,
    ray: &Ray,
) {
    let traceable = ray.is_traceable();
    if let Some((got, stale)) = tally.guard(name, "ray closest", |_| {
        let mut stale = 0;
        (s.closest(ray, live, &mut stale), stale)
    }) {
        let mut ignored = 0;
        // A hit at infinity (a box reached only in the limit, from extreme origins) is no
        // hit: the widened slab tests of the trees turn `inf` into NaN and miss it.
        let finite = |h: Option<RayHit>| h.filter(|h| h.t.is_finite());
        let (got, want) = (finite(got), finite(oracle.closest(ray, live, &mut ignored)));
        if stale > 0 {
            tally.fail(name, "ray closest", Failure::Leak, || {
                format!("{stale} stale ids for {ray:?}")
            });
        }
        if got.is_some_and(|h| h.t.is_nan()) {
            tally.fail(name, "ray closest", Failure::Nan, || format!("{ray:?}"));
        }
        let bad = match (got, want) {
            (Some(g), Some(w)) => g.t != w.t,
            (g, w) => g.is_some() != w.is_some(),
        };
        if bad || (!traceable && got.is_some()) {
            tally.fail(name, "ray closest", Failure::Miss, || {
                format!("{ray:?}: got {got:?}, oracle {want:?}")
            });
        }
    }
    if let Some(got) = tally.guard(name, "ray any", |_| s.any(ray, live)) {
        // Blocked when the oracle has a hit at a finite distance (see the closest hit).
        let mut ignored = 0;
        let closest = oracle.closest(ray, live, &mut ignored);
        let want = closest.is_some_and(|h| h.t.is_finite());
        // Blocked only at infinity: either answer stands. Minus infinity too: a ray with
        // `t_min = -inf` and a subnormal direction meets its boxes at `t = -inf`, which the
        // closest hit above discards as no hit, while an any-hit test rightly stops there.
        let at_infinity = closest.is_some_and(|h| h.t.is_infinite());
        if got != want && !at_infinity {
            tally.fail(name, "ray any", Failure::Miss, || {
                format!("{ray:?}: got {got}, oracle {want}")
            });
        }
    }
    if let Some(got) = tally.guard(name, "ray all", |_| s.all(ray, live)) {
        let finite = |v: Vec<RayHit>| -> Vec<RayHit> {
            v.into_iter()
                .filter(|h| h.t.is_finite() || h.t.is_nan())
                .collect()
        };
        let (got, want) = (finite(got), finite(oracle.all(ray, live)));
        check_ids(
            tally,
            name,
            "ray all",
            got.iter().map(|h| h.primitive).collect(),
            want.iter().map(|h| h.primitive).collect(),
            || format!("{ray:?}"),
        );
        if got.iter().any(|h| h.t.is_nan()) {
            tally.fail(name, "ray all", Failure::Nan, || format!("{ray:?}"));
        }
    }
}

/// Runs one volume query through `s` and the oracle.
pub fn check_volume(
    tally: &mut Tally,
    name: &str,
    s: &dyn Queries,
    oracle: &BruteForceIndex,
    live: &HashMap<u32, Aabb>,
    q: &Volume,
) {
    let query = q.name();
    let Some(got) = tally.guard(name, query, |_| s.candidates(q)) else {
        return;
    };
    let exact = |ids: Vec<u32>| -> Vec<u32> {
        ids.into_iter()
            .filter(|id| {
                live.get(id)
                    .is_none_or(|b| valid(b).is_some_and(|b| q.accepts(b)))
            })
            .collect()
    };
    let want = exact(oracle.candidates(q));
    check_ids(tally, name, query, exact(got), want, || format!("{q:?}"));
}

/// Runs one k-nearest query through `s` and the oracle: the same distances, in order.
pub fn check_nearest(
    tally: &mut Tally,
    name: &str,
    s: &dyn Queries,
    oracle: &BruteForceIndex,
    live: &HashMap<u32, Aabb>,
    p: Vec3A,
    k: usize,
) {
    let Some(got) = tally.guard(name, "nearest k", |_| s.nearest(p, k, live)) else {
        return;
    };
    // Entries at no finite distance (invalid bounds, or a non-finite point) are not ranked.
    let finite = |v: Vec<(u32, f32)>| -> Vec<(u32, f32)> {
        v.into_iter().filter(|x| x.1 < f32::INFINITY).collect()
    };
    if got.iter().any(|(_, d)| d.is_nan()) {
        tally.fail(name, "nearest k", Failure::Nan, || format!("{p:?} k={k}"));
    }
    let (got, want) = (finite(got), finite(oracle.nearest(p, k, live)));
    let d = |v: &[(u32, f32)]| v.iter().map(|x| x.1.to_bits()).collect::<Vec<_>>();
    if d(&got) != d(&want) {
        tally.fail(name, "nearest k", Failure::Miss, || {
            format!("{p:?} k={k}: got {got:?}, oracle {want:?}")
        });
    }
    let ids: Vec<u32> = got.iter().map(|x| x.0).collect();
    check_unique(tally, name, "nearest k", ids, || format!("{p:?}"));
}

/// Reported ids against the oracle's: one missing is a miss; one not live, or reported
/// twice, a leak.
pub fn check_ids(
    tally: &mut Tally,
    name: &str,
    query: &str,
    got: Vec<u32>,
    mut want: Vec<u32>,
    what: impl Fn() -> String,
) {
    let got = check_unique(tally, name, query, got, &what);
    want.sort_unstable();
    want.dedup();
    let missing = want
        .iter()
        .filter(|id| got.binary_search(id).is_err())
        .count();
    let extra = got
        .iter()
        .filter(|id| want.binary_search(id).is_err())
        .count();
    if missing > 0 {
        tally.fail(name, query, Failure::Miss, || {
            format!("{missing} missing: {}", what())
        });
    }
    if extra > 0 {
        tally.fail(name, query, Failure::Leak, || {
            format!("{extra} not in the oracle: {}", what())
        });
    }
}

/// Sorts the ids; a repeat is a leak.
fn check_unique(
    tally: &mut Tally,
    name: &str,
    query: &str,
    mut ids: Vec<u32>,
    what: impl Fn() -> String,
) -> Vec<u32> {
    ids.sort_unstable();
    let n = ids.len();
    ids.dedup();
    if ids.len() != n {
        tally.fail(name, query, Failure::Leak, || {
            format!("{} repeats: {}", n - ids.len(), what())
        });
    }
    ids
}
