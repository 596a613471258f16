//! The wide node: structure-of-arrays child boxes, then child references.

use crate::Aabb;
use glam::Vec3A;

/// Marks an unused child slot (its box is empty, so no test ever passes it).
pub const EMPTY_SLOT: u32 = u32::MAX;

/// Set in a leaf slot's `count` when the slot holds one primitive whose id is stored in the
/// count's other bits (see [`WideBvh::inline_single_leaves`](super::WideBvh::inline_single_leaves)).
pub const INLINE_PRIMITIVE: u32 = 1 << 31;

/// A node with up to `N` children. Child boxes are stored per coordinate (`min_x[0..N]`, ...)
/// so one SIMD load fetches a coordinate of every child.
///
/// Slot `i` is unused when `child[i] == EMPTY_SLOT` (its box is [`Aabb::EMPTY`]); an interior
/// child when `count[i] == 0` (`child[i]` is a node index); a leaf otherwise (`count[i]`
/// primitives from `child[i]` in the primitive-index array).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct WideNode<const N: usize> {
    /// Minimum x of each child box.
    pub min_x: [f32; N],
    /// Minimum y of each child box.
    pub min_y: [f32; N],
    /// Minimum z of each child box.
    pub min_z: [f32; N],
    /// Maximum x of each child box.
    pub max_x: [f32; N],
    /// Maximum y of each child box.
    pub max_y: [f32; N],
    /// Maximum z of each child box.
    pub max_z: [f32; N],
    /// Node index (interior), first primitive slot (leaf) or [`EMPTY_SLOT`].
    pub child: [u32; N],
    /// Primitive count of a leaf slot; 0 for interior and unused slots. A single-primitive
    /// leaf may instead hold [`INLINE_PRIMITIVE`]` | id`, its primitive's id (the count is
    /// then 1; read it through [`WideLayout::count`](super::WideLayout::count)).
    pub count: [u32; N],
}

impl<const N: usize> Default for WideNode<N> {
    fn default() -> Self {
        Self {
            min_x: [f32::INFINITY; N],
            min_y: [f32::INFINITY; N],
            min_z: [f32::INFINITY; N],
            max_x: [f32::NEG_INFINITY; N],
            max_y: [f32::NEG_INFINITY; N],
            max_z: [f32::NEG_INFINITY; N],
            child: [EMPTY_SLOT; N],
            count: [0; N],
        }
    }
}

impl<const N: usize> WideNode<N> {
    /// The six plane arrays in their stored order: minimum x, y, z, then maximum x, y, z (the
    /// order of [`RayLanes`](super::ray::RayLanes)' plane indices).
    #[inline(always)]
    pub(crate) fn planes(&self) -> &[[f32; N]; 6] {
        const { assert!(core::mem::offset_of!(Self, max_z) == 5 * N * 4) };
        // SAFETY: `repr(C)` lays the six `[f32; N]` arrays out first and back to back (the
        // offset of the last is checked above), so together they are one `[[f32; N]; 6]`.
        unsafe { &*(self as *const Self).cast::<[[f32; N]; 6]>() }
    }

    /// The box of slot `i`.
    #[inline]
    pub fn child_aabb(&self, i: usize) -> Aabb {
        Aabb::new(
            Vec3A::new(self.min_x[i], self.min_y[i], self.min_z[i]),
            Vec3A::new(self.max_x[i], self.max_y[i], self.max_z[i]),
        )
    }

    /// Sets the box of slot `i`.
    #[inline]
    pub fn set_child_aabb(&mut self, i: usize, b: &Aabb) {
        self.min_x[i] = b.min.x;
        self.min_y[i] = b.min.y;
        self.min_z[i] = b.min.z;
        self.max_x[i] = b.max.x;
        self.max_y[i] = b.max.y;
        self.max_z[i] = b.max.z;
    }

    /// True when slot `i` holds something.
    #[inline]
    pub fn is_used(&self, i: usize) -> bool {
        self.child[i] != EMPTY_SLOT
    }

    /// True when slot `i` is a leaf.
    #[inline]
    pub fn is_leaf(&self, i: usize) -> bool {
        self.count[i] > 0
    }
}
