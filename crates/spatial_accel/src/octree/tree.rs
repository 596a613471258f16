//! The loose tree itself: its parts, its constructors and what it reports about itself.

use super::cells::{Arena, NONE};
use super::config::{OctreeConfig, OctreeConfigError};
use super::handle::{OctreeHandle, Slots};
use crate::Aabb;
use glam::Vec3A;

/// Entry counts per level are kept at `level + LEVEL_OFFSET`: levels run from the deepest
/// grown root (above the world cube, negative) to `max_depth`.
pub(super) const LEVEL_OFFSET: i16 = 256;

/// A loose tree over `AXES` placement axes: the [`LooseOctree`] (3) and the [`Quadtree`] (2)
/// are this one code. See [`LooseOctree`] for how it places, moves and finds objects.
///
/// `AXES` must be 2 or 3 (checked at compile time by the constructors).
#[derive(Clone, Debug)]
pub struct LooseTree<const AXES: usize> {
    pub(super) config: OctreeConfig,
    /// `(1 + looseness) / 2`: an entry that still fits its cell moves to a child only once it
    /// fits that child's cell at this smaller looseness, so an object hovering at the edge of
    /// a child does not go down and up again every frame.
    pub(super) descend_looseness: f32,
    pub(super) arena: Arena,
    /// The root octant, or [`NONE`] when the tree is empty.
    pub(super) root: u32,
    pub(super) slots: Slots,
    pub(super) len: usize,
    /// Octants whose node bounds are stale, with their levels: queued by edits, drained by
    /// the refit.
    pub(super) dirty: Vec<(u32, i16)>,
    /// The refit's per-level queues, kept for their capacity.
    pub(super) refit_buckets: Vec<Vec<u32>>,
    /// Entries per level (see [`LEVEL_OFFSET`]), so the depth is known without a walk.
    pub(super) level_counts: Vec<usize>,
    /// Bytes held by the octants' entry arrays, kept as they grow.
    pub(super) entry_bytes: usize,
    /// The deepest level entries go to now: `max_depth`, or less while the tree holds few
    /// entries (see [`OctreeConfig::target_occupancy`]). It only rises, until `clear`.
    pub(super) depth_limit: i16,
    /// The union of the inserted entries' centres since the tree was last empty: the part of
    /// the world the entries spread over, which the depth limit counts its levels from.
    pub(super) spread: Aabb,
}

/// The depth limit for `len` entries whose centres spread over `spread`: the first level at
/// which the cells over the spread hold them `target_occupancy` at a time, at most
/// `max_depth`.
///
/// Why count from the spread, not the world cube: entries gathered in a small part of a
/// large world would otherwise share a few huge cells.
pub(super) fn population_depth<const AXES: usize>(
    config: &OctreeConfig,
    len: usize,
    spread: &Aabb,
) -> i16 {
    let max = i16::from(config.max_depth);
    if config.target_occupancy == 0 {
        return max;
    }
    // Levels from the world cube down to the first cell as large as the spread.
    let widest = (0..AXES)
        .map(|axis| 0.5 * (spread.max[axis] - spread.min[axis]))
        .fold(0.0f32, f32::max);
    let ratio = config.world_half_size / widest;
    let to_spread = if ratio.is_finite() && ratio > 1.0 {
        (ratio.log2().floor() as i16).min(max)
    } else {
        0
    };
    let (mut depth, mut held) = (to_spread, config.target_occupancy as usize);
    while held < len && depth < max {
        held = held.saturating_mul(1 << AXES);
        depth += 1;
    }
    depth
}

/// A loose octree (Ulrich, Game Programming Gems 1, "Loose Octrees") over moving boxes,
/// keyed by stable [`OctreeHandle`]s.
///
/// **Placement.** Each octant's *loose cell* is its cell scaled by
/// [`OctreeConfig::looseness`] about its centre. An object goes to the deepest octant whose
/// loose cell contains it, following from the root the child whose cell holds the object's
/// centre, so its depth follows from its size: at looseness 2 an object of half size `r`
/// fits the loose cell of any cell of half size `r` or more that holds its centre, whatever
/// its position (Ulrich; Ericson, Real-Time Collision Detection, section 7.3 on loose
/// octrees). Objects live at interior octants as well as leaves, so
/// [`insert`](Self::insert), [`update`](Self::update) and [`remove`](Self::remove) cost
/// O(depth).
///
/// **Depth limit.** By size alone, small objects each end in an octant of their own many
/// levels down. With [`OctreeConfig::target_occupancy`] set, the tree also goes no deeper
/// than the level whose cells would hold its entries that many at a time, a limit that rises
/// as it fills; objects small enough for deeper cells share the octants at the limit. Off by
/// default (Ulrich's rule alone).
///
/// **Motion.** An object whose new box stays inside its octant's loose cell is only
/// rewritten: [`update`](Self::update) returns `Ok(false)`. It moves when it leaves the loose
/// cell (up to the nearest ancestor that holds it, then down), or when it has become small
/// enough to fit a child's cell at looseness `(1 + looseness) / 2`: that band keeps an object
/// at a child's edge from going down and up again every frame.
///
/// **Outside the root.** The root grows: an object outside the root's loose cell, larger
/// than it, or with its centre outside the root's cell, makes a root twice the size above
/// the old one, toward the object, until it holds it (no entry moves: the old root becomes a
/// child). A root above the world cube that keeps no entry and one child is dropped again as
/// soon as that happens, so an object that visits the far distance and comes back leaves no
/// chain behind. Growing keeps every object at the depth its size gives, which an outside
/// list would not (every query would test that list whole, and objects that had wandered
/// out would never be placed by size again). Past
/// [`MAX_ROOT_HALF_SIZE`](super::config::MAX_ROOT_HALF_SIZE) the root stops growing and a box
/// it cannot hold (one reaching near `f32::MAX`) is kept at the root.
///
/// **Storage.** Octants are allocated as objects need them from an arena with a free list,
/// and released as soon as they hold nothing, so a long run of edits does not grow it. Cells
/// that would hold nothing but one child are not made: a link may skip levels (a compressed
/// octree), so an isolated object costs one octant below the nearest branching cell, not a
/// chain of them down to its depth. The cells skipped are computed from their parent's when
/// a walk needs them.
///
/// **Queries.** Every [`SpatialQuery`](crate::SpatialQuery) comes from the shared walks
/// ([`crate::query::walks`]) through the [`BoundingTree`](crate::query::BoundingTree) view.
/// A node's bounds are the union of what it holds (the *tight* bounds), not its loose cell,
/// so queries prune on what is really there. Edits queue the octants they touch;
/// [`maintain`](Self::maintain) refits them, bottom-up, before the next query. Rays go front
/// to back by the shared walk's order (the nearest child the ray enters first): loose cells
/// overlap and tight bounds shrink inside them, so the ray's direction signs alone would not
/// give the order the distances give.
///
/// ```
/// use spatial_accel::octree::LooseOctree;
/// use spatial_accel::query::IndexError;
/// use spatial_accel::{Aabb, Ray, SpatialQuery};
/// use glam::Vec3A;
///
/// let mut tree = LooseOctree::new();
/// let mut boxes = Vec::new();
/// let mut handles = Vec::new();
/// for i in 0..100u32 {
///     let b = Aabb::from_center_half_extents(Vec3A::new(i as f32 * 3.0, 0.0, 0.0), Vec3A::splat(0.5));
///     handles.push(tree.insert(i, b).unwrap());
///     boxes.push(b);
/// }
/// // A small step stays inside the loose cell: only the box is written.
/// let nudged = Aabb::from_center_half_extents(Vec3A::new(0.1, 0.0, 0.0), Vec3A::splat(0.5));
/// assert_eq!(tree.update(handles[0], nudged), Ok(false));
/// boxes[0] = nudged;
/// // A far move changes octant.
/// boxes[1] = Aabb::from_center_half_extents(Vec3A::new(3.0, 40.0, 0.0), Vec3A::splat(0.5));
/// assert_eq!(tree.update(handles[1], boxes[1]), Ok(true));
/// // Let the tree catch up before querying.
/// tree.maintain();
/// tree.validate().unwrap();
///
/// let ray = Ray::new(Vec3A::new(-10.0, 0.0, 0.0), Vec3A::X);
/// let hit = tree.cast_ray(&ray, |id, r| r.intersect_aabb(&boxes[id as usize])).unwrap();
/// assert_eq!(hit.primitive, 0);
///
/// // A handle kept past `remove` is stale, even once its slot is reused.
/// assert_eq!(tree.remove(handles[1]), Ok(1));
/// tree.insert(1000, boxes[1]).unwrap();
/// assert_eq!(tree.remove(handles[1]), Err(IndexError::StaleHandle));
/// ```
pub type LooseOctree = LooseTree<3>;

/// A loose quadtree for 2D worlds (sprites): the [`LooseOctree`]'s code over x and y only.
///
/// Entries are 3D boxes as everywhere in the crate; z plays no part in placement (every
/// cell spans all of z), and the node bounds, being the union of the boxes held, keep each
/// subtree's own z range, so 3D queries stay exact.
///
/// ```
/// use spatial_accel::octree::Quadtree;
/// use spatial_accel::{Aabb, SpatialQuery};
/// use core::ops::ControlFlow;
/// use glam::Vec3A;
///
/// let mut tree = Quadtree::new();
/// let sprite = |x: f32, y: f32| Aabb::new(Vec3A::new(x, y, 0.0), Vec3A::new(x + 1.0, y + 1.0, 0.0));
/// tree.insert(7, sprite(10.0, 10.0)).unwrap();
/// tree.insert(8, sprite(-30.0, 5.0)).unwrap();
/// tree.maintain();
/// let mut found = Vec::new();
/// let area = Aabb::new(Vec3A::new(9.0, 9.0, -1.0), Vec3A::new(12.0, 12.0, 1.0));
/// tree.for_each_overlapping_aabb(&area, |id| {
///     found.push(id);
///     ControlFlow::Continue(())
/// });
/// assert_eq!(found, [7]);
/// ```
pub type Quadtree = LooseTree<2>;

impl<const AXES: usize> Default for LooseTree<AXES> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const AXES: usize> LooseTree<AXES> {
    /// An empty tree with the [default](OctreeConfig::default) settings.
    pub fn new() -> Self {
        Self::with_config(OctreeConfig::default()).expect("the default settings are valid")
    }

    /// An empty tree, or the reason `config` is refused (see [`OctreeConfig::validate`]).
    pub fn with_config(config: OctreeConfig) -> Result<Self, OctreeConfigError> {
        const { assert!(AXES == 2 || AXES == 3, "a loose tree places on 2 or 3 axes") };
        config.validate()?;
        Ok(Self {
            config,
            descend_looseness: 0.5 * (1.0 + config.looseness),
            arena: Arena::default(),
            root: NONE,
            slots: Slots::default(),
            len: 0,
            dirty: Vec::new(),
            refit_buckets: Vec::new(),
            level_counts: vec![0; (LEVEL_OFFSET as usize) + usize::from(config.max_depth) + 1],
            entry_bytes: 0,
            depth_limit: population_depth::<AXES>(&config, 0, &Aabb::EMPTY),
            spread: Aabb::EMPTY,
        })
    }

    /// The settings the tree was made with.
    pub fn config(&self) -> &OctreeConfig {
        &self.config
    }

    /// Number of entries.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when the tree holds nothing.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The id of a live entry.
    pub fn id(&self, handle: OctreeHandle) -> Option<u32> {
        let slot = self.slots.get(handle)?;
        Some(self.arena.get(slot.octant).ids[slot.position as usize])
    }

    /// The box last given to a live entry.
    pub fn bounds_of(&self, handle: OctreeHandle) -> Option<Aabb> {
        let slot = self.slots.get(handle)?;
        Some(self.arena.get(slot.octant).entries[slot.position as usize].bounds)
    }

    /// How many levels below the root a live entry is kept.
    pub fn depth_of(&self, handle: OctreeHandle) -> Option<usize> {
        let slot = self.slots.get(handle)?;
        let level = self.arena.get(slot.octant).level;
        Some((level - self.arena.get(self.root).level) as usize)
    }

    /// The loose cell of the octant keeping a live entry (on the quadtree, all of z).
    pub fn loose_cell_of(&self, handle: OctreeHandle) -> Option<Aabb> {
        let slot = self.slots.get(handle)?;
        Some(self.cell_bounds(slot.octant, self.config.looseness))
    }

    /// The root's cell (not loosened), or `None` when the tree is empty: the world cube, or
    /// the larger cube the root grew to.
    pub fn root_cell(&self) -> Option<Aabb> {
        (self.root != NONE).then(|| self.cell_bounds(self.root, 1.0))
    }

    /// Octants in use.
    pub fn octant_count(&self) -> usize {
        self.arena.live()
    }

    /// Octants the arena has ever held (in use or on its free list): the high-water mark of
    /// [`octant_count`](Self::octant_count).
    pub fn allocated_octants(&self) -> usize {
        self.arena.octants.len()
    }

    /// Levels from the root down to the deepest entry (0 when empty or flat).
    pub fn depth(&self) -> usize {
        let Some(deepest) = self.level_counts.iter().rposition(|&n| n > 0) else {
            return 0;
        };
        let root_level = self.arena.get(self.root).level;
        (deepest as i16 - LEVEL_OFFSET - root_level) as usize
    }

    /// Bytes held by the tree's arrays.
    pub fn memory_bytes(&self) -> usize {
        self.arena.octants.capacity() * size_of::<super::cells::Octant>()
            + self.arena.free.capacity() * size_of::<u32>()
            + self.entry_bytes
            + self.slots.memory_bytes()
            + self.dirty.capacity() * size_of::<(u32, i16)>()
            + self.level_counts.capacity() * size_of::<usize>()
    }

    /// True when edits are waiting for [`maintain`](Self::maintain): node bounds are stale
    /// until it runs, and queries made in between may miss entries (debug builds assert
    /// against it).
    pub fn needs_maintain(&self) -> bool {
        !self.dirty.is_empty()
    }

    /// An octant's cell scaled by `looseness` about its centre; on the quadtree it spans all
    /// of z.
    pub(super) fn cell_bounds(&self, o: u32, looseness: f32) -> Aabb {
        let octant = self.arena.get(o);
        let reach = Vec3A::splat(octant.half * looseness);
        let mut b = Aabb::from_center_half_extents(octant.center, reach);
        for axis in AXES..3 {
            b.min[axis] = f32::NEG_INFINITY;
            b.max[axis] = f32::INFINITY;
        }
        b
    }
}
