//! A static tree with the tables the layered indexes derive from it, made ahead of time.
//!
//! Replacing the static tree of a [`StaticDynamicPair`](super::StaticDynamicPair) or a
//! [`LayeredIndex`](super::LayeredIndex) derives its 16-wide ray form and its subtree spans,
//! a pass over every node. For a level of a million boxes that pass alone stalls the frame
//! that swaps the tree in, even when the tree itself was built on another thread. A
//! [`PreparedStatic`] carries those tables, so the whole preparation can run off the frame and
//! the swap costs a move.

use super::pair_rays::wide_for_rays;
use crate::Bvh;
use crate::bvh::wide::Bvh16;

/// A static [`Bvh`] with its 16-wide ray form and subtree spans, ready to be swapped into a
/// layered index in O(1) ([`StaticDynamicPair::set_static_prepared`](super::StaticDynamicPair::set_static_prepared),
/// [`LayeredIndex::set_static_prepared`](super::LayeredIndex::set_static_prepared)).
///
/// ```
/// use spatial_accel::dynamic::{DynamicBvh, PreparedStatic, StaticDynamicPair};
/// use spatial_accel::{Aabb, BuildConfig, Bvh};
/// use glam::Vec3A;
///
/// let walls: Vec<Aabb> = (0..100)
///     .map(|i| Aabb::from_center_half_extents(Vec3A::new(i as f32, 0.0, 0.0), Vec3A::splat(0.4)))
///     .collect();
/// // The expensive part, on any thread.
/// let prepared = std::thread::spawn(move || {
///     PreparedStatic::new(Bvh::build(&walls, &BuildConfig::default()))
/// })
/// .join()
/// .unwrap();
/// let mut pair = StaticDynamicPair::new(Bvh::default(), DynamicBvh::new());
/// pair.set_static_prepared(prepared);
/// assert_eq!(pair.static_tree().primitive_count(), 100);
/// ```
#[derive(Clone, Debug, Default)]
pub struct PreparedStatic {
    pub(super) tree: Bvh,
    pub(super) wide: Bvh16,
    pub(super) ranges: Vec<[u32; 2]>,
}

impl PreparedStatic {
    /// Derives the tables of `tree`: O(n) in its nodes.
    pub fn new(tree: Bvh) -> Self {
        Self {
            wide: wide_for_rays(&tree),
            ranges: tree.subtree_ranges(),
            tree,
        }
    }

    /// The tree.
    pub fn tree(&self) -> &Bvh {
        &self.tree
    }
}
