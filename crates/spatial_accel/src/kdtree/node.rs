//! The compact node: eight bytes, interior and leaf alike (Wald and Havran 2006, section 5;
//! pbrt's layout).

/// The tag that marks a leaf in the low two bits (axes use 0, 1 and 2).
const LEAF_TAG: u32 = 3;

/// Largest child index or leaf size the 30 bits left by the tag can hold.
pub(super) const MAX_PACKED: u32 = (1 << 30) - 1;

/// One node of a [`super::KdTree`], packed in two words so that a cache line holds eight.
///
/// Nodes are stored depth first: an interior node's child below the split is the next node,
/// so only the child above needs an index. The low two bits of the first word are the split
/// axis (0 to 2) or 3 for a leaf; the other 30 hold the child above, or a leaf's triangle
/// count. The second word is the split position's bits, or where the leaf's run of triangle
/// indices starts in [`super::KdTree::leaf_references`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct KdNode {
    tag_and_index: u32,
    payload: u32,
}

/// A [`KdNode`] unpacked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum KdNodeKind {
    /// A split at `point[axis] = position`.
    Interior {
        /// The split axis, 0 to 2.
        axis: usize,
        /// The plane's position on the axis.
        position: f32,
        /// The child above the plane (the one below is the next node).
        above: u32,
    },
    /// A leaf: `count` triangle indices from `first` in the leaf references.
    Leaf {
        /// Index of the first reference.
        first: u32,
        /// Number of references.
        count: u32,
    },
}

impl KdNode {
    /// An interior node; `above` must fit in 30 bits (the builder checks).
    #[inline]
    pub(super) fn interior(axis: usize, position: f32, above: u32) -> Self {
        debug_assert!(axis < 3 && above <= MAX_PACKED);
        Self {
            tag_and_index: (above << 2) | axis as u32,
            payload: position.to_bits(),
        }
    }

    /// A leaf; `count` must fit in 30 bits (the builder checks).
    #[inline]
    pub(super) fn leaf(first: u32, count: u32) -> Self {
        debug_assert!(count <= MAX_PACKED);
        Self {
            tag_and_index: (count << 2) | LEAF_TAG,
            payload: first,
        }
    }

    /// True for a leaf.
    #[inline]
    pub fn is_leaf(&self) -> bool {
        self.tag_and_index & 3 == LEAF_TAG
    }

    /// The node unpacked.
    #[inline]
    pub fn kind(&self) -> KdNodeKind {
        let index = self.tag_and_index >> 2;
        match self.tag_and_index & 3 {
            LEAF_TAG => KdNodeKind::Leaf {
                first: self.payload,
                count: index,
            },
            axis => KdNodeKind::Interior {
                axis: axis as usize,
                position: f32::from_bits(self.payload),
                above: index,
            },
        }
    }
}
