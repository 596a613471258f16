//! Four triangles in structure-of-arrays form and the watertight test on all four at once.
//!
//! A BVH leaf holds a few triangles, and a ray tests them all. One at a time, the watertight
//! test spends as much on fetching the coordinates its ray picked (`a[kx]`, a run-time index)
//! as on arithmetic. Stored per coordinate, four triangles' `x`s are one vector, so picking the
//! axes is choosing which vector to load, and the arithmetic runs four lanes wide (Embree's
//! `Triangle4` and its `intersect_ray_woop`, Woop et al. 2013).

use super::{Aabb, Backfaces, TriangleHit, WatertightRay};
use glam::{BVec4A, Vec3A, Vec4};

/// Four triangles, stored per corner and per coordinate: `corners[v][axis]` holds coordinate
/// `axis` of corner `v` of all four. Unused lanes hold NaN and never hit.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(16))]
pub struct Triangle4 {
    /// `corners[v][axis]`: lane `i` is triangle `i`.
    pub corners: [[Vec4; 3]; 3],
}

impl Default for Triangle4 {
    /// Four unused lanes.
    fn default() -> Self {
        Self {
            corners: [[Vec4::NAN; 3]; 3],
        }
    }
}

impl Triangle4 {
    /// Writes triangle `lane` (its three corners, in winding order).
    #[inline]
    pub fn set(&mut self, lane: usize, corners: [Vec3A; 3]) {
        for (v, corner) in corners.iter().enumerate() {
            let corner = corner.to_array();
            for (axis, &c) in corner.iter().enumerate() {
                // Through the array view: indexing a `Vec4` by a run-time lane is a `match`.
                let lanes: &mut [f32; 4] = self.corners[v][axis].as_mut();
                lanes[lane] = c;
            }
        }
    }

    /// The corners of triangle `lane` (NaN for an unused lane).
    #[inline]
    pub fn get(&self, lane: usize) -> [Vec3A; 3] {
        core::array::from_fn(|v| {
            let [x, y, z] = self.corners[v].map(|c| c.to_array()[lane]);
            Vec3A::new(x, y, z)
        })
    }

    /// The box around the lanes whose corners are all finite (unused lanes are NaN, so they
    /// drop out, as does a triangle a bad pose made non-finite); empty when none is.
    #[inline]
    pub fn bounds(&self) -> Aabb {
        let [a, b, c] = &self.corners;
        let mut finite = BVec4A::splat(true);
        for v in [a, b, c] {
            for coord in v {
                finite &= coord.is_finite_mask();
            }
        }
        let lo = core::array::from_fn::<f32, 3, _>(|axis| {
            let m = a[axis].min(b[axis]).min(c[axis]);
            Vec4::select(finite, m, Vec4::INFINITY).min_element()
        });
        let hi = core::array::from_fn::<f32, 3, _>(|axis| {
            let m = a[axis].max(b[axis]).max(c[axis]);
            Vec4::select(finite, m, Vec4::NEG_INFINITY).max_element()
        });
        Aabb::new(Vec3A::from_array(lo), Vec3A::from_array(hi))
    }
}

/// What the four-wide test found: which lanes hit, and where.
#[derive(Clone, Copy, Debug)]
pub struct Triangle4Hits {
    /// Bit `i` set when triangle `i` was hit within the ray's range.
    pub mask: u32,
    t: [f32; 4],
    u: [f32; 4],
    v: [f32; 4],
    front: u32,
}

impl Triangle4Hits {
    /// The hit on lane `lane` (meaningful only when its bit is in `mask`).
    #[inline]
    pub fn hit(&self, lane: usize) -> TriangleHit {
        TriangleHit {
            t: self.t[lane],
            u: self.u[lane],
            v: self.v[lane],
            front_face: self.front & (1 << lane) != 0,
        }
    }

    /// The nearest hit lane (the lowest lane on ties), or `None`.
    #[inline]
    pub fn closest(&self) -> Option<(usize, TriangleHit)> {
        let mut mask = self.mask;
        let mut best: Option<usize> = None;
        while mask != 0 {
            let lane = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            if best.is_none_or(|b| self.t[lane] < self.t[b]) {
                best = Some(lane);
            }
        }
        best.map(|lane| (lane, self.hit(lane)))
    }
}

impl WatertightRay {
    /// The watertight test against four triangles at once: the same arithmetic, in the same
    /// order, as [`WatertightRay::intersect_vertices`] on each lane, and verdicts that decide
    /// as its comparisons do, so a lane's result is bit-for-bit the single test's. Lanes with
    /// an edge function of exactly zero take the single test, with its double-precision
    /// fallback.
    #[inline(always)]
    pub fn intersect4(&self, tris: &Triangle4, backfaces: Backfaces) -> Triangle4Hits {
        let (kx, ky, kz) = (self.kx, self.ky, self.kz);
        let o = self.origin.to_array();
        // Corner `v` relative to the origin, on the permuted axes: choosing the axes is choosing
        // which vector to load.
        let rel = |v: usize, axis: usize| tris.corners[v][axis] - Vec4::splat(o[axis]);
        let (sx, sy, sz) = (
            Vec4::splat(self.shear_x),
            Vec4::splat(self.shear_y),
            Vec4::splat(self.shear_z),
        );
        let (a_z, b_z, c_z) = (rel(0, kz), rel(1, kz), rel(2, kz));
        let ax = rel(0, kx) - sx * a_z;
        let ay = rel(0, ky) - sy * a_z;
        let bx = rel(1, kx) - sx * b_z;
        let by = rel(1, ky) - sy * b_z;
        let cx = rel(2, kx) - sx * c_z;
        let cy = rel(2, ky) - sy * c_z;

        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        let zero = Vec4::ZERO;
        let exact_zero = (u.cmpeq(zero) | v.cmpeq(zero) | w.cmpeq(zero)).bitmask();

        // Lanes with no edge function of zero (the others take the single test below): a
        // lane is inside when its three signs agree, so sign bits compared stand for the
        // single test's six comparisons, and `det` (a sum of three nonzero values of one
        // sign) cannot be zero. A NaN edge function (unused lanes are NaN) makes `det`, and
        // so `t`, NaN, which the range test rejects. The same verdicts as the single test, in
        // fewer instructions (BENCHMARKS.md, Core geometry).
        let det = u + v + w;
        let mixed_signs = sign_differences(u, v) | sign_differences(v, w);
        let back = det.is_negative_bitmask();
        let mut inside = !mixed_signs;
        if backfaces == Backfaces::Cull {
            inside &= !back;
        }
        let t_scaled = u * (sz * a_z) + v * (sz * b_z) + w * (sz * c_z);
        let inv_det = Vec4::ONE / det;
        let t = t_scaled * inv_det;
        // Finite too, as the single test asks (a hit at infinity is a miss).
        let in_range = t.cmpge(Vec4::splat(self.t_min))
            & t.cmple(Vec4::splat(self.t_max))
            & t.is_finite_mask();
        let mut hits = Triangle4Hits {
            mask: inside & in_range.bitmask() & !exact_zero,
            t: t.to_array(),
            u: (v * inv_det).to_array(),
            v: (w * inv_det).to_array(),
            front: !back & 0xF,
        };
        if exact_zero != 0 {
            self.retest_lanes(tris, backfaces, exact_zero, &mut hits);
        }
        hits
    }

    /// The single test on the lanes of `lanes` (those with an edge function of exactly zero,
    /// rare), its answers written over theirs in `hits`. Out of line, so that the four-lane
    /// test inlined into a walk stays small.
    #[cold]
    #[inline(never)]
    fn retest_lanes(
        &self,
        tris: &Triangle4,
        backfaces: Backfaces,
        mut lanes: u32,
        hits: &mut Triangle4Hits,
    ) {
        while lanes != 0 {
            let lane = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            let [a, b, c] = tris.get(lane);
            if let Some(h) = self.intersect_vertices(a, b, c, backfaces) {
                hits.mask |= 1 << lane;
                hits.t[lane] = h.t;
                hits.u[lane] = h.u;
                hits.v[lane] = h.v;
                hits.front = (hits.front & !(1 << lane)) | (u32::from(h.front_face) << lane);
            }
        }
    }
}

/// Bit `i` set when lanes `i` of `a` and `b` differ in their sign bits.
#[inline(always)]
fn sign_differences(a: Vec4, b: Vec4) -> u32 {
    #[cfg(target_arch = "x86_64")]
    {
        use core::arch::x86_64::{_mm_movemask_ps, _mm_xor_ps};
        // SAFETY: SSE is part of the x86-64 baseline.
        unsafe { _mm_movemask_ps(_mm_xor_ps(a.into(), b.into())) as u32 }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let (a, b) = (a.to_array(), b.to_array());
        (0..4).fold(0, |m, i| {
            m | (((a[i].to_bits() ^ b[i].to_bits()) >> 31) << i)
        })
    }
}
