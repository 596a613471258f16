//! Triangles and the watertight ray/triangle test.

use crate::{Aabb, Ray};
use glam::{DVec3, Vec3A};

/// A triangle by its three corners. Counter-clockwise corners (seen from the front) make the
/// front face, as in Bevy and glTF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    /// The corners, in winding order.
    pub vertices: [Vec3A; 3],
}

/// Where a ray met a triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    /// The ray parameter of the hit.
    pub t: f32,
    /// Barycentric weights of vertices 1 and 2; vertex 0 has `1 - u - v`.
    pub u: f32,
    /// See [`TriangleHit::u`].
    pub v: f32,
    /// True when the ray met the front (counter-clockwise) side.
    pub front_face: bool,
}

impl TriangleHit {
    /// All three barycentric weights, vertex 0 first.
    #[inline]
    pub fn barycentrics(&self) -> [f32; 3] {
        [1.0 - self.u - self.v, self.u, self.v]
    }
}

/// Which sides of a triangle a ray may hit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Backfaces {
    /// Both sides count (Bevy's `Backfaces::Include`).
    #[default]
    Include,
    /// Only the front (counter-clockwise) side counts (Bevy's `Backfaces::Cull`).
    Cull,
}

impl Triangle {
    /// A triangle from its corners.
    #[inline]
    pub fn new(a: impl Into<Vec3A>, b: impl Into<Vec3A>, c: impl Into<Vec3A>) -> Self {
        Self {
            vertices: [a.into(), b.into(), c.into()],
        }
    }

    /// The bounding box of the corners.
    #[inline]
    pub fn aabb(&self) -> Aabb {
        Aabb::from_point(self.vertices[0])
            .grow(self.vertices[1])
            .grow(self.vertices[2])
    }

    /// The centroid of the corners.
    #[inline]
    pub fn centroid(&self) -> Vec3A {
        (self.vertices[0] + self.vertices[1] + self.vertices[2]) * (1.0 / 3.0)
    }

    /// The geometric normal `(b - a) x (c - a)`, not normalised (its length is twice the area);
    /// it points out of the front face.
    #[inline]
    pub fn normal(&self) -> Vec3A {
        let [a, b, c] = self.vertices;
        (b - a).cross(c - a)
    }

    /// The watertight ray/triangle test: see [`WatertightRay::intersect`]. Prefer building one
    /// [`WatertightRay`] per ray when testing many triangles.
    #[inline]
    pub fn intersect(&self, ray: &Ray, backfaces: Backfaces) -> Option<TriangleHit> {
        WatertightRay::new(ray).intersect(self, backfaces)
    }
}

/// A ray prepared for the watertight ray/triangle test of Woop, Benthin and Wald 2013
/// ("Watertight Ray/Triangle Intersection", JCGT 2(1)).
///
/// The test translates the triangle to the ray origin, shears it so the ray runs down the `z`
/// axis, and decides inside/outside with three 2D edge functions. A shared edge is computed from
/// the same two sheared vertices by both triangles, so its edge function is bit-for-bit the same
/// number with opposite signs: a ray through a shared edge or vertex of a closed mesh hits at
/// least one side, never none. Möller-Trumbore with an epsilon (Bevy's) leaks there and misses
/// small triangles. When an edge function is exactly zero, it is recomputed in `f64`, as the
/// paper prescribes, so that rounding cannot break a tie the wrong way.
#[derive(Clone, Copy, Debug)]
pub struct WatertightRay {
    pub(super) origin: Vec3A,
    pub(super) t_min: f32,
    pub(super) t_max: f32,
    /// Permuted axes: `kz` is the dominant direction axis; `kx`, `ky` keep the winding.
    pub(super) kx: usize,
    pub(super) ky: usize,
    pub(super) kz: usize,
    pub(super) shear_x: f32,
    pub(super) shear_y: f32,
    pub(super) shear_z: f32,
}

impl WatertightRay {
    /// Precomputes the axis permutation and shear for a ray.
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        // Arrays and selects, not `Vec3A::max_position` and `Vec3A` indexed by a run-time axis
        // (each a `match`): on random directions their branches mispredict, which makes
        // preparing a ray far dearer; diffuse and incoherent mesh rays are faster without them
        // (BENCHMARKS.md, Rays on meshes).
        let d = ray.direction.to_array();
        let a = ray.direction.abs().to_array();
        // The first of the largest components (`max_position`'s rule; NaN picks x).
        let kz = if a[1] > a[0] { 1 } else { 0 };
        let kz = if a[2] > a[kz] { 2 } else { kz };
        let (next, after) = ([1, 2, 0][kz], [2, 0, 1][kz]);
        // A negative dominant axis mirrors the sheared space; swapping x and y undoes the
        // mirror so front faces stay front faces.
        let (kx, ky) = if d[kz] < 0.0 {
            (after, next)
        } else {
            (next, after)
        };
        // One vector division: each lane is the scalar quotient, to the bit.
        let shear = Vec3A::new(d[kx], d[ky], 1.0) / Vec3A::splat(d[kz]);
        Self {
            origin: ray.origin,
            t_min: ray.t_min,
            t_max: ray.t_max,
            kx,
            ky,
            kz,
            shear_x: shear.x,
            shear_y: shear.y,
            shear_z: shear.z,
        }
    }

    /// Shrinks the accepted range to `t <= t_max` (after a closer hit).
    #[inline]
    pub fn set_t_max(&mut self, t_max: f32) {
        self.t_max = self.t_max.min(t_max);
    }

    /// The current far end of the accepted range.
    #[inline]
    pub fn t_max(&self) -> f32 {
        self.t_max
    }

    /// Intersects one triangle; `None` on a miss, a hit outside `[t_min, t_max]` or at an
    /// infinite `t`, a culled back face, a degenerate (zero-area as seen by the ray) triangle,
    /// or a degenerate ray.
    #[inline]
    pub fn intersect(&self, tri: &Triangle, backfaces: Backfaces) -> Option<TriangleHit> {
        self.intersect_vertices(tri.vertices[0], tri.vertices[1], tri.vertices[2], backfaces)
    }

    /// [`WatertightRay::intersect`] on three corners given directly.
    #[inline]
    pub fn intersect_vertices(
        &self,
        v0: Vec3A,
        v1: Vec3A,
        v2: Vec3A,
        backfaces: Backfaces,
    ) -> Option<TriangleHit> {
        let (kx, ky, kz) = (self.kx, self.ky, self.kz);
        // Plain arrays: indexing `Vec3A` by a run-time axis goes through a `match`, which
        // costs more than the rest of the test; an array index is one load.
        let a = (v0 - self.origin).to_array();
        let b = (v1 - self.origin).to_array();
        let c = (v2 - self.origin).to_array();
        let ax = a[kx] - self.shear_x * a[kz];
        let ay = a[ky] - self.shear_y * a[kz];
        let bx = b[kx] - self.shear_x * b[kz];
        let by = b[ky] - self.shear_y * b[kz];
        let cx = c[kx] - self.shear_x * c[kz];
        let cy = c[ky] - self.shear_y * c[kz];

        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        // An edge function of exactly zero may be rounding's verdict, not geometry's: the
        // paper's fallback recomputes all three in double precision, where these products of
        // f32 values are exact.
        if u == 0.0 || v == 0.0 || w == 0.0 {
            let (axd, ayd, bxd, byd, cxd, cyd) = (
                ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64,
            );
            u = f64_to_f32_keep_sign(cxd * byd - cyd * bxd);
            v = f64_to_f32_keep_sign(axd * cyd - ayd * cxd);
            w = f64_to_f32_keep_sign(bxd * ayd - byd * axd);
        }

        let any_negative = u < 0.0 || v < 0.0 || w < 0.0;
        let any_positive = u > 0.0 || v > 0.0 || w > 0.0;
        if any_negative && any_positive {
            return None;
        }
        let det = u + v + w;
        // A NaN determinant (degenerate ray or NaN vertex) fails this test too.
        if !(det != 0.0) || det.is_nan() {
            return None;
        }
        // The edge functions are twice the signed areas of the sheared 2D triangle, positive
        // when its corners run counter-clockwise as seen looking down the ray (the axis swap
        // in `new` undoes the mirror of a negative dominant axis). Counter-clockwise as seen
        // from the origin is the front face, so the front face gives det > 0.
        let front_face = det > 0.0;
        if backfaces == Backfaces::Cull && !front_face {
            return None;
        }

        let az = self.shear_z * a[kz];
        let bz = self.shear_z * b[kz];
        let cz = self.shear_z * c[kz];
        let t_scaled = u * az + v * bz + w * cz;
        let inv_det = 1.0 / det;
        let t = t_scaled * inv_det;
        // A hit at an infinite distance (a subnormal direction, an origin at the end of the
        // float range) is a miss: no box test reaches it, so the trees never offered it and
        // the brute-force oracle alone reported it.
        if !(t >= self.t_min && t <= self.t_max) || t.is_infinite() {
            return None;
        }
        Some(TriangleHit {
            t,
            u: v * inv_det,
            v: w * inv_det,
            front_face,
        })
    }
}

/// Narrows an exact double-precision edge function to `f32` without letting a tiny nonzero
/// value underflow to zero: only its sign matters to the inside test, and zero means "on the
/// edge".
#[inline]
fn f64_to_f32_keep_sign(x: f64) -> f32 {
    let y = x as f32;
    if y == 0.0 && x != 0.0 {
        f32::from_bits(1).copysign(x as f32)
    } else {
        y
    }
}

/// The triangle test in double precision with the same conventions, for oracles in tests and
/// benchmarks (exported so every crate's tests agree on one reference).
pub fn intersect_triangle_f64(
    origin: DVec3,
    direction: DVec3,
    vertices: [DVec3; 3],
) -> Option<(f64, f64, f64)> {
    let [v0, v1, v2] = vertices;
    let e1 = v1 - v0;
    let e2 = v2 - v0;
    let p = direction.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let s = origin - v0;
    let u = s.dot(p) / det;
    let q = s.cross(e1);
    let v = direction.dot(q) / det;
    if u < 0.0 || v < 0.0 || u + v > 1.0 {
        return None;
    }
    Some((e2.dot(q) / det, u, v))
}
