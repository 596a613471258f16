//! The interface of an index that follows moving objects: insert, update and remove by
//! handle, and per-frame upkeep.

use super::{NodeView, SpatialQuery};
use crate::Aabb;
use core::fmt;
use core::hash::Hash;
use core::ops::{ControlFlow, RangeInclusive};
use std::time::Duration;

/// Why an edit of a [`DynamicIndex`] was refused. The index is unchanged when one is
/// returned: a refused edit never loses or duplicates an entry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IndexError {
    /// The box has a NaN or infinite coordinate, or `min > max`: in a tree it would poison
    /// every ancestor's box (NaN fails every comparison and hides whole subtrees from
    /// queries).
    InvalidBounds,
    /// The handle was removed (or never came from this index).
    StaleHandle,
    /// The index holds as many entries as its handles can name.
    CapacityExceeded,
}

impl fmt::Display for IndexError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::InvalidBounds => f.write_str("bounds are NaN, infinite or inverted"),
            Self::StaleHandle => f.write_str("the handle does not name a live entry"),
            Self::CapacityExceeded => f.write_str("the index is full"),
        }
    }
}

impl std::error::Error for IndexError {}

/// What one [`DynamicIndex::maintain`] call did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct UpkeepReport {
    /// Nodes (or cells) whose bounds were recomputed for the edits since the last call.
    pub refit_nodes: usize,
    /// Entries moved to a better place within the budget (a tree's reinsertions).
    pub improved: usize,
    /// Whether the whole structure was rebuilt (or a rebuild made elsewhere swapped in).
    pub rebuilt: bool,
}

/// Shape and cost of a [`DynamicIndex`], cheap to read every frame (no walk).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct IndexStats {
    /// Entries held.
    pub entries: usize,
    /// Nodes or cells in use.
    pub nodes: usize,
    /// Depth of the deepest entry (0 for a flat structure).
    pub depth: usize,
    /// Bytes held by the structure's arrays.
    pub memory_bytes: usize,
    /// How much costlier queries are than on a fresh build over the same entries (1.0 =
    /// as good as fresh), where the structure tracks it; `None` where it does not.
    pub quality_ratio: Option<f32>,
}

/// An index over moving boxes: entries come and go by handle, move every frame, and the
/// index stays ready for every [`SpatialQuery`].
///
/// The contract every implementation keeps (the conformance suite in
/// `crates/spatial_accel/tests/conformance` checks it against [`BruteForceIndex`](super::BruteForceIndex)):
/// - an entry is reported by queries from its `insert` to its `remove`, with the bounds of
///   its last accepted `insert` or `update`, once per query;
/// - a refused edit ([`IndexError`]) changes nothing;
/// - after edits, call [`maintain`](Self::maintain) before the next query: it makes the
///   structure consistent (a tree refits what moved), then spends up to its budget making
///   later queries cheaper.
///
/// ```
/// use spatial_accel::query::{BruteForceIndex, DynamicIndex};
/// use spatial_accel::{Aabb, DynamicBvh, SpatialQuery};
/// use core::ops::ControlFlow;
/// use glam::Vec3A;
/// use std::time::Duration;
///
/// fn follow<I: DynamicIndex>(index: &mut I) -> Vec<u32> {
///     let a = index.insert(1, Aabb::new(Vec3A::ZERO, Vec3A::ONE)).unwrap();
///     let b = index.insert(2, Aabb::new(Vec3A::splat(5.0), Vec3A::splat(6.0))).unwrap();
///     index.update(a, Aabb::new(Vec3A::splat(10.0), Vec3A::splat(11.0))).unwrap();
///     index.remove(b).unwrap();
///     index.maintain(Duration::ZERO);
///     let mut found = Vec::new();
///     let query = Aabb::new(Vec3A::splat(9.0), Vec3A::splat(12.0));
///     index.for_each_overlapping_aabb(&query, |id| {
///         found.push(id);
///         ControlFlow::Continue(())
///     });
///     found
/// }
/// assert_eq!(follow(&mut DynamicBvh::new()), [1]);
/// assert_eq!(follow(&mut BruteForceIndex::new()), [1]);
/// ```
pub trait DynamicIndex: SpatialQuery {
    /// A stable reference to one entry: valid from `insert` until `remove`. A handle kept
    /// past `remove` is reported as stale, never taken for a later entry.
    type Handle: Copy + Eq + Hash + fmt::Debug;

    /// Adds an entry with the caller's `id` and its box.
    fn insert(&mut self, id: u32, bounds: Aabb) -> Result<Self::Handle, IndexError>;

    /// Gives an entry new bounds. `Ok(true)` when the structure changed; `Ok(false)` when
    /// the entry still fits where it is (a fat leaf, a loose cell) and only its box was
    /// written.
    fn update(&mut self, handle: Self::Handle, bounds: Aabb) -> Result<bool, IndexError>;

    /// Removes an entry, returning its id.
    fn remove(&mut self, handle: Self::Handle) -> Result<u32, IndexError>;

    /// The id of a live entry.
    fn id(&self, handle: Self::Handle) -> Option<u32>;

    /// The bounds last given to a live entry (not enlarged by any margin).
    fn bounds_of(&self, handle: Self::Handle) -> Option<Aabb>;

    /// Number of entries.
    fn len(&self) -> usize;

    /// True when the index holds nothing.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Removes every entry; every handle becomes stale.
    fn clear(&mut self);

    /// The once-per-frame call after edits: makes the index consistent for queries, then
    /// spends up to `budget` improving it.
    fn maintain(&mut self, budget: Duration) -> UpkeepReport;

    /// Shape and cost, without a walk.
    fn index_stats(&self) -> IndexStats;

    /// Calls `visit` for each node of the structure whose depth lies in `depths`, shallowest
    /// first (every node of one depth before any deeper one), for debug overlays. The walk
    /// stops as soon as `visit` breaks, and returns [`ControlFlow::Break`] then.
    ///
    /// Nothing below `depths.end()` is read, so the cost follows what is drawn: an overlay
    /// with a line budget keeps the top of the tree by breaking once it is spent. An empty
    /// range or an empty index visits nothing. What a node and its depth are is each
    /// structure's own, documented on its implementation (see [`NodeView`]); in short:
    /// - [`DynamicBvh`](crate::DynamicBvh): every node with its fat box, depth the edges from
    ///   the root;
    /// - [`LooseOctree`](crate::LooseOctree) and [`Quadtree`](crate::Quadtree): every octant
    ///   in use with its loose cell, depth the levels below the root;
    /// - [`UniformGrid`](crate::UniformGrid): every non-empty cell at depth 0, every
    ///   oversize entry at depth 1;
    /// - [`BruteForceIndex`](super::BruteForceIndex): the list as one leaf at depth 0.
    ///
    /// Bounds are those the structure holds: after edits, call [`maintain`](Self::maintain)
    /// first for bounds that contain what they hold.
    ///
    /// ```
    /// use spatial_accel::query::{AnyIndex, DynamicIndex, IndexKind};
    /// use spatial_accel::Aabb;
    /// use core::ops::ControlFlow;
    /// use glam::Vec3A;
    /// use std::time::Duration;
    ///
    /// for kind in IndexKind::ALL {
    ///     let mut index = AnyIndex::new(kind);
    ///     for i in 0..100 {
    ///         let p = Vec3A::new(i as f32 * 2.0, (i % 7) as f32, 0.0);
    ///         index.insert(i, Aabb::new(p, p + 0.5)).unwrap();
    ///     }
    ///     index.maintain(Duration::ZERO);
    ///     // At most 16 boxes of the top two levels, shallowest first.
    ///     let mut lines = Vec::new();
    ///     index.visit_nodes(0..=1, &mut |node| {
    ///         lines.push((node.depth, node.bounds));
    ///         if lines.len() == 16 { ControlFlow::Break(()) } else { ControlFlow::Continue(()) }
    ///     });
    ///     assert!(!lines.is_empty() && lines.len() <= 16);
    ///     assert!(lines.windows(2).all(|w| w[0].0 <= w[1].0 && w[1].0 <= 1));
    /// }
    /// ```
    fn visit_nodes(
        &self,
        depths: RangeInclusive<u32>,
        visit: &mut dyn FnMut(NodeView) -> ControlFlow<()>,
    ) -> ControlFlow<()>;
}
