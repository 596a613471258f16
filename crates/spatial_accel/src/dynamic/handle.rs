//! Handles to a dynamic tree's leaves, and the errors its edits report.

/// A stable reference to one leaf of a [`DynamicBvh`](super::DynamicBvh): valid from `insert`
/// until `remove`.
///
/// It holds the leaf's arena index (leaves never move) and the slot's generation, so a handle
/// kept past `remove` is reported as stale instead of naming whatever later reused the slot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct LeafHandle {
    pub(super) index: u32,
    pub(super) generation: u32,
}

impl LeafHandle {
    /// The leaf's node index in the tree (a [`BoundingTree`](crate::query::BoundingTree) node
    /// id).
    pub fn index(self) -> u32 {
        self.index
    }

    /// The handle packed into 64 bits (to store it in a component or a slot map).
    pub fn to_bits(self) -> u64 {
        (u64::from(self.generation) << 32) | u64::from(self.index)
    }

    /// The handle packed by [`LeafHandle::to_bits`].
    pub fn from_bits(bits: u64) -> Self {
        Self {
            index: bits as u32,
            generation: (bits >> 32) as u32,
        }
    }
}

/// Why a dynamic-tree edit was refused: the [`IndexError`](crate::query::IndexError) of
/// every [`DynamicIndex`](crate::query::DynamicIndex). The tree is unchanged when one is
/// returned; it holds at most 2^31 - 1 nodes.
pub type DynamicBvhError = crate::query::IndexError;
