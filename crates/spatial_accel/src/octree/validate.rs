//! The invariant checker: what the tests ask of the tree after every frame.

use super::cells::{NONE, child_center, child_index};
use super::tree::{LEVEL_OFFSET, LooseTree};
use core::fmt;

/// A broken invariant of a [`LooseTree`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum OctreeValidationError {
    /// Edits are waiting for [`maintain`](LooseTree::maintain), so node bounds are not
    /// current yet.
    PendingEdits,
    /// An octant's links, cell or node bounds are wrong.
    Octant {
        /// The octant.
        octant: u32,
        /// What is wrong with it.
        problem: &'static str,
    },
    /// An entry is misplaced, or its handle slot does not point back at it.
    Entry {
        /// The octant keeping it.
        octant: u32,
        /// Its position there.
        position: usize,
        /// What is wrong with it.
        problem: &'static str,
    },
    /// A count the tree keeps differs from what it holds.
    Count {
        /// What was counted.
        what: &'static str,
        /// The count kept.
        kept: usize,
        /// The count found.
        found: usize,
    },
}

impl fmt::Display for OctreeValidationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::PendingEdits => f.write_str("edits are waiting for maintain"),
            Self::Octant { octant, problem } => write!(f, "octant {octant}: {problem}"),
            Self::Entry {
                octant,
                position,
                problem,
            } => write!(f, "entry {position} of octant {octant}: {problem}"),
            Self::Count { what, kept, found } => {
                write!(f, "{what}: {kept} kept, {found} found")
            }
        }
    }
}

impl std::error::Error for OctreeValidationError {}

fn octant_error(octant: u32, problem: &'static str) -> OctreeValidationError {
    OctreeValidationError::Octant { octant, problem }
}

fn count_error(what: &'static str, kept: usize, found: usize) -> Result<(), OctreeValidationError> {
    if kept == found {
        Ok(())
    } else {
        Err(OctreeValidationError::Count { what, kept, found })
    }
}

impl<const AXES: usize> LooseTree<AXES> {
    /// Checks every invariant, after [`maintain`](Self::maintain):
    /// - every octant is reachable from the root exactly once or is on the free list, never
    ///   both, and none in use is empty;
    /// - a child's parent link, octant index, level and cell agree with its parent (a child
    ///   may lie several levels down; below a grown root, an old root keeps its own cell),
    ///   no octant but the root and the old roots holds nothing but one child, and no level
    ///   is deeper than `max_depth`;
    /// - each octant's node bounds are exactly the union of its entries' boxes and its
    ///   children's bounds (so they contain both);
    /// - every entry is kept once, its handle slot points back at it, its box lies inside its
    ///   octant's loose cell, and it does not belong deeper (see
    ///   [`update`](Self::update)). The one exception is the root once it can grow no
    ///   further, which keeps whatever it cannot hold;
    /// - a root above the world cube keeps an entry or more than one child;
    /// - the entry count, the live handle slots, the per-level counts and the byte count
    ///   match what the octants hold.
    pub fn validate(&self) -> Result<(), OctreeValidationError> {
        if !self.dirty.is_empty() {
            return Err(OctreeValidationError::PendingEdits);
        }
        let octants = self.arena.octants.len();
        let mut seen = vec![false; octants];
        for &free in &self.arena.free {
            match seen.get_mut(free as usize) {
                Some(s) if !*s => *s = true,
                _ => return Err(octant_error(free, "on the free list twice or out of range")),
            }
        }
        let mut level_counts = vec![0usize; self.level_counts.len()];
        let mut entries = 0usize;
        if self.root == NONE {
            count_error("octants in use in an empty tree", 0, self.arena.live())?;
        } else {
            self.check_root()?;
            let mut stack = vec![self.root];
            while let Some(o) = stack.pop() {
                match seen.get_mut(o as usize) {
                    Some(s) if !*s => *s = true,
                    _ => return Err(octant_error(o, "reached twice, or both reached and free")),
                }
                self.check_octant(o)?;
                let octant = self.arena.get(o);
                for position in 0..octant.ids.len() {
                    self.check_entry(o, position)?;
                }
                level_counts[(octant.level + LEVEL_OFFSET) as usize] += octant.ids.len();
                entries += octant.ids.len();
                stack.extend_from_slice(octant.children());
            }
        }
        if let Some(lost) = seen.iter().position(|&s| !s) {
            return Err(octant_error(lost as u32, "neither reachable nor free"));
        }
        count_error("entries", self.len, entries)?;
        let live_slots = self.slots.slots.iter().filter(|s| s.octant != NONE).count();
        count_error("live handle slots", self.len, live_slots)?;
        let mut free_slot = vec![false; self.slots.slots.len()];
        for &slot in &self.slots.free {
            match free_slot.get_mut(slot as usize) {
                Some(f) if !*f && self.slots.slots[slot as usize].octant == NONE => *f = true,
                _ => {
                    return Err(OctreeValidationError::Count {
                        what: "free handle slot listed twice, live or out of range",
                        kept: slot as usize,
                        found: self.slots.slots.len(),
                    });
                }
            }
        }
        count_error(
            "handle slots",
            self.slots.slots.len(),
            live_slots + self.slots.free.len(),
        )?;
        for (level, (&kept, &found)) in self.level_counts.iter().zip(&level_counts).enumerate() {
            if kept != found {
                return Err(OctreeValidationError::Count {
                    what: "entries at a level",
                    kept: level,
                    found,
                });
            }
        }
        let entry_bytes = self.arena.octants.iter().map(|o| o.entry_bytes()).sum();
        count_error("entry bytes", self.entry_bytes, entry_bytes)
    }

    fn check_root(&self) -> Result<(), OctreeValidationError> {
        let root = self.arena.get(self.root);
        if root.parent != NONE || root.anchored {
            return Err(octant_error(
                self.root,
                "the root has a parent or is anchored",
            ));
        }
        if root.level > 0 {
            return Err(octant_error(self.root, "the root is below the world cube"));
        }
        if root.level < 0 && root.ids.is_empty() && root.children().len() == 1 {
            return Err(octant_error(
                self.root,
                "a grown root with one child and no entry was not dropped",
            ));
        }
        Ok(())
    }

    fn check_octant(&self, o: u32) -> Result<(), OctreeValidationError> {
        let octant = self.arena.get(o);
        if octant.is_empty() {
            return Err(octant_error(o, "in use but holds nothing"));
        }
        if octant.dirty {
            return Err(octant_error(o, "still queued for refit"));
        }
        if octant.level > i16::from(self.config.max_depth) {
            return Err(octant_error(o, "deeper than max_depth"));
        }
        if octant.entries.len() != octant.ids.len() {
            return Err(octant_error(o, "entry arrays of different lengths"));
        }
        if octant.own != octant.entries_union() {
            return Err(octant_error(o, "kept entry bounds are not their union"));
        }
        if u32::from(octant.child_mask) >> (1 << AXES) != 0 {
            return Err(octant_error(
                o,
                "a child on an axis the tree does not split",
            ));
        }
        let count = octant.children().len();
        if octant.children[count..].iter().any(|&c| c != NONE) {
            return Err(octant_error(o, "child run not compact"));
        }
        let mut bounds = octant.entries_union();
        for index in 0..8u8 {
            let Some(c) = octant.child(index) else {
                continue;
            };
            self.check_link(o, index, c)?;
            bounds = bounds.union(&self.arena.get(c).tight);
        }
        let chain = octant.ids.is_empty() && octant.children().len() == 1;
        if chain && o != self.root && !octant.anchored {
            return Err(octant_error(
                o,
                "holds nothing but one child: not spliced out",
            ));
        }
        // Moves inside the node bounds leave them as they were (`refit::OWN_MARGIN`), so
        // they hold what the octant holds, up to the margin a refit gives them.
        if !octant.tight.contains_aabb(&bounds) {
            return Err(octant_error(o, "node bounds miss what it holds"));
        }
        Ok(())
    }

    /// The link from `o` to its child `c` at octant index `index`: the child's parent link
    /// and index, a deeper level, and the cell `o`'s cell gives at that level on the way to
    /// the child (an anchored old root: its own cell, one level below a grown root).
    fn check_link(&self, o: u32, index: u8, c: u32) -> Result<(), OctreeValidationError> {
        let (octant, child) = (self.arena.get(o), self.arena.get(c));
        if child.parent != o || child.index_in_parent != index || child.level <= octant.level {
            return Err(octant_error(c, "links or level disagree with its parent"));
        }
        let steps = i32::from(child.level - octant.level);
        if child.half != octant.half / 2f32.powi(steps) {
            return Err(octant_error(c, "cell size is not its level's"));
        }
        if child.anchored {
            if octant.level >= 0 || steps != 1 {
                return Err(octant_error(
                    c,
                    "anchored below the world cube or a level apart",
                ));
            }
            return Ok(());
        }
        if child_index::<AXES>(octant.center, child.center) != index {
            return Err(octant_error(c, "not in its parent's octant of its index"));
        }
        let (mut center, mut half) = self.child_cell(o, index);
        for _ in 1..steps {
            center = child_center::<AXES>(center, half, child_index::<AXES>(center, child.center));
            half *= 0.5;
        }
        if (center, half) != (child.center, child.half) {
            return Err(octant_error(c, "cell is not the one its parent's gives"));
        }
        Ok(())
    }

    fn check_entry(&self, o: u32, position: usize) -> Result<(), OctreeValidationError> {
        let error = |problem| OctreeValidationError::Entry {
            octant: o,
            position,
            problem,
        };
        let octant = self.arena.get(o);
        let slot = self.slots.slots.get(octant.entries[position].slot as usize);
        if !slot.is_some_and(|s| s.octant == o && s.position as usize == position) {
            return Err(error("its handle slot does not point back at it"));
        }
        let b = &octant.entries[position].bounds;
        if !b.is_finite() {
            return Err(error("a NaN, infinite or inverted box"));
        }
        let root_exception = o == self.root && !self.root_can_grow();
        if !self.fits(o, b) && !root_exception {
            return Err(error("outside its octant's loose cell"));
        }
        if self.wants_deeper(o, b) {
            return Err(error("small enough for a child's cell, kept too shallow"));
        }
        Ok(())
    }
}
