//! What a wide tree needs from its node type, so one set of traversals serves the float and
//! the quantized layouts.

use super::ray::SlotRayTest;
use super::{EMPTY_SLOT, INLINE_PRIMITIVE, WideNode};
use crate::Aabb;
use glam::Vec3A;

/// A node layout for [`super::WideBvh`]: `N` child slots, each unused, a leaf (a run of
/// primitives) or an interior child (a node index).
///
/// Implemented by [`WideNode`] (exact `f32` boxes) and [`super::QuantizedNode`] (8-bit boxes
/// relative to the node, half the bytes). The ray test is a private part of the trait.
pub trait WideLayout<const N: usize>:
    Clone + Copy + core::fmt::Debug + Default + PartialEq + SlotRayTest<N>
{
    /// The most primitives one leaf slot can hold; larger binary leaves are split before the
    /// collapse.
    const MAX_LEAF_PRIMITIVES: u32;

    /// The node with the same slots as a float node; its boxes enclose the float boxes.
    fn from_float(node: &WideNode<N>) -> Self;

    /// The box of slot `slot` (for quantized layouts, the decoded, enclosing box).
    fn child_aabb(&self, slot: usize) -> Aabb;

    /// Replaces every slot's box at once (quantized layouts re-derive their frame from all
    /// of them); unused slots get [`Aabb::EMPTY`].
    fn set_child_boxes(&mut self, boxes: &[Aabb; N]);

    /// Whether [`set_slot_boxes`](Self::set_slot_boxes) can replace some slots and keep the
    /// others exactly (float boxes can; quantized ones are relative to a frame derived from
    /// all of them, and re-encoding decoded boxes would grow them at every refit).
    const SETS_SLOTS_ALONE: bool = false;

    /// Replaces the boxes of the slots in `mask` (bit `s`: slot `s`). Only for layouts with
    /// [`SETS_SLOTS_ALONE`](Self::SETS_SLOTS_ALONE); the others get every slot's box through
    /// [`set_child_boxes`](Self::set_child_boxes).
    #[inline]
    fn set_slot_boxes(&mut self, mask: u32, boxes: &[Aabb; N]) {
        debug_assert!(Self::SETS_SLOTS_ALONE || mask == (1 << N) - 1);
        self.set_child_boxes(boxes);
    }

    /// Node index (interior slot), first primitive slot (leaf) or [`EMPTY_SLOT`].
    fn child(&self, slot: usize) -> u32;

    /// Primitive count of a leaf slot; 0 for interior and unused slots.
    fn count(&self, slot: usize) -> u32;

    /// The primitive of a single-primitive leaf slot whose id the node stores itself (see
    /// [`super::WideBvh::inline_single_leaves`]); `None` for every other slot, whose
    /// primitives are read from the tree's primitive array at [`Self::child`].
    #[inline]
    fn inline_primitive(&self, slot: usize) -> Option<u32> {
        let _ = slot;
        None
    }

    /// The union of the used slots' boxes.
    #[inline]
    fn bounds(&self) -> Aabb {
        (0..N)
            .filter(|&s| self.is_used(s))
            .fold(Aabb::EMPTY, |acc, s| acc.union(&self.child_aabb(s)))
    }

    /// True when slot `slot` holds something.
    #[inline]
    fn is_used(&self, slot: usize) -> bool {
        self.child(slot) != EMPTY_SLOT
    }

    /// True when slot `slot` is a leaf.
    #[inline]
    fn is_leaf(&self, slot: usize) -> bool {
        self.count(slot) > 0
    }
}

impl<const N: usize> WideLayout<N> for WideNode<N> {
    // The count's top bit marks an inlined primitive.
    const MAX_LEAF_PRIMITIVES: u32 = INLINE_PRIMITIVE - 1;

    fn from_float(node: &WideNode<N>) -> Self {
        *node
    }

    #[inline]
    fn child_aabb(&self, slot: usize) -> Aabb {
        WideNode::child_aabb(self, slot)
    }

    fn set_child_boxes(&mut self, boxes: &[Aabb; N]) {
        for (slot, b) in boxes.iter().enumerate() {
            self.set_child_aabb(slot, b);
        }
    }

    const SETS_SLOTS_ALONE: bool = true;

    #[inline]
    fn set_slot_boxes(&mut self, mask: u32, boxes: &[Aabb; N]) {
        for slot in (0..N).filter(|s| mask & (1 << s) != 0) {
            self.set_child_aabb(slot, &boxes[slot]);
        }
    }

    /// Unused slots hold the empty box, so a plain reduction over all lanes is the union.
    #[inline]
    fn bounds(&self) -> Aabb {
        let min = |a: &[f32; N]| a.iter().copied().fold(f32::INFINITY, f32::min);
        let max = |a: &[f32; N]| a.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        Aabb::new(
            Vec3A::new(min(&self.min_x), min(&self.min_y), min(&self.min_z)),
            Vec3A::new(max(&self.max_x), max(&self.max_y), max(&self.max_z)),
        )
    }

    #[inline]
    fn child(&self, slot: usize) -> u32 {
        self.child[slot]
    }

    #[inline]
    fn count(&self, slot: usize) -> u32 {
        let count = self.count[slot];
        if count & INLINE_PRIMITIVE != 0 {
            1
        } else {
            count
        }
    }

    #[inline]
    fn inline_primitive(&self, slot: usize) -> Option<u32> {
        let count = self.count[slot];
        (count & INLINE_PRIMITIVE != 0).then_some(count & !INLINE_PRIMITIVE)
    }
}
