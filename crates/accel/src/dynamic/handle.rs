//! Handles to a dynamic tree's leaves, and the errors its edits report.

use std::fmt;

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

/// Why a dynamic-tree edit was refused. The tree is unchanged when one is returned.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DynamicBvhError {
    /// The box has a NaN or infinite coordinate, or `min > max`: it would poison every
    /// ancestor's box (NaN fails every comparison and hides whole subtrees from queries).
    InvalidBounds,
    /// The handle was removed (or never came from this tree).
    StaleHandle,
    /// The tree already holds 2^31 - 1 nodes.
    CapacityExceeded,
}

impl fmt::Display for DynamicBvhError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::InvalidBounds => f.write_str("bounds are NaN, infinite or inverted"),
            Self::StaleHandle => f.write_str("the handle does not name a live leaf"),
            Self::CapacityExceeded => f.write_str("the dynamic BVH is full (2^31 - 1 nodes)"),
        }
    }
}

impl std::error::Error for DynamicBvhError {}
