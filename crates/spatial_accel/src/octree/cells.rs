//! The arena of cells: each octant's place in space, its links, its node bounds and the
//! entries it keeps; and the cell geometry the placement rules are written in.

use crate::Aabb;
use glam::Vec3A;

/// The null link: no parent, no root, no octant.
pub(super) const NONE: u32 = u32::MAX;

/// One entry kept at an octant: the box last given, and the handle slot that names it.
#[derive(Clone, Copy, Debug)]
pub(super) struct Entry {
    pub(super) bounds: Aabb,
    pub(super) slot: u32,
}

/// One cell of the tree (an octant, or a quadrant in the quadtree).
///
/// Laid out by cache line: a walk reads the first line of every node it meets (bounds and
/// children) and the second of those it enters (the ids, and the cell for an edit); the
/// third holds what only edits and the refit read.
#[derive(Clone, Debug)]
#[repr(C, align(64))]
pub(super) struct Octant {
    /// The node bounds queries see: `own` and the children's bounds, as of the last refit.
    /// Tighter than the loose cell, so queries prune on what is there.
    pub(super) tight: Aabb,
    /// The children, in ascending octant index; the first `child_mask.count_ones()` are
    /// meaningful. A compact run, so the tree view hands it out as a slice. A child is the
    /// nearest octant in use below its octant index, possibly several levels down: cells
    /// that would hold nothing but one child are not made (a compressed octree), so sparse
    /// regions cost an octant per object, not a chain of them.
    pub(super) children: [u32; 8],
    /// The caller's ids of the entries kept here (the tree view's primitives), parallel to
    /// `entries`.
    pub(super) ids: Vec<u32>,
    /// The parent octant, or [`NONE`] for the root (and for free octants).
    pub(super) parent: u32,
    /// Half the side of the cell (the loose cell's is `looseness` times it).
    pub(super) half: f32,
    /// Levels below the world cube: 0 for it, negative for roots grown above it.
    pub(super) level: i16,
    /// Which octant of its parent's cell this cell lies in (bit `a` set: the upper half on
    /// axis `a`).
    pub(super) index_in_parent: u8,
    /// Bit `i` set when a child lies in octant index `i`.
    pub(super) child_mask: u8,
    /// Queued for the next refit.
    pub(super) dirty: bool,
    /// An old root kept below the roots grown above it: its cell is its own, not the one its
    /// parent's would compute (offsetting a centre and back need not round to it). Every
    /// other octant's cell is computed from its parent's.
    pub(super) anchored: bool,
    /// The cell's centre.
    pub(super) center: Vec3A,
    /// The union of the entries' boxes, kept exact by every entry edit while the entries are
    /// in cache, so the refit reads no entry.
    pub(super) own: Aabb,
    /// The entries' boxes and slots.
    pub(super) entries: Vec<Entry>,
}

const _: () = assert!(
    size_of::<Octant>() <= 192,
    "an octant spans three cache lines"
);

impl Octant {
    fn new(center: Vec3A, half: f32, level: i16, parent: u32, index_in_parent: u8) -> Self {
        Self {
            tight: Aabb::EMPTY,
            children: [NONE; 8],
            ids: Vec::new(),
            parent,
            half,
            level,
            index_in_parent,
            child_mask: 0,
            dirty: false,
            anchored: false,
            center,
            own: Aabb::EMPTY,
            entries: Vec::new(),
        }
    }

    /// The existing children, in ascending octant index.
    #[inline]
    pub(super) fn children(&self) -> &[u32] {
        &self.children[..self.child_mask.count_ones() as usize]
    }

    /// The position of octant index `index` in the compact run: the children before it.
    #[inline]
    fn rank(&self, index: u8) -> usize {
        (self.child_mask & ((1u8 << index) - 1)).count_ones() as usize
    }

    /// The child of octant index `index`, if it exists.
    #[inline]
    pub(super) fn child(&self, index: u8) -> Option<u32> {
        (self.child_mask & (1 << index) != 0).then(|| self.children[self.rank(index)])
    }

    /// Records `child` as the child of octant index `index` (which must be absent).
    pub(super) fn attach_child(&mut self, index: u8, child: u32) {
        debug_assert!(self.child_mask & (1 << index) == 0, "octant already taken");
        let (rank, count) = (self.rank(index), self.child_mask.count_ones() as usize);
        self.children.copy_within(rank..count, rank + 1);
        self.children[rank] = child;
        self.child_mask |= 1 << index;
    }

    /// Puts `child` in place of the existing child of octant index `index`.
    pub(super) fn replace_child(&mut self, index: u8, child: u32) {
        debug_assert!(self.child_mask & (1 << index) != 0, "no such child");
        let rank = self.rank(index);
        self.children[rank] = child;
    }

    /// Forgets the child of octant index `index` (which must exist).
    pub(super) fn detach_child(&mut self, index: u8) {
        debug_assert!(self.child_mask & (1 << index) != 0, "no such child");
        let (rank, count) = (self.rank(index), self.child_mask.count_ones() as usize);
        self.children.copy_within(rank + 1..count, rank);
        self.children[count - 1] = NONE;
        self.child_mask &= !(1 << index);
    }

    /// True when the octant keeps no entry and has no child: it is freed then.
    #[inline]
    pub(super) fn is_empty(&self) -> bool {
        self.ids.is_empty() && self.child_mask == 0
    }

    /// Bytes held by the entry arrays.
    pub(super) fn entry_bytes(&self) -> usize {
        self.ids.capacity() * size_of::<u32>() + self.entries.capacity() * size_of::<Entry>()
    }

    /// Appends an entry, returning its position.
    pub(super) fn push_entry(&mut self, id: u32, bounds: Aabb, slot: u32) -> u32 {
        if self.entries.len() == self.entries.capacity() {
            // Most octants keep one entry or a few: grow from one by doubling, where a plain
            // push would make room for four at once.
            let more = self.entries.len().max(1);
            self.entries.reserve_exact(more);
            self.ids
                .reserve_exact(self.entries.capacity() - self.ids.len());
        }
        self.ids.push(id);
        self.entries.push(Entry { bounds, slot });
        self.own = self.own.union(&bounds);
        (self.ids.len() - 1) as u32
    }

    /// Takes out the entry at `position` (the last moves into its place), returning its id,
    /// its box and the slot of the entry that moved, if one did.
    pub(super) fn take_entry(&mut self, position: usize) -> (u32, Aabb, Option<u32>) {
        let id = self.ids.swap_remove(position);
        let taken = self.entries.swap_remove(position).bounds;
        if touches_boundary(&self.own, &taken) {
            self.own = self.entries_union();
        }
        (id, taken, self.entries.get(position).map(|e| e.slot))
    }

    /// Gives the entry at `position` a new box.
    pub(super) fn rewrite_entry(&mut self, position: usize, bounds: Aabb) {
        let old = core::mem::replace(&mut self.entries[position].bounds, bounds);
        // Only a box that shaped a side of `own` can shrink it; any other just adds to it.
        self.own = if touches_boundary(&self.own, &old) {
            self.entries_union()
        } else {
            self.own.union(&bounds)
        };
    }

    /// The union of the entries' boxes, recomputed.
    pub(super) fn entries_union(&self) -> Aabb {
        self.entries
            .iter()
            .fold(Aabb::EMPTY, |acc, e| acc.union(&e.bounds))
    }
}

/// Whether `b` lies on a face of `bounds` (which contains it): removing or moving it may
/// then shrink `bounds`.
#[inline]
fn touches_boundary(bounds: &Aabb, b: &Aabb) -> bool {
    (b.min.cmple(bounds.min) | b.max.cmpge(bounds.max)).any()
}

/// The octants, with a free list: an emptied octant is released at once and its storage
/// (the entry arrays' capacity included) reused by the next octant needed, so a long run of
/// edits never grows the arena past the most octants alive at once.
#[derive(Clone, Debug, Default)]
pub(super) struct Arena {
    pub(super) octants: Vec<Octant>,
    pub(super) free: Vec<u32>,
}

impl Arena {
    /// Octants in use.
    #[inline]
    pub(super) fn live(&self) -> usize {
        self.octants.len() - self.free.len()
    }

    /// A fresh octant with the given cell, queued nowhere, holding nothing.
    pub(super) fn allocate(
        &mut self,
        center: Vec3A,
        half: f32,
        level: i16,
        parent: u32,
        index_in_parent: u8,
    ) -> u32 {
        match self.free.pop() {
            Some(o) => {
                let octant = &mut self.octants[o as usize];
                // The entry arrays were emptied on release; their capacity is kept.
                let (ids, entries) = (
                    core::mem::take(&mut octant.ids),
                    core::mem::take(&mut octant.entries),
                );
                *octant = Octant {
                    ids,
                    entries,
                    ..Octant::new(center, half, level, parent, index_in_parent)
                };
                o
            }
            None => {
                let o = self.octants.len() as u32;
                self.octants
                    .push(Octant::new(center, half, level, parent, index_in_parent));
                o
            }
        }
    }

    /// Returns an octant (already emptied and unlinked by the caller) to the free list.
    pub(super) fn release(&mut self, o: u32) {
        let octant = &mut self.octants[o as usize];
        debug_assert!(octant.is_empty(), "released a non-empty octant");
        octant.parent = NONE;
        // A freed octant may still be listed for refit; the cleared flag makes the refit
        // skip it.
        octant.dirty = false;
        octant.tight = Aabb::EMPTY;
        self.free.push(o);
    }

    #[inline]
    pub(super) fn get(&self, o: u32) -> &Octant {
        &self.octants[o as usize]
    }

    #[inline]
    pub(super) fn get_mut(&mut self, o: u32) -> &mut Octant {
        &mut self.octants[o as usize]
    }
}

/// The placement axes' bits in a `BVec3A` mask: x and y for the quadtree, all three for the
/// octree.
#[inline(always)]
pub(super) const fn axis_mask<const AXES: usize>() -> u32 {
    (1 << AXES) - 1
}

/// The centre of a box, written so that boxes near `f32::MAX` do not overflow to infinity.
#[inline(always)]
pub(super) fn box_center(b: &Aabb) -> Vec3A {
    b.min * 0.5 + b.max * 0.5
}

/// Whether the loose cell of half size `half * looseness` around `center` contains `b` on the
/// placement axes (the quadtree's cells span all of z).
#[inline(always)]
pub(super) fn loose_contains<const AXES: usize>(
    center: Vec3A,
    half: f32,
    looseness: f32,
    b: &Aabb,
) -> bool {
    let reach = Vec3A::splat(half * looseness);
    let inside = (center - reach).cmple(b.min) & b.max.cmple(center + reach);
    inside.bitmask() & axis_mask::<AXES>() == axis_mask::<AXES>()
}

/// The octant index of the child of a cell centred at `center` whose cell holds `point`: bit
/// `a` set for the upper half on axis `a`. A point on a dividing plane goes up, so every
/// point has exactly one child.
#[inline(always)]
pub(super) fn child_index<const AXES: usize>(center: Vec3A, point: Vec3A) -> u8 {
    (point.cmpge(center).bitmask() & axis_mask::<AXES>()) as u8
}

/// The centre of the child of octant index `index` of a cell of half size `half`.
#[inline(always)]
pub(super) fn child_center<const AXES: usize>(center: Vec3A, half: f32, index: u8) -> Vec3A {
    let quarter = half * 0.5;
    let mut offset = Vec3A::ZERO;
    for axis in 0..AXES {
        offset[axis] = if index >> axis & 1 == 1 {
            quarter
        } else {
            -quarter
        };
    }
    center + offset
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn children_stay_compact_and_ordered() {
        let mut o = Octant::new(Vec3A::ZERO, 1.0, 0, NONE, 0);
        for (index, child) in [(5u8, 50u32), (1, 10), (7, 70), (0, 0), (3, 30)] {
            o.attach_child(index, child);
        }
        assert_eq!(o.children(), &[0, 10, 30, 50, 70]);
        assert_eq!(o.child(3), Some(30));
        assert_eq!(o.child(2), None);
        o.detach_child(1);
        o.detach_child(7);
        assert_eq!(o.children(), &[0, 30, 50]);
        assert_eq!((o.child(5), o.child(7)), (Some(50), None));
        for index in [0, 3, 5] {
            o.detach_child(index);
        }
        assert!(o.is_empty());
    }

    #[test]
    fn the_quadtree_ignores_z() {
        let tall = Aabb::new(Vec3A::new(0.1, 0.1, -1e6), Vec3A::new(0.2, 0.2, 1e6));
        assert!(loose_contains::<2>(Vec3A::ZERO, 0.5, 1.0, &tall));
        assert!(!loose_contains::<3>(Vec3A::ZERO, 0.5, 1.0, &tall));
        let below = Vec3A::new(1.0, -1.0, -5.0);
        assert_eq!(child_index::<2>(Vec3A::ZERO, below), 0b01);
        assert_eq!(child_index::<3>(Vec3A::ZERO, below), 0b001);
        assert_eq!(
            child_center::<2>(Vec3A::ZERO, 2.0, 0b01),
            Vec3A::new(1.0, -1.0, 0.0)
        );
    }
}
