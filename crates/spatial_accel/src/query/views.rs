//! One walk for several views at once: which views hold each primitive wholly, which only
//! cross it, and which never reach it. [`for_each_in_views`] is the walk of every
//! [`BoundingTree`] behind
//! [`SpatialQuery::for_each_in_views`](super::SpatialQuery::for_each_in_views).
//!
//! A point light's shadow has six cube faces, a directional light four cascades per camera.
//! Walking the tree once per view repeats the descent through the top of the tree, where
//! every view's answer is "crossing", once for each view. Here each node is classified only
//! against the views still undecided above it (Assarsson and Möller's plane masking, 2000,
//! applied to whole views), and a subtree leaves the walk as soon as every view has decided
//! it.

use super::walks::visit_subtree;
use super::{BoundingTree, NodeVolume};
use crate::Aabb;

/// Which views, one bit each, a primitive's tree box lies wholly inside (`inside`: no test
/// needed), and which only cross its leaf (`crossing`: the caller tests it). A view in
/// neither never reached it: the primitive's box is outside that view.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct ViewMasks {
    /// Views holding the whole primitive box.
    pub inside: u32,
    /// Views whose boundary crosses the primitive's leaf.
    pub crossing: u32,
}

impl ViewMasks {
    /// The masks a walk starts from at the root: no view decided, all of `views` to ask.
    #[inline]
    pub fn undecided(views: u32) -> Self {
        Self {
            inside: 0,
            crossing: views,
        }
    }

    /// The masks of a node whose bounds classify as `c` against the views still undecided
    /// above it, given its parent's masks (`self`: the views holding the parent wholly, and
    /// those crossing it, which are the ones asked about). `None` when no view reaches the
    /// node. Every walk of [`SpatialQuery::for_each_in_views`](super::SpatialQuery) steps
    /// down its tree with this.
    #[inline]
    pub fn below(self, c: ViewClassification) -> Option<ViewMasks> {
        let newly_inside = c.inside & self.crossing;
        let masks = ViewMasks {
            inside: self.inside | newly_inside,
            crossing: self.crossing & !(newly_inside | c.outside),
        };
        (masks.inside | masks.crossing != 0).then_some(masks)
    }
}

/// How a box stands with the views asked about: `inside` holds the views containing it
/// wholly, `outside` those it lies wholly outside of. Views in neither are undecided.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ViewClassification {
    /// Views that hold the whole box.
    pub inside: u32,
    /// Views the box lies wholly outside of.
    pub outside: u32,
}

/// Visits each primitive that at least one of the views in `views` (a bit mask, up to 32
/// views) reaches, once, with the views that hold it and those that cross it.
///
/// `classify(bounds, undecided)` says how a node's box stands with the views of `undecided`;
/// answers for other views are ignored. It must be monotone, as box-against-volume tests
/// are: a box inside (outside) a view makes every box within it inside (outside) too. Then
/// a primitive's `inside` views hold its tree box, and the views missing from its masks lie
/// wholly outside its tree box.
///
/// ```
/// use spatial_accel::query::views::{ViewClassification, for_each_in_views};
/// use spatial_accel::{Aabb, BuildConfig, Bvh};
/// use glam::Vec3A;
/// let boxes: Vec<Aabb> = (0..10)
///     .map(|i| Aabb::new(Vec3A::new(i as f32, 0.0, 0.0), Vec3A::new(i as f32 + 0.5, 1.0, 1.0)))
///     .collect();
/// let bvh = Bvh::build(&boxes, &BuildConfig::default());
/// // View 0 is x < 5, view 1 is x > 5: classify a box against each undecided view.
/// let classify = |b: &Aabb, undecided: u32| {
///     let mut c = ViewClassification::default();
///     if undecided & 1 != 0 {
///         if b.max.x < 5.0 { c.inside |= 1 } else if b.min.x >= 5.0 { c.outside |= 1 }
///     }
///     if undecided & 2 != 0 {
///         if b.min.x > 5.0 { c.inside |= 2 } else if b.max.x <= 5.0 { c.outside |= 2 }
///     }
///     c
/// };
/// let mut seen = Vec::new();
/// for_each_in_views(&bvh, 0b11, classify, |id, masks| seen.push((id, masks.inside | masks.crossing)));
/// seen.sort();
/// // Every box is reached by exactly one of the two views (or crossed by both near x = 5).
/// assert_eq!(seen.len(), 10);
/// assert!(seen.iter().all(|&(id, views)| views == if id < 5 { 1 } else { 2 } || views == 3));
/// ```
pub fn for_each_in_views<T, C, F>(tree: &T, views: u32, mut classify: C, mut visit: F)
where
    T: BoundingTree + ?Sized,
    C: FnMut(&Aabb, u32) -> ViewClassification,
    F: FnMut(u32, ViewMasks),
{
    let Some(root) = tree.root() else { return };
    if views == 0 {
        return;
    }
    // A queue, not a stack: the order primitives come out in is not promised, and in a
    // queue the node read `PREFETCH_AHEAD` steps from now is already known, so its fetch
    // starts that many steps early. A depth-first walk reads each node right after pushing
    // it, and in a tree larger than the cache it waits one memory latency per node; the
    // queue, with subtree spans read from a table, overlaps those waits (BENCHMARKS.md,
    // Culling). Each entry carries its parent's masks: the views holding it whole, and those
    // to ask.
    let mut queue: Vec<(u32, ViewMasks)> = Vec::with_capacity(256);
    queue.push((root, ViewMasks::undecided(views)));
    let mut next = 0;
    while let Some(&(node, above)) = queue.get(next) {
        next += 1;
        if let Some(&(ahead, _)) = queue.get(next + PREFETCH_AHEAD) {
            tree.prefetch_node(ahead);
        }
        // Keep only the unread part once the read part is the larger: the queue's memory
        // follows the walk's frontier, not the number of nodes visited.
        if next >= 1024 && 2 * next >= queue.len() {
            queue.drain(..next);
            next = 0;
        }
        let c = classify(&tree.node_bounds(node).bounding_box(), above.crossing);
        let Some(masks) = above.below(c) else {
            continue;
        };
        if masks.crossing == 0 {
            // Every view has decided the subtree: emit it whole without another test.
            visit_subtree(tree, node, |p| visit(p, masks));
            continue;
        }
        let children = tree.node_children(node);
        if children.is_none() || T::INTERIOR_PRIMITIVES {
            for &p in tree.node_primitives(node) {
                visit(p, masks);
            }
        }
        let Some(children) = children else { continue };
        // Near the front of the queue, the children are read before the look-ahead above
        // reaches them.
        let prefetch = queue.len() - next < PREFETCH_AHEAD;
        for child in children {
            if prefetch {
                tree.prefetch_node(child);
            }
            queue.push((child, masks));
        }
    }
}

/// How many queued nodes ahead of the one being read [`for_each_in_views`] prefetches: enough
/// to cover a memory latency with the work of that many nodes.
const PREFETCH_AHEAD: usize = 8;
