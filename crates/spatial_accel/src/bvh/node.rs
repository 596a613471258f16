//! The 32-byte binary node of the flat BVH array.

use crate::Aabb;
use glam::Vec3A;

/// One node of the flat binary BVH: its box and either its children or its primitives.
///
/// 32 bytes, two to a cache line (the layout of tinybvh and of Wald's builders): an interior
/// node (`count == 0`) keeps its left child at `first` and its right child at `first + 1`, so
/// one index names both; a leaf keeps `count` primitive ids starting at `first` in the tree's
/// primitive-index array.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(32))]
pub struct BvhNode {
    /// Minimum corner of the node's box.
    pub min: [f32; 3],
    /// Left child (interior) or first primitive slot (leaf).
    pub first: u32,
    /// Maximum corner of the node's box.
    pub max: [f32; 3],
    /// Number of primitives; 0 marks an interior node.
    pub count: u32,
}

impl BvhNode {
    /// True for leaves.
    #[inline]
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }

    /// The node's box.
    #[inline]
    pub fn aabb(&self) -> Aabb {
        Aabb::new(Vec3A::from_array(self.min), Vec3A::from_array(self.max))
    }

    /// Sets the node's box.
    #[inline]
    pub fn set_aabb(&mut self, aabb: &Aabb) {
        self.min = aabb.min.to_array();
        self.max = aabb.max.to_array();
    }
}

const _: () = assert!(core::mem::size_of::<BvhNode>() == 32);
