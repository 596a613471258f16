//! The arena the dynamic tree lives in: fixed-size nodes addressed by index, and a free list.
//!
//! Leaves never move in the arena, so a leaf's index is a handle the caller can keep for the
//! entity's lifetime; tree edits (insertion, removal, rotations, rebuilds) rewire parent and
//! child links instead of moving nodes. Freed slots carry a generation counter so a handle kept
//! past `remove` is detected rather than silently naming whatever reused the slot.

use crate::Aabb;

/// "No node": the parent of the root, the children of a leaf, the end of the free list.
pub(crate) const NULL: u32 = u32::MAX;

/// The height stored in free slots; no live node is that tall.
pub(crate) const FREE: u32 = u32::MAX;

/// Set on internal nodes while a refit pass has them queued (so each is queued once).
pub(crate) const FLAG_QUEUED: u32 = 1;
/// Set on leaves placed by a rebuild, so the leaves the rebuild did not know are found.
pub(crate) const FLAG_PLACED: u32 = 4;

/// The low bit of [`Node::dirty_mark`]: the leaf's new fat box lies clear of the old one (a
/// teleport, a respawn), and the refit decides whether to reinsert it.
pub(crate) const MARK_JUMPED: u32 = 1;

/// Arena slots are capped below 2^31: the static/dynamic pair tags static node ids with the
/// top bit, so dynamic ids must leave it clear.
pub(crate) const MAX_NODES: usize = (1 << 31) - 1;

/// One node: 64 bytes aligned to 64, one cache line, so a traversal step touches one line.
/// (With the 16-byte alignment its `Aabb` alone asks for, three nodes in four straddled two
/// lines, and prefetching a node's first line left its links and height to miss.)
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(crate) struct Node {
    /// The node's box: for a leaf the *fat* box (tight box plus margin), for an internal node
    /// the union of its children's boxes.
    pub aabb: Aabb,
    /// The parent, [`NULL`] for the root; for a free slot, the next free slot.
    pub parent: u32,
    /// The two children; `[NULL, NULL]` for a leaf.
    pub children: [u32; 2],
    /// The caller's primitive id (leaves only).
    pub id: u32,
    /// 0 for a leaf, 1 + max(children) for an internal node, [`FREE`] for a free slot.
    pub height: u32,
    /// Bumped each time the slot is freed; a handle is live only while it matches.
    pub generation: u32,
    /// `FLAG_*` bits.
    pub flags: u32,
    /// Whether the leaf waits in the dirty list: `refit epoch << 1 | jumped` while it does
    /// (the tree's current epoch), 0 or an older epoch's mark otherwise.
    ///
    /// An epoch rather than a flag, because a flag must be cleared on every leaf the refit
    /// reaches: after a mass update the whole-tree refit would write back a line per leaf it
    /// only needs to read. Bumping the tree's epoch clears every mark at once.
    pub dirty_mark: u32,
}

const _: () = assert!(core::mem::size_of::<Node>() == 64 && core::mem::align_of::<Node>() == 64);

impl Node {
    /// True for leaves (free slots are not leaves: their height is [`FREE`]).
    #[inline]
    pub fn is_leaf(&self) -> bool {
        self.height == 0
    }

    /// True for internal nodes.
    #[inline]
    pub fn is_internal(&self) -> bool {
        self.height != 0 && self.height != FREE
    }

    /// True for free slots.
    #[inline]
    pub fn is_free(&self) -> bool {
        self.height == FREE
    }
}

/// Nodes plus the free list threaded through the free ones' `parent` fields.
#[derive(Clone, Debug)]
pub(crate) struct Arena {
    pub nodes: Vec<Node>,
    free_head: u32,
    free_count: usize,
}

impl Default for Arena {
    fn default() -> Self {
        Self {
            nodes: Vec::new(),
            free_head: NULL,
            free_count: 0,
        }
    }
}

impl Arena {
    /// Takes a slot off the free list (or grows the arena) and resets it to a lone leaf with an
    /// empty box. Returns `None` past [`MAX_NODES`].
    pub fn alloc(&mut self) -> Option<u32> {
        let index = if self.free_head != NULL {
            let i = self.free_head;
            self.free_head = self.nodes[i as usize].parent;
            self.free_count -= 1;
            i
        } else {
            if self.nodes.len() >= MAX_NODES {
                return None;
            }
            self.nodes.push(Node {
                aabb: Aabb::EMPTY,
                parent: NULL,
                children: [NULL; 2],
                id: 0,
                height: FREE,
                generation: 0,
                flags: 0,
                dirty_mark: 0,
            });
            (self.nodes.len() - 1) as u32
        };
        let n = &mut self.nodes[index as usize];
        n.aabb = Aabb::EMPTY;
        n.parent = NULL;
        n.children = [NULL; 2];
        n.id = 0;
        n.height = 0;
        n.flags = 0;
        n.dirty_mark = 0;
        Some(index)
    }

    /// Returns a slot to the free list, invalidating handles to it.
    pub fn free(&mut self, index: u32) {
        let n = &mut self.nodes[index as usize];
        debug_assert!(!n.is_free(), "double free of node {index}");
        n.generation = n.generation.wrapping_add(1);
        n.height = FREE;
        n.children = [NULL; 2];
        n.flags = 0;
        n.dirty_mark = 0;
        n.aabb = Aabb::EMPTY;
        n.parent = self.free_head;
        self.free_head = index;
        self.free_count += 1;
    }

    /// Slots in use.
    pub fn live(&self) -> usize {
        self.nodes.len() - self.free_count
    }

    /// The free list, in order (for the validator).
    pub fn free_list(&self) -> impl Iterator<Item = u32> + '_ {
        let mut i = self.free_head;
        core::iter::from_fn(move || {
            if i == NULL {
                return None;
            }
            let cur = i;
            i = self.nodes[cur as usize].parent;
            Some(cur)
        })
    }

    /// Number of free slots.
    pub fn free_count(&self) -> usize {
        self.free_count
    }
}

/// Prefetches node `i` of `nodes` if it exists ([`NULL`] and stale indices are skipped): the
/// arena's order is random after insertions, so walks that know their next nodes ask for them
/// early.
#[inline(always)]
pub(crate) fn prefetch_index(nodes: &[Node], i: u32) {
    if let Some(n) = nodes.get(i as usize) {
        crate::prefetch::prefetch_node(n);
    }
}
