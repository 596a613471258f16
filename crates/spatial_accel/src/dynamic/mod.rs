//! The dynamic BVH: a binary tree of moving boxes, edited in place in O(log n).
//!
//! Game entities move every frame. Rebuilding a tree every frame wastes the frame; refitting
//! only lets it rot (svenstaro/bvh reports its rays many times slower once a tenth of the
//! shapes moved).
//! [`DynamicBvh`] combines the known remedies so that callers tune nothing:
//!
//! - **Fat leaves** (Box2D): each leaf stores its box grown by a margin, so motion that stays
//!   inside costs one comparison and touches no other node.
//! - **Batched refit** ([`DynamicBvh::refit`]): [`DynamicBvh::update`] only marks the leaves
//!   that left their fat box; the refit then recomputes just their ancestors, bottom-up, each
//!   once, with Kopta 2012 rotations on the way.
//! - **SAH insertion** (Bittner 2013, Box2D v3 `b2FindBestSibling`): a new leaf goes next to
//!   the sibling that adds the least surface area, found by branch and bound in O(log n), and
//!   the ancestors are rotated (Kopta 2012) to repair the tree locally.
//! - **Incremental optimiser** ([`DynamicBvh::optimize`]): each frame, within a time budget,
//!   the internal nodes with the worst SAH inefficiency are taken out and their children
//!   reinserted (Bittner 2013).
//! - **Quality monitor** ([`DynamicBvh::quality`]): the tree's SAH cost, maintained
//!   incrementally, against an estimate of what a fresh binned-SAH build would cost; past
//!   [`DynamicBvhConfig::rebuild_threshold`] [`DynamicBvh::maintain`] rebuilds, optionally on
//!   another thread, and swaps the new tree in at a later call with the edits made meanwhile
//!   applied.
//!
//! Queries go through the same traversal code as the static [`crate::Bvh`]
//! ([`crate::query::walks`]): [`DynamicBvh`] implements [`BoundingTree`] and
//! [`SpatialQuery`](crate::SpatialQuery). A static tree and a dynamic one can be queried as one
//! with [`StaticDynamicPair`] (which also keeps a 16-wide ray snapshot of the dynamic tree),
//! a static tree and any [`DynamicIndex`](crate::query::DynamicIndex) with [`LayeredIndex`];
//! [`PreparedStatic`] makes the static tree's derived tables off the frame that swaps it in.
//!
//! ```
//! use spatial_accel::{Aabb, Ray, SpatialQuery};
//! use spatial_accel::dynamic::DynamicBvh;
//! use glam::Vec3A;
//!
//! let mut tree = DynamicBvh::new();
//! let mut boxes = Vec::new();
//! let mut handles = Vec::new();
//! for i in 0..100u32 {
//!     let b = Aabb::from_center_half_extents(Vec3A::new(i as f32 * 3.0, 0.0, 0.0), Vec3A::splat(0.5));
//!     handles.push(tree.insert(i, b).unwrap());
//!     boxes.push(b);
//! }
//! // A frame: move some entities, then let the tree catch up before querying.
//! for i in (0..100).step_by(7) {
//!     boxes[i] = Aabb::from_center_half_extents(boxes[i].center() + Vec3A::Y * 10.0, Vec3A::splat(0.5));
//!     tree.update(handles[i], boxes[i]).unwrap();
//! }
//! tree.maintain();
//! tree.validate().unwrap();
//!
//! // Queries call back with the caller's id; the callback runs the exact test.
//! let ray = Ray::new(Vec3A::new(-10.0, 0.0, 0.0), Vec3A::X);
//! let hit = tree.cast_ray(&ray, |id, r| r.intersect_aabb(&boxes[id as usize])).unwrap();
//! assert_eq!(hit.primitive, 1); // entity 0 moved up out of the ray's way
//!
//! // Handles are stable until removed, and detected as stale afterwards.
//! assert_eq!(tree.remove(handles[3]), Ok(3));
//! assert!(tree.remove(handles[3]).is_err());
//! ```

mod as_index;
mod config;
mod handle;
mod insert;
mod layered;
mod node;
mod optimize;
mod pair;
mod pair_rays;
mod prepared_static;
mod quality;
mod ray_snapshot;
mod refit;
mod refit_schedule;
mod remove;
mod rotate;
mod validate;

pub use config::DynamicBvhConfig;
pub use handle::{DynamicBvhError, LeafHandle};
pub use layered::{LayeredIndex, merge_nearest};
pub use optimize::OptimizeReport;
pub use pair::StaticDynamicPair;
pub use prepared_static::PreparedStatic;
pub use quality::{MaintainReport, QualityEstimate};
pub use validate::DynamicValidationError;

use crate::bvh::stats::{TreeStats, tree_stats};
use crate::query::BoundingTree;
use crate::{Aabb, SahCosts};
use node::{Arena, MARK_JUMPED, NULL};

/// A dynamic bounding-volume hierarchy keyed by stable [`LeafHandle`]s; see the
/// [module docs](self).
///
/// Edits ([`insert`](Self::insert), [`remove`](Self::remove)) keep the tree queryable at once.
/// [`update`](Self::update) is batched: call [`refit`](Self::refit) or
/// [`maintain`](Self::maintain) once after a frame's updates and before querying (queries made
/// in between may miss leaves that moved; debug builds assert against it).
#[derive(Debug)]
pub struct DynamicBvh {
    arena: Arena,
    /// Tight boxes, indexed like the arena (only leaf entries are meaningful).
    tight: Vec<Aabb>,
    root: u32,
    leaf_count: usize,
    config: DynamicBvhConfig,
    /// Leaves whose fat box changed since the last refit.
    dirty: Vec<u32>,
    /// How many of them are marked jumped (counted as they are marked, so the refit decides
    /// on reinsertion without a pass over the dirty list).
    jumped_pending: usize,
    /// The current refit epoch: a leaf is in the dirty list while its
    /// [`dirty_mark`](node::Node::dirty_mark) names this epoch. Never 0 (the mark of a clean
    /// node).
    refit_epoch: u32,
    /// Reused by the refit pass: queued internal nodes, then the same sorted by height.
    refit_buckets: Vec<Vec<u32>>,
    refit_sorted: Vec<u32>,
    /// The whole-tree refit's compiled shape, replayed while the links stay as they are.
    schedule: refit_schedule::RefitSchedule,
    /// Sum of half areas of internal nodes and of leaves, kept current by every box write
    /// so the SAH cost is O(1) to read.
    internal_area: f64,
    leaf_area: f64,
    /// The largest value of each sum since it was last recomputed (see `set_aabb`).
    area_peaks: (f64, f64),
    optimizer: optimize::OptimizerState,
    quality: quality::QualityState,
}

/// The fraction of its peak below which an area sum is recounted (see `set_aabb`): the
/// rounding error a sum carries is a few ulps of its peak per edit, so below 2^-10 of the
/// peak it could reach the validator's 1e-6 tolerance after a few thousand edits.
const AREA_CANCELLATION: f64 = 1.0 / 1024.0;

impl Default for DynamicBvh {
    fn default() -> Self {
        Self::with_config(DynamicBvhConfig::default())
    }
}

impl Clone for DynamicBvh {
    /// Clones the tree; a background rebuild in flight stays with the original.
    fn clone(&self) -> Self {
        Self {
            arena: self.arena.clone(),
            tight: self.tight.clone(),
            root: self.root,
            leaf_count: self.leaf_count,
            config: self.config,
            dirty: self.dirty.clone(),
            jumped_pending: self.jumped_pending,
            refit_epoch: self.refit_epoch,
            refit_buckets: Vec::new(),
            refit_sorted: Vec::new(),
            schedule: refit_schedule::RefitSchedule::default(),
            internal_area: self.internal_area,
            leaf_area: self.leaf_area,
            area_peaks: self.area_peaks,
            optimizer: optimize::OptimizerState::default(),
            quality: self.quality.clone_without_job(),
        }
    }
}

impl DynamicBvh {
    /// An empty tree with the default configuration.
    pub fn new() -> Self {
        Self::default()
    }

    /// An empty tree with the given configuration.
    pub fn with_config(config: DynamicBvhConfig) -> Self {
        Self {
            arena: Arena::default(),
            tight: Vec::new(),
            root: NULL,
            leaf_count: 0,
            config,
            dirty: Vec::new(),
            jumped_pending: 0,
            refit_epoch: 1,
            refit_buckets: Vec::new(),
            refit_sorted: Vec::new(),
            schedule: refit_schedule::RefitSchedule::default(),
            internal_area: 0.0,
            leaf_area: 0.0,
            area_peaks: (0.0, 0.0),
            optimizer: optimize::OptimizerState::default(),
            quality: quality::QualityState::default(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &DynamicBvhConfig {
        &self.config
    }

    /// Changes the configuration; fat boxes already stored keep their old margin until their
    /// leaf next leaves them.
    pub fn set_config(&mut self, config: DynamicBvhConfig) {
        self.config = config;
    }

    /// Number of leaves.
    pub fn len(&self) -> usize {
        self.leaf_count
    }

    /// True when the tree holds no leaf.
    pub fn is_empty(&self) -> bool {
        self.leaf_count == 0
    }

    /// The fat bounds of everything in the tree (empty for an empty tree).
    pub fn bounds(&self) -> Aabb {
        if self.root == NULL {
            Aabb::EMPTY
        } else {
            self.arena.nodes[self.root as usize].aabb
        }
    }

    /// The longest root-to-leaf path, in edges (0 for an empty tree or a lone leaf): the
    /// [`TreeStats::max_depth`] of [`stats`](Self::stats), read in O(1) from the root's
    /// stored height instead of a walk. Current after [`refit`](Self::refit).
    pub fn height(&self) -> usize {
        if self.root == NULL {
            0
        } else {
            self.arena.nodes[self.root as usize].height as usize
        }
    }

    /// True while updates wait for [`refit`](Self::refit).
    pub fn needs_refit(&self) -> bool {
        !self.dirty.is_empty()
    }

    /// Removes every leaf; all handles become stale.
    pub fn clear(&mut self) {
        self.finish_background_rebuild_discard();
        let n = self.arena.nodes.len();
        for i in 0..n as u32 {
            if !self.arena.nodes[i as usize].is_free() {
                self.arena.free(i);
            }
        }
        self.root = NULL;
        self.schedule.invalidate();
        self.leaf_count = 0;
        self.end_refit_epoch();
        self.jumped_pending = 0;
        self.internal_area = 0.0;
        self.leaf_area = 0.0;
        self.area_peaks = (0.0, 0.0);
    }

    /// Adds a leaf with the caller's `id` (what queries report) and tight `bounds`.
    ///
    /// O(log n): the sibling is chosen by SAH branch and bound and the ancestors rotated.
    /// Non-finite or inverted bounds are refused and the tree left unchanged.
    pub fn insert(&mut self, id: u32, bounds: Aabb) -> Result<LeafHandle, DynamicBvhError> {
        if !bounds.is_finite() {
            return Err(DynamicBvhError::InvalidBounds);
        }
        let fat = self.config.fatten(&bounds);
        if !fat.is_finite() {
            return Err(DynamicBvhError::InvalidBounds);
        }
        // Reserve the leaf and its future parent together, so running out of slots can never
        // leave a leaf allocated but unlinked.
        if self.arena.free_count() < 2 && self.arena.nodes.len() + 2 > node::MAX_NODES {
            return Err(DynamicBvhError::CapacityExceeded);
        }
        let leaf = self
            .arena
            .alloc()
            .ok_or(DynamicBvhError::CapacityExceeded)?;
        if self.tight.len() < self.arena.nodes.len() {
            self.tight.resize(self.arena.nodes.len(), Aabb::EMPTY);
        }
        self.tight[leaf as usize] = bounds;
        self.arena.nodes[leaf as usize].id = id;
        self.set_aabb(leaf, fat);
        self.attach(leaf);
        self.leaf_count += 1;
        self.optimizer.note_change();
        self.quality.note_edit();
        Ok(LeafHandle::new(
            leaf,
            self.arena.nodes[leaf as usize].generation,
        ))
    }

    /// Records a leaf's new tight bounds. Returns whether its fat box had to change (the
    /// leaf left it, or shrank to well under it); only then is the leaf queued for the next
    /// [`refit`](Self::refit), so small motions cost one comparison. Bounds that are not
    /// finite, or whose fat box would overflow, are refused with
    /// [`DynamicBvhError::InvalidBounds`] and change nothing.
    pub fn update(&mut self, handle: LeafHandle, bounds: Aabb) -> Result<bool, DynamicBvhError> {
        let leaf = self.check(handle)?;
        if !bounds.is_finite() {
            return Err(DynamicBvhError::InvalidBounds);
        }
        let fat = self.arena.nodes[leaf as usize].aabb;
        if fat.contains_aabb(&bounds) {
            // A box that shrank to a small part of its fat box would keep the tree loose for
            // ever: refatten once the fat box's area is four times what it needs to be.
            let wanted = self.config.fatten(&bounds);
            if fat.half_area() <= 4.0 * wanted.half_area() + f32::MIN_POSITIVE {
                self.tight[leaf as usize] = bounds;
                return Ok(false);
            }
        }
        let new_fat = self
            .config
            .fatten_moving(&self.tight[leaf as usize], &bounds);
        // Refused before anything is written: a finite box near the float range's end can
        // still fatten to infinity, and the leaf must keep its old, consistent boxes.
        if !new_fat.is_finite() {
            return Err(DynamicBvhError::InvalidBounds);
        }
        self.tight[leaf as usize] = bounds;
        // A jump clear of the old fat box (a teleport, a respawn) is flagged: the refit
        // reinserts such leaves when they are few (see `refit`).
        let jumped = !fat.intersects_aabb(&new_fat);
        self.set_aabb(leaf, new_fat);
        let listed = self.refit_epoch << 1;
        let n = &mut self.arena.nodes[leaf as usize];
        if n.dirty_mark & !MARK_JUMPED != listed {
            n.dirty_mark = listed;
            self.dirty.push(leaf);
        }
        if jumped && n.dirty_mark & MARK_JUMPED == 0 {
            n.dirty_mark |= MARK_JUMPED;
            self.jumped_pending += 1;
        }
        Ok(true)
    }

    /// Asks for the cache lines an [`update`](Self::update) of this leaf reads first (its node
    /// and its tight box), a hint only. A caller updating many leaves in an order unrelated to
    /// the tree's layout (a game's entities after the tree was rebuilt or optimised) waits one
    /// memory latency per leaf otherwise; calling this a few leaves ahead overlaps those waits.
    /// A stale handle is ignored.
    ///
    /// ```
    /// use spatial_accel::{Aabb, dynamic::DynamicBvh};
    /// use glam::Vec3;
    ///
    /// let mut tree = DynamicBvh::new();
    /// let handles: Vec<_> = (0..64u32)
    ///     .map(|i| tree.insert(i, Aabb::new(Vec3::splat(i as f32), Vec3::splat(i as f32 + 1.0))))
    ///     .collect::<Result<_, _>>()
    ///     .unwrap();
    /// // Ask for each leaf a few updates before it is updated.
    /// for (k, &h) in handles.iter().enumerate() {
    ///     if let Some(&ahead) = handles.get(k + 8) {
    ///         tree.prefetch_leaf(ahead);
    ///     }
    ///     let p = Vec3::splat(k as f32 + 5.0);
    ///     tree.update(h, Aabb::new(p, p + 1.0)).unwrap();
    /// }
    /// tree.refit();
    /// ```
    #[inline]
    pub fn prefetch_leaf(&self, handle: LeafHandle) {
        let i = handle.index();
        node::prefetch_index(&self.arena.nodes, i);
        if let Some(tight) = self.tight.get(i as usize) {
            crate::prefetch::prefetch_all(tight);
        }
    }

    /// Removes a leaf and returns its id; O(log n). A stale handle is refused with
    /// [`DynamicBvhError::StaleHandle`] and changes nothing.
    pub fn remove(&mut self, handle: LeafHandle) -> Result<u32, DynamicBvhError> {
        let leaf = self.check(handle)?;
        let id = self.arena.nodes[leaf as usize].id;
        self.detach(leaf);
        self.free_node(leaf);
        self.leaf_count -= 1;
        self.optimizer.note_change();
        self.quality.note_edit();
        Ok(id)
    }

    /// True while the handle names a leaf of this tree.
    pub fn contains(&self, handle: LeafHandle) -> bool {
        self.check(handle).is_ok()
    }

    /// The id a live leaf was inserted with.
    pub fn id(&self, handle: LeafHandle) -> Option<u32> {
        let leaf = self.check(handle).ok()?;
        Some(self.arena.nodes[leaf as usize].id)
    }

    /// The tight bounds last given for a live leaf.
    pub fn tight_bounds(&self, handle: LeafHandle) -> Option<Aabb> {
        let leaf = self.check(handle).ok()?;
        Some(self.tight[leaf as usize])
    }

    /// The fat bounds stored for a live leaf (what traversals test).
    pub fn fat_bounds(&self, handle: LeafHandle) -> Option<Aabb> {
        let leaf = self.check(handle).ok()?;
        Some(self.arena.nodes[leaf as usize].aabb)
    }

    /// Every live leaf as `(handle, id, tight bounds)`, in arena order.
    pub fn leaves(&self) -> impl Iterator<Item = (LeafHandle, u32, Aabb)> + '_ {
        self.arena
            .nodes
            .iter()
            .enumerate()
            .filter(|(_, n)| n.is_leaf())
            .map(|(i, n)| (LeafHandle::new(i as u32, n.generation), n.id, self.tight[i]))
    }

    /// Shape and SAH statistics, walking the whole tree (O(n)); see [`TreeStats`].
    pub fn stats(&self, costs: &SahCosts) -> TreeStats {
        tree_stats(self, costs)
    }

    /// Memory held by the tree's arrays, in bytes.
    pub fn memory_bytes(&self) -> usize {
        self.arena.nodes.capacity() * core::mem::size_of::<node::Node>()
            + self.tight.capacity() * core::mem::size_of::<Aabb>()
            + (self.dirty.capacity()
                + self.refit_buckets.iter().map(Vec::capacity).sum::<usize>()
                + self.refit_sorted.capacity())
                * 4
            + self.schedule.memory_bytes()
    }

    #[inline]
    fn check(&self, handle: LeafHandle) -> Result<u32, DynamicBvhError> {
        match self.arena.nodes.get(handle.index() as usize) {
            Some(n) if n.is_leaf() && n.generation == handle.generation() => Ok(handle.index()),
            _ => Err(DynamicBvhError::StaleHandle),
        }
    }

    /// Writes a node's box, keeping the area sums of the quality monitor current. A node's
    /// kind (leaf or internal) must be set before its box.
    ///
    /// The areas are f64 ([`Aabb::half_area_f64`]): an f32 area of a finite box near the
    /// float range's end is infinite, and once it leaves the sum again the sum is NaN. Such a
    /// box still dwarfs the rest, so that its removal leaves a sum of rounding errors: when a
    /// sum falls below [`AREA_CANCELLATION`] of its peak since the last recount, it is
    /// recounted (O(n), once per such collapse, not per edit).
    #[inline]
    pub(crate) fn set_aabb(&mut self, i: u32, b: Aabb) {
        let n = &mut self.arena.nodes[i as usize];
        let d = b.half_area_f64() - n.aabb.half_area_f64();
        let leaf = n.height == 0;
        n.aabb = b;
        let (sum, peak) = if leaf {
            (&mut self.leaf_area, &mut self.area_peaks.1)
        } else {
            (&mut self.internal_area, &mut self.area_peaks.0)
        };
        *sum += d;
        *peak = peak.max(*sum);
        if *sum < *peak * AREA_CANCELLATION {
            self.recompute_area_sums();
        }
    }

    /// Frees a node, taking its area out of the sums.
    #[inline]
    pub(crate) fn free_node(&mut self, i: u32) {
        self.set_aabb(i, Aabb::EMPTY);
        self.arena.free(i);
    }

    /// Allocates an internal node (height set, empty box).
    #[inline]
    pub(crate) fn alloc_internal(&mut self) -> u32 {
        // Callers reserve capacity up front (a leaf's insertion checks for two slots and
        // every other caller frees a node before allocating one), so this cannot fail.
        let i = self
            .arena
            .alloc()
            .expect("dynamic BVH node capacity checked by the caller");
        self.arena.nodes[i as usize].height = 1;
        if self.tight.len() < self.arena.nodes.len() {
            self.tight.resize(self.arena.nodes.len(), Aabb::EMPTY);
        }
        i
    }

    /// Takes every leaf off the dirty list at once, by starting a new refit epoch: their marks
    /// name an older one from now on. (Once in 2^31 refits the epochs run out, and the marks
    /// are cleared one by one instead.)
    pub(crate) fn end_refit_epoch(&mut self) {
        self.dirty.clear();
        self.refit_epoch += 1;
        if self.refit_epoch > u32::MAX >> 1 {
            for n in &mut self.arena.nodes {
                n.dirty_mark = 0;
            }
            self.refit_epoch = 1;
        }
    }
}

impl BoundingTree for DynamicBvh {
    type Volume = Aabb;
    type Children<'a>
        = [u32; 2]
    where
        Self: 'a;

    #[inline]
    fn root(&self) -> Option<u32> {
        debug_assert!(
            self.dirty.is_empty(),
            "DynamicBvh queried with updates pending: call refit() or maintain() first"
        );
        (self.root != NULL).then_some(self.root)
    }

    #[inline]
    fn node_bounds(&self, node: u32) -> Aabb {
        self.arena.nodes[node as usize].aabb
    }

    #[inline]
    fn node_children(&self, node: u32) -> Option<[u32; 2]> {
        let n = &self.arena.nodes[node as usize];
        (n.height != 0).then_some(n.children)
    }

    #[inline]
    fn prefetch_node(&self, node: u32) {
        node::prefetch_index(&self.arena.nodes, node);
    }

    #[inline]
    fn node_primitives(&self, node: u32) -> &[u32] {
        let n = &self.arena.nodes[node as usize];
        if n.height == 0 {
            core::slice::from_ref(&n.id)
        } else {
            &[]
        }
    }
}

crate::impl_spatial_query_for_tree!(DynamicBvh);
