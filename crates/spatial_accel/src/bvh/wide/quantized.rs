//! The quantized wide node: child boxes as 8-bit offsets on a per-node grid.
//!
//! An incoherent ray's traversal waits on memory: every node it visits is a cache miss. An
//! 8-wide float node is 256 bytes (four cache lines); this one is 128 (two), at the price of
//! boxes rounded out to a 1/250-of-the-node grid and a few conversions per visit. The idea is
//! Embree's QBVH and Ylitie et al. 2017's compressed wide BVH; the grid spacing is a power of
//! two, as theirs, so decoding `origin + q * scale` rounds only once.
//!
//! Robustness: the builder does not trust the rounding analysis. For each plane it computes
//! the decoded value exactly as the traversal will (the same `f32` operations) and moves the
//! 8-bit value outward until that value encloses the true box, so the traversal's decoded box
//! always contains the exact one and the usual conservative slab test applies unchanged.

use super::layout::WideLayout;
use super::ray::{RayLanes, SlotRayTest, leaf_mask_of, slab_test_lanes};
use super::{EMPTY_SLOT, WideNode};
use crate::Aabb;
use glam::{Vec3A, Vec4};

/// Grid steps the node box may span: 250 of the 255 available, so the outward fix-ups after
/// rounding always have room.
const GRID_STEPS: f64 = 250.0;

/// A wide node with quantized child boxes (see the module docs); 128 bytes when `N = 8`.
///
/// Slot `i` decodes to the box `origin + lo[i] * scale ..= origin + hi[i] * scale` per axis.
/// Geometry must be finite: infinite boxes are clamped to `±f32::MAX`, so use the float
/// [`WideNode`] for trees over unbounded primitives.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct QuantizedNode<const N: usize> {
    /// The grid origin: the minimum corner of the union of the slot boxes.
    pub origin: [f32; 3],
    /// The grid spacing per axis, a power of two.
    pub scale: [f32; 3],
    /// Node index (interior), first primitive slot (leaf) or [`EMPTY_SLOT`].
    pub child: [u32; N],
    /// Primitive count of a leaf slot (at most 255); 0 for interior and unused slots.
    pub count: [u8; N],
    /// Grid coordinates of each slot's box, per axis and side.
    pub lo: [[u8; N]; 3],
    /// See [`QuantizedNode::lo`].
    pub hi: [[u8; N]; 3],
    /// Bit i set when slot i holds a non-empty box (only those can be hit).
    pub live: u8,
    /// Bit i set when slot i is a leaf.
    pub leaves: u8,
}

impl<const N: usize> Default for QuantizedNode<N> {
    fn default() -> Self {
        Self {
            origin: [0.0; 3],
            scale: [1.0; 3],
            child: [EMPTY_SLOT; N],
            count: [0; N],
            lo: [[u8::MAX; N]; 3],
            hi: [[0; N]; 3],
            live: 0,
            leaves: 0,
        }
    }
}

/// The smallest power of two `s` with `extent / s <= GRID_STEPS`, within `f32`'s normal range.
fn grid_scale(extent: f64) -> f32 {
    let exponent = (extent / GRID_STEPS).log2().ceil();
    let exponent = if exponent.is_nan() { -126.0 } else { exponent };
    let exponent = exponent.clamp(-126.0, 127.0) as i32;
    f32::from_bits(((exponent + 127) as u32) << 23)
}

/// The decoded plane, computed exactly as the traversal computes it (one product that is
/// exact, one rounded sum).
#[inline(always)]
fn decode(origin: f32, scale: f32, q: u8) -> f32 {
    f32::from(q) * scale + origin
}

/// The grid values of `[min, max]` on one axis, rounded outward until the decoded planes
/// enclose the interval.
fn quantize_interval(origin: f32, scale: f32, min: f32, max: f32) -> (u8, u8) {
    let to_grid = |v: f32| (f64::from(v) - f64::from(origin)) / f64::from(scale);
    let mut lo = to_grid(min).floor().clamp(0.0, 255.0) as u8;
    let mut hi = to_grid(max).ceil().clamp(0.0, 255.0) as u8;
    while lo > 0 && decode(origin, scale, lo) > min {
        lo -= 1;
    }
    while hi < u8::MAX && decode(origin, scale, hi) < max {
        hi += 1;
    }
    (lo, hi)
}

/// The grid coordinates of up to eight slots as floats, four lanes per vector.
#[inline(always)]
fn grid_lanes<const N: usize>(q: &[u8; N]) -> [Vec4; 2] {
    let mut bytes = [0u8; 8];
    bytes[..N].copy_from_slice(q);
    #[cfg(target_arch = "x86_64")]
    {
        use core::arch::x86_64::*;
        // SAFETY: SSE2 is part of the x86_64 baseline; the load reads the 8 bytes of `bytes`.
        unsafe {
            let zero = _mm_setzero_si128();
            let v = _mm_loadl_epi64(bytes.as_ptr().cast());
            let words = _mm_unpacklo_epi8(v, zero);
            [
                Vec4::from(_mm_cvtepi32_ps(_mm_unpacklo_epi16(words, zero))),
                Vec4::from(_mm_cvtepi32_ps(_mm_unpackhi_epi16(words, zero))),
            ]
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let f = bytes.map(f32::from);
        [Vec4::from_slice(&f[..4]), Vec4::from_slice(&f[4..])]
    }
}

impl<const N: usize> SlotRayTest<N> for QuantizedNode<N> {
    #[inline(always)]
    fn intersect_slots(&self, ray: &RayLanes, t_max: f32, entry_t: &mut [f32; N]) -> u32 {
        // Decoded once for both halves of an 8-wide node: one 8-byte load per plane array.
        let planes = self.planes();
        let decode = |plane: usize| {
            let axis = plane % 3;
            let (scale, origin) = (
                Vec4::splat(self.scale[axis]),
                Vec4::splat(self.origin[axis]),
            );
            grid_lanes(&planes[plane]).map(|g| g * scale + origin)
        };
        let (entry, exit) = (ray.entry_plane.map(decode), ray.exit_plane.map(decode));
        let mask = slab_test_lanes::<N>(
            |chunk| {
                (
                    [entry[0][chunk], entry[1][chunk], entry[2][chunk]],
                    [exit[0][chunk], exit[1][chunk], exit[2][chunk]],
                )
            },
            ray,
            t_max,
            entry_t,
        );
        // Empty slots decode to inverted but finite boxes, which the widened test could let
        // through on a grazing ray: only live slots count.
        mask & u32::from(self.live)
    }

    #[inline(always)]
    fn leaf_mask(&self) -> u32 {
        u32::from(self.leaves)
    }
}

impl<const N: usize> QuantizedNode<N> {
    /// The six grid arrays in their stored order: low x, y, z, then high x, y, z (the order of
    /// [`RayLanes`]' plane indices).
    #[inline(always)]
    fn planes(&self) -> &[[u8; N]; 6] {
        const { assert!(core::mem::offset_of!(Self, hi) == core::mem::offset_of!(Self, lo) + 3 * N) };
        // SAFETY: `repr(C)` lays `lo` and `hi` out back to back (checked above) with byte
        // alignment, so together they are one `[[u8; N]; 6]`.
        unsafe { &*(&raw const self.lo).cast::<[[u8; N]; 6]>() }
    }
}

impl<const N: usize> WideLayout<N> for QuantizedNode<N> {
    const MAX_LEAF_PRIMITIVES: u32 = u8::MAX as u32;

    fn from_float(node: &WideNode<N>) -> Self {
        const { assert!(N <= 8, "the live and leaf masks are 8 bits") };
        let mut q = Self {
            child: node.child,
            ..Self::default()
        };
        let mut boxes = [Aabb::EMPTY; N];
        for (slot, b) in boxes.iter_mut().enumerate() {
            if node.is_used(slot) {
                *b = node.child_aabb(slot);
            }
            q.count[slot] = u8::try_from(WideLayout::count(node, slot))
                .expect("leaves are split to at most 255 primitives before quantizing");
        }
        q.leaves = leaf_mask_of(&q.count) as u8;
        q.set_child_boxes(&boxes);
        q
    }

    fn child_aabb(&self, slot: usize) -> Aabb {
        if self.live & (1 << slot) == 0 {
            return Aabb::EMPTY;
        }
        let corner = |q: &[[u8; N]; 3]| {
            Vec3A::from_array(core::array::from_fn(|axis| {
                decode(self.origin[axis], self.scale[axis], q[axis][slot])
            }))
        };
        Aabb::new(corner(&self.lo), corner(&self.hi))
    }

    fn set_child_boxes(&mut self, boxes: &[Aabb; N]) {
        let finite = |b: &Aabb| {
            Aabb::new(
                b.min.clamp(Vec3A::splat(-f32::MAX), Vec3A::splat(f32::MAX)),
                b.max.clamp(Vec3A::splat(-f32::MAX), Vec3A::splat(f32::MAX)),
            )
        };
        let mut live = 0u8;
        let mut union = Aabb::EMPTY;
        for (slot, b) in boxes.iter().enumerate() {
            if self.child[slot] != EMPTY_SLOT && b.is_valid() {
                live |= 1 << slot;
                union = union.union(&finite(b));
            }
        }
        *self = Self {
            child: self.child,
            count: self.count,
            leaves: self.leaves,
            live,
            ..Self::default()
        };
        if live == 0 {
            return;
        }
        for axis in 0..3 {
            let (min, max) = (union.min[axis], union.max[axis]);
            self.origin[axis] = min;
            self.scale[axis] = grid_scale(f64::from(max) - f64::from(min));
        }
        for (slot, b) in boxes.iter().enumerate() {
            if live & (1 << slot) == 0 {
                continue;
            }
            let b = finite(b);
            for axis in 0..3 {
                let (lo, hi) = quantize_interval(
                    self.origin[axis],
                    self.scale[axis],
                    b.min[axis],
                    b.max[axis],
                );
                self.lo[axis][slot] = lo;
                self.hi[axis][slot] = hi;
            }
        }
    }

    #[inline]
    fn child(&self, slot: usize) -> u32 {
        self.child[slot]
    }

    #[inline]
    fn count(&self, slot: usize) -> u32 {
        u32::from(self.count[slot])
    }
}

const _: () = assert!(core::mem::size_of::<QuantizedNode<8>>() == 128);
