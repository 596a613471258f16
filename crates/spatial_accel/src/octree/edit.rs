//! Insert, update and remove: where an entry goes, when it moves, and how the tree grows and
//! gives back octants around it.

use super::cells::{NONE, box_center, child_center, child_index, loose_contains};
use super::config::MAX_ROOT_HALF_SIZE;
use super::handle::OctreeHandle;
use super::tree::{LEVEL_OFFSET, LooseTree, population_depth};
use crate::Aabb;
use crate::query::IndexError;
use glam::Vec3A;

/// An edit is refused before it changes anything when fewer octant ids than this are left:
/// one placement allocates at most one octant per level, and there are fewer levels than
/// this (grown roots above the world cube included).
const OCTANT_HEADROOM: usize = 1024;

impl<const AXES: usize> LooseTree<AXES> {
    /// Adds an entry with the caller's `id` and its box, at the deepest octant whose loose
    /// cell holds it (growing the root first when the box lies outside it).
    pub fn insert(&mut self, id: u32, bounds: Aabb) -> Result<OctreeHandle, IndexError> {
        if !bounds.is_finite() {
            return Err(IndexError::InvalidBounds);
        }
        if !self.slots.has_room() || !self.arena_has_room() {
            return Err(IndexError::CapacityExceeded);
        }
        self.spread = self.spread.union(&Aabb::from_point(box_center(&bounds)));
        self.raise_depth_limit(self.len + 1);
        let start = self.root_holding(&bounds);
        let target = self.descend(start, &bounds);
        let handle = self.slots.allocate(target, 0);
        let position = self.push_entry(target, id, bounds, handle.index());
        self.slots.relocate(handle.index(), target, position);
        self.len += 1;
        // A root grown for this box may have passed it down to a child.
        self.collapse_root();
        Ok(handle)
    }

    /// Gives an entry new bounds. `Ok(false)` when it stays in its octant (only its box is
    /// written); `Ok(true)` when it moved to another octant.
    ///
    /// It stays while its box is inside the octant's loose cell, unless it has become small
    /// enough to fit the loose cell of the child holding its centre at looseness
    /// `(1 + looseness) / 2` (see [`LooseOctree`](super::LooseOctree)).
    pub fn update(&mut self, handle: OctreeHandle, bounds: Aabb) -> Result<bool, IndexError> {
        let slot = self.slots.get(handle).ok_or(IndexError::StaleHandle)?;
        if !bounds.is_finite() {
            return Err(IndexError::InvalidBounds);
        }
        if !self.arena_has_room() {
            return Err(IndexError::CapacityExceeded);
        }
        let from = slot.octant;
        let fits_here = self.fits(from, &bounds);
        if fits_here && !self.wants_deeper(from, &bounds) {
            self.rewrite_box(from, slot.position, bounds);
            return Ok(false);
        }
        // Up to the nearest ancestor whose loose cell holds the box, then down from there: a
        // step into a neighbouring cell costs a level or two, not the whole depth.
        let start = if fits_here {
            from
        } else {
            self.nearest_holder(from, &bounds)
        };
        let target = self.descend(start, &bounds);
        if target == from {
            // Only a root that can grow no further keeps a box it does not hold.
            self.rewrite_box(from, slot.position, bounds);
            return Ok(false);
        }
        let (id, _) = self.take_entry(from, slot.position);
        let position = self.push_entry(target, id, bounds, handle.index());
        self.slots.relocate(handle.index(), target, position);
        self.tidy(from);
        self.collapse_root();
        Ok(true)
    }

    /// Asks for what an [`update`](Self::update) of this entry reads at a scattered place:
    /// its octant (the handle's slot record is read to find it). A hint only: a caller
    /// updating many entries in turn calls it a few entries ahead, as the plugin's sync does.
    #[inline]
    pub fn prefetch_entry(&self, handle: OctreeHandle) {
        let Some(slot) = self.slots.slots.get(handle.index() as usize) else {
            return;
        };
        if let Some(octant) = self.arena.octants.get(slot.octant as usize) {
            crate::prefetch::prefetch_all(octant);
        }
    }

    /// Removes an entry, returning its id. Octants left empty are released at once.
    pub fn remove(&mut self, handle: OctreeHandle) -> Result<u32, IndexError> {
        let slot = self.slots.get(handle).ok_or(IndexError::StaleHandle)?;
        let (id, _) = self.take_entry(slot.octant, slot.position);
        self.slots.release(handle.index());
        self.len -= 1;
        self.tidy(slot.octant);
        self.collapse_root();
        Ok(id)
    }

    /// Removes every entry; every handle becomes stale. The octants are dropped (the arena
    /// keeps its capacity).
    pub fn clear(&mut self) {
        self.slots.release_all();
        self.arena.octants.clear();
        self.arena.free.clear();
        self.entry_bytes = 0;
        self.root = NONE;
        self.len = 0;
        self.dirty.clear();
        self.level_counts.fill(0);
        self.spread = Aabb::EMPTY;
        self.depth_limit = population_depth::<AXES>(&self.config, 0, &self.spread);
    }

    /// Lets entries go deeper once `len` entries would crowd the deepest cells allowed (see
    /// [`OctreeConfig::target_occupancy`]), and moves down those at the old limit that now
    /// belong deeper. The limit grows `2^AXES`-fold in entries per level, so the moves cost
    /// O(1) per insertion, amortised.
    fn raise_depth_limit(&mut self, len: usize) {
        let wanted = population_depth::<AXES>(&self.config, len, &self.spread);
        if wanted <= self.depth_limit {
            return;
        }
        let old = self.depth_limit;
        self.depth_limit = wanted;
        let crowded: Vec<(OctreeHandle, Aabb)> = (0..self.slots.slots.len() as u32)
            .filter_map(|slot| {
                let s = self.slots.slots[slot as usize];
                if s.octant == NONE || self.arena.get(s.octant).level != old {
                    return None;
                }
                let handle = OctreeHandle::new(slot, s.generation);
                let bounds = self.arena.get(s.octant).entries[s.position as usize].bounds;
                Some((handle, bounds))
            })
            .collect();
        for (handle, bounds) in crowded {
            // Its box is unchanged: the update moves it only if it now belongs deeper.
            let moved = self.update(handle, bounds);
            debug_assert!(moved.is_ok(), "a live entry's own box: {moved:?}");
        }
    }

    /// Whether the loose cell of octant `o` holds `b`.
    #[inline]
    pub(super) fn fits(&self, o: u32, b: &Aabb) -> bool {
        let octant = self.arena.get(o);
        loose_contains::<AXES>(octant.center, octant.half, self.config.looseness, b)
    }

    /// The cell one level below `o` at octant index `index`: computed from `o`'s cell, except
    /// where that child is an old root below a grown one, which keeps its own cell (see
    /// [`Octant::anchored`](super::cells::Octant::anchored)). The computation reads no other
    /// octant, so the placement tests cost no memory access beyond `o`.
    #[inline]
    pub(super) fn child_cell(&self, o: u32, index: u8) -> (Vec3A, f32) {
        let octant = self.arena.get(o);
        if octant.level < 0
            && let Some(child) = octant.child(index)
            && self.arena.get(child).anchored
        {
            let child = self.arena.get(child);
            return (child.center, child.half);
        }
        (
            child_center::<AXES>(octant.center, octant.half, index),
            octant.half * 0.5,
        )
    }

    /// Whether an entry of box `b` at `o` belongs deeper: `o` is above the deepest level, and
    /// the child cell holding the box's centre would hold the box at the smaller looseness
    /// `descend_looseness`.
    #[inline]
    pub(super) fn wants_deeper(&self, o: u32, b: &Aabb) -> bool {
        let octant = self.arena.get(o);
        if octant.level >= self.depth_limit {
            return false;
        }
        let (center, half) = self.child_cell(o, child_index::<AXES>(octant.center, box_center(b)));
        loose_contains::<AXES>(center, half, self.descend_looseness, b)
    }

    /// Whether the root may double once more (see
    /// [`MAX_ROOT_HALF_SIZE`]).
    pub(super) fn root_can_grow(&self) -> bool {
        let root = self.arena.get(self.root);
        2.0 * root.half <= MAX_ROOT_HALF_SIZE && root.level > -LEVEL_OFFSET
    }

    fn arena_has_room(&self) -> bool {
        self.arena.live() + OCTANT_HEADROOM < NONE as usize
    }

    /// The root, made as the world cube when the tree is empty, grown until its loose cell
    /// holds `b` and its cell holds the box's centre (or it can grow no further).
    ///
    /// The centre matters as much as the box: a box that the loose cell holds but whose
    /// centre lies outside the cell has no child cell to go down into, and would stay at
    /// the root whatever its size.
    fn root_holding(&mut self, b: &Aabb) -> u32 {
        if self.root == NONE {
            let (center, half) = (self.config.world_center, self.config.world_half_size);
            self.root = self.arena.allocate(center, half, 0, NONE, 0);
            self.mark_dirty(self.root);
        }
        let centre = Aabb::from_point(box_center(b));
        while self.root_can_grow() {
            let root = self.arena.get(self.root);
            let holds_centre = loose_contains::<AXES>(root.center, root.half, 1.0, &centre);
            if holds_centre && self.fits(self.root, b) {
                break;
            }
            self.grow_root(b);
        }
        self.root
    }

    /// Makes a root twice the size with the old root as one of its children, toward the side
    /// where `b` reaches furthest past the old root's loose cell on each axis. Choosing per
    /// side, not by the box's centre, matters for a box that overhangs both sides: growing
    /// toward its centre alone would never reach its far end.
    fn grow_root(&mut self, b: &Aabb) {
        let old = self.root;
        let (center, half, level) = {
            let root = self.arena.get(old);
            (root.center, root.half, root.level)
        };
        let reach = Vec3A::splat(half * self.config.looseness);
        let below = (center - reach) - b.min;
        let above = b.max - (center + reach);
        let upward = above.cmpgt(below).bitmask();
        let mut step = Vec3A::ZERO;
        let mut old_index = 0u8;
        for axis in 0..AXES {
            if upward >> axis & 1 == 1 {
                step[axis] = half;
            } else {
                step[axis] = -half;
                old_index |= 1 << axis;
            }
        }
        if self.arena.get(old).is_empty() {
            // A root made for this very box: it becomes the larger cell itself, rather than
            // an empty child that nothing would ever release.
            let root = self.arena.get_mut(old);
            root.center += step;
            root.half *= 2.0;
            root.level -= 1;
            self.requeue(old);
            return;
        }
        let new = self
            .arena
            .allocate(center + step, 2.0 * half, level - 1, NONE, 0);
        self.arena.get_mut(new).attach_child(old_index, old);
        let old_root = self.arena.get_mut(old);
        old_root.parent = new;
        old_root.index_in_parent = old_index;
        old_root.anchored = true;
        self.root = new;
        self.mark_dirty(new);
    }

    /// The nearest strict ancestor of `o` whose loose cell holds `b`, growing the root when
    /// none does.
    fn nearest_holder(&mut self, o: u32, b: &Aabb) -> u32 {
        let mut a = self.arena.get(o).parent;
        while a != NONE {
            if self.fits(a, b) {
                return a;
            }
            a = self.arena.get(a).parent;
        }
        self.root_holding(b)
    }

    /// From `start` (whose loose cell holds `b`, or the root), down the cells holding the
    /// box's centre while their loose cells hold the box. Returns the octant the entry
    /// belongs to, made if needed.
    ///
    /// The cells between an octant and a child several levels below it exist only as
    /// arithmetic: the walk computes them, and makes one only where the box stops in it or
    /// where the box's path leaves the child's (a branching cell). A new branch is one octant
    /// at the deepest cell that holds the box.
    fn descend(&mut self, start: u32, b: &Aabb) -> u32 {
        let point = box_center(b);
        let (looseness, max_level) = (self.config.looseness, self.depth_limit);
        let mut o = start;
        'octants: loop {
            let (level, index, existing) = {
                let octant = self.arena.get(o);
                let index = child_index::<AXES>(octant.center, point);
                (octant.level, index, octant.child(index))
            };
            if level >= max_level {
                return o;
            }
            let (mut center, mut half) = self.child_cell(o, index);
            if !loose_contains::<AXES>(center, half, looseness, b) {
                return o;
            }
            let mut cell_level = level + 1;
            let Some(child) = existing else {
                while cell_level < max_level {
                    let below = child_index::<AXES>(center, point);
                    let next = child_center::<AXES>(center, half, below);
                    if !loose_contains::<AXES>(next, half * 0.5, looseness, b) {
                        break;
                    }
                    (center, half, cell_level) = (next, half * 0.5, cell_level + 1);
                }
                let leaf = self.arena.allocate(center, half, cell_level, o, index);
                self.arena.get_mut(o).attach_child(index, leaf);
                self.mark_dirty(leaf);
                return leaf;
            };
            let (child_center_point, child_level) = {
                let c = self.arena.get(child);
                (c.center, c.level)
            };
            // The cell (center, half, cell_level) holds the box and lies on the child's path.
            while cell_level < child_level {
                let below = child_index::<AXES>(center, point);
                if below != child_index::<AXES>(center, child_center_point) {
                    // The paths part here: this cell becomes an octant with the child below
                    // it, and the walk goes on from it into the box's side.
                    o = self.split_link(o, index, child, center, half, cell_level);
                    continue 'octants;
                }
                let next = child_center::<AXES>(center, half, below);
                if !loose_contains::<AXES>(next, half * 0.5, looseness, b) {
                    return self.split_link(o, index, child, center, half, cell_level);
                }
                (center, half, cell_level) = (next, half * 0.5, cell_level + 1);
            }
            o = child;
        }
    }

    /// Makes the cell (`center`, `half`, `level`), which lies between `o` and its child
    /// `child` at octant index `index`, an octant of its own: `o`'s child, and `child`'s
    /// parent.
    fn split_link(
        &mut self,
        o: u32,
        index: u8,
        child: u32,
        center: Vec3A,
        half: f32,
        level: i16,
    ) -> u32 {
        let child_center_point = self.arena.get(child).center;
        let middle = self.arena.allocate(center, half, level, o, index);
        let below = child_index::<AXES>(center, child_center_point);
        self.arena.get_mut(middle).attach_child(below, child);
        self.arena.get_mut(o).replace_child(index, middle);
        let c = self.arena.get_mut(child);
        c.parent = middle;
        c.index_in_parent = below;
        self.mark_dirty(middle);
        middle
    }

    /// Queues `o` for the next refit.
    #[inline]
    pub(super) fn mark_dirty(&mut self, o: u32) {
        let octant = self.arena.get_mut(o);
        if !octant.dirty {
            octant.dirty = true;
            // The level goes with it, so the refit sorts the queue without reading octants.
            self.dirty.push((o, octant.level));
        }
    }

    /// Queues `o` again after its level changed in place (a root grown or moved down): the
    /// refit takes an entry whose level is not the octant's for a stale one.
    fn requeue(&mut self, o: u32) {
        self.arena.get_mut(o).dirty = false;
        self.mark_dirty(o);
    }

    fn rewrite_box(&mut self, o: u32, position: u32, b: Aabb) {
        let octant = self.arena.get_mut(o);
        octant.rewrite_entry(position as usize, b);
        // Node bounds that still hold the box stay valid (see `refit::OWN_MARGIN`); they are
        // recomputed, and may shrink, when the octant is next refit for another reason.
        if !octant.tight.contains_aabb(&b) {
            self.mark_dirty(o);
        }
    }

    /// Appends an entry to `o`, returning its position.
    fn push_entry(&mut self, o: u32, id: u32, b: Aabb, slot: u32) -> u32 {
        let octant = self.arena.get_mut(o);
        let before = octant.entry_bytes();
        let position = octant.push_entry(id, b, slot);
        self.entry_bytes += octant.entry_bytes() - before;
        let level = octant.level;
        self.level_counts[(level + LEVEL_OFFSET) as usize] += 1;
        self.mark_dirty(o);
        position
    }

    /// Takes the entry at `position` out of `o`: the last entry moves into its place and its
    /// slot is told.
    fn take_entry(&mut self, o: u32, position: u32) -> (u32, Aabb) {
        let octant = self.arena.get_mut(o);
        let (id, b, moved) = octant.take_entry(position as usize);
        let level = octant.level;
        if let Some(moved) = moved {
            self.slots.relocate(moved, o, position);
        }
        self.level_counts[(level + LEVEL_OFFSET) as usize] -= 1;
        self.mark_dirty(o);
        (id, b)
    }

    /// Restores the tree's shape after an entry left `o`: releases `o` and then each ancestor
    /// while it holds nothing, and splices out the first one left holding nothing but one
    /// child (its child takes its place), so no chain of empty cells is kept.
    fn tidy(&mut self, mut o: u32) {
        loop {
            let octant = self.arena.get(o);
            let (parent, index) = (octant.parent, octant.index_in_parent);
            if octant.is_empty() {
                self.arena.release(o);
                if parent == NONE {
                    self.root = NONE;
                    // Whatever is still queued was released with the tree.
                    self.dirty.clear();
                    return;
                }
                self.arena.get_mut(parent).detach_child(index);
                self.mark_dirty(parent);
                o = parent;
                continue;
            }
            // The root stays, whatever it holds; an anchored old root keeps its own cell,
            // which its parent would not compute for its child.
            let chain = octant.ids.is_empty() && octant.children().len() == 1;
            if chain && parent != NONE && !octant.anchored {
                let child = octant.children[0];
                let below = self.arena.get(child).index_in_parent;
                self.arena.get_mut(o).detach_child(below);
                self.arena.release(o);
                self.arena.get_mut(parent).replace_child(index, child);
                let c = self.arena.get_mut(child);
                c.parent = parent;
                c.index_in_parent = index;
                self.mark_dirty(parent);
            }
            return;
        }
    }

    /// Drops roots grown above the world cube that keep no entry and one child, so a visit to
    /// the far distance leaves no chain of single-child octants above the world. A root whose
    /// one child lies below the world cube's level moves down to the cell of that level on
    /// the child's path instead: the root is never below the world cube.
    fn collapse_root(&mut self) {
        while self.root != NONE {
            let root = self.arena.get(self.root);
            if root.level >= 0 || !root.ids.is_empty() || root.children().len() != 1 {
                return;
            }
            let child = root.children[0];
            let (child_level, child_center_point) = {
                let c = self.arena.get(child);
                (c.level, c.center)
            };
            if child_level > 0 {
                let (mut center, mut half) = (root.center, root.half);
                for _ in root.level..0 {
                    center = child_center::<AXES>(
                        center,
                        half,
                        child_index::<AXES>(center, child_center_point),
                    );
                    half *= 0.5;
                }
                let root = self.arena.get_mut(self.root);
                (root.center, root.half, root.level) = (center, half, 0);
                let below = child_index::<AXES>(center, child_center_point);
                let old = self.arena.get(child).index_in_parent;
                let root = self.arena.get_mut(self.root);
                root.detach_child(old);
                root.attach_child(below, child);
                self.arena.get_mut(child).index_in_parent = below;
                self.requeue(self.root);
                return;
            }
            let index = self.arena.get(child).index_in_parent;
            let old = self.root;
            self.arena.get_mut(old).detach_child(index);
            self.arena.release(old);
            let c = self.arena.get_mut(child);
            c.parent = NONE;
            c.anchored = false;
            self.root = child;
        }
    }
}
