//! The whole-tree refit as a flat schedule: the tree's shape compiled once into arrays, then
//! replayed bottom-up every frame in which most leaves moved, for as long as the shape holds.
//!
//! A depth-first refit over the arena is a chain of dependent loads: each node's children are
//! known only once the node has arrived, and the arena's order is random after insertions, so
//! at 100k leaves every step waits a full memory latency (about 200 ns on the benchmark VM,
//! against 16 ns per line when the loads are independent and prefetched: the
//! `dynamic_timing` example measures both). The schedule turns the refit into independent
//! loads:
//!
//! - **Compiling** walks the tree breadth-first. The queue names every node long before it
//!   is read, so each is prefetched a fixed number of entries ahead and the reads overlap
//!   instead of forming a chain. It records the internal nodes in breadth-first order and,
//!   for each, where its two children are: another entry of the schedule, or a leaf's arena
//!   slot.
//! - **Replaying** runs the entries backwards, children before parents. An internal child's
//!   box comes from a dense scratch array written earlier in the same pass; only the leaves
//!   and the internal nodes' own boxes are scattered, and those are prefetched some entries
//!   ahead, being known from the schedule without reading the tree.
//!
//! Any edit of links (insertion, removal, rotation, reinsertion, rebuild) invalidates the
//! schedule; the next whole-tree refit compiles it again. A frame whose motion only refits
//! (the common case for a crowd that keeps moving) replays it as is.

use super::node::{FLAG_DIRTY, FLAG_JUMPED, NULL, Node};
use crate::Aabb;
use crate::prefetch::prefetch_node;

/// Marks a child reference that names a leaf's arena slot rather than a schedule entry.
/// Arena slots stay below 2^31 ([`super::node::MAX_NODES`]), so the bit is free.
const LEAF_CHILD: u32 = 1 << 31;

/// How many entries ahead the replay asks for the nodes it will read and write.
/// (Distances from 4 to 48 measured alike at 100k leaves: the replay is bound by memory
/// bandwidth once the loads overlap.)
const PREFETCH_DISTANCE: usize = 12;

/// How many queue entries ahead compilation asks for nodes: its steps are short, so it must
/// look further ahead than the replay to cover a memory latency (~200 ns on the VM).
const COMPILE_PREFETCH_DISTANCE: usize = 48;

/// The compiled shape of a [`super::DynamicBvh`] and the scratch its replay uses.
#[derive(Debug, Default)]
pub(super) struct RefitSchedule {
    /// The tree's internal nodes in breadth-first order (arena indices).
    internal: Vec<u32>,
    /// For each entry of `internal`, its two children: an entry index, or a leaf's arena slot
    /// tagged with [`LEAF_CHILD`].
    children: Vec<[u32; 2]>,
    /// Whether `internal` and `children` describe the tree's current links.
    valid: bool,
    /// Compilation's queue: (arena index, parent entry, child slot).
    queue: Vec<(u32, u32, u8)>,
    /// Replay scratch, per entry: the box and height just computed.
    boxes: Vec<Aabb>,
    heights: Vec<u32>,
}

impl RefitSchedule {
    /// Forgets the compiled shape: the tree's links changed.
    #[inline]
    pub fn invalidate(&mut self) {
        self.valid = false;
    }

    /// Whether a compiled shape is held (the validator checks it against the tree).
    pub fn is_valid(&self) -> bool {
        self.valid
    }

    /// The internal nodes and their children as compiled, for the validator: each child as
    /// `Ok(entry)` or `Err(leaf slot)`.
    pub fn entries(&self) -> impl Iterator<Item = (u32, [Result<u32, u32>; 2])> + '_ {
        self.internal.iter().zip(&self.children).map(|(&i, c)| {
            let decode = |r: u32| {
                if r & LEAF_CHILD != 0 {
                    Err(r & !LEAF_CHILD)
                } else {
                    Ok(r)
                }
            };
            (i, [decode(c[0]), decode(c[1])])
        })
    }

    /// Compiles the shape below `root`, an internal node.
    fn compile(&mut self, nodes: &[Node], root: u32) {
        self.internal.clear();
        self.children.clear();
        self.queue.clear();
        self.queue.push((root, NULL, 0));
        let mut k = 0;
        while k < self.queue.len() {
            // The queue names its nodes long before they are read: ask for the one a fixed
            // distance ahead. (Asking when a node is queued, a whole level ahead, fetched
            // megabytes early at the wide levels, and the lines were evicted before use.)
            if let Some(&(ahead, _, _)) = self.queue.get(k + COMPILE_PREFETCH_DISTANCE) {
                prefetch_node(&nodes[ahead as usize]);
            }
            let (i, parent, slot) = self.queue[k];
            k += 1;
            let n = &nodes[i as usize];
            let reference = if n.is_leaf() {
                i | LEAF_CHILD
            } else {
                let entry = self.internal.len() as u32;
                self.internal.push(i);
                if n.height == 1 {
                    // Both children are leaves (heights are exact between edits; the
                    // validator checks them): recorded without reading them, which spares
                    // compilation a scattered read for most leaves.
                    self.children.push(n.children.map(|c| c | LEAF_CHILD));
                } else {
                    self.children.push([NULL; 2]);
                    for (s, c) in n.children.into_iter().enumerate() {
                        self.queue.push((c, entry, s as u8));
                    }
                }
                entry
            };
            if parent != NULL {
                self.children[parent as usize][usize::from(slot)] = reference;
            }
        }
        self.valid = true;
    }

    /// Recomputes every internal node below `root` (an internal node) from its children,
    /// clears the leaves' dirty flags, and appends the internal nodes, children before
    /// parents, to `order`. Compiles first if the shape changed since the last replay.
    /// Returns the sum of the internal nodes' half areas.
    pub fn replay(&mut self, nodes: &mut [Node], root: u32, order: &mut Vec<u32>) -> f64 {
        if !self.valid {
            self.compile(nodes, root);
        }
        let m = self.internal.len();
        self.boxes.resize(m, Aabb::EMPTY);
        self.heights.resize(m, 0);
        let mut internal_area = 0.0f64;
        order.reserve(m);
        for e in (0..m).rev() {
            if let Some(ahead) = e.checked_sub(PREFETCH_DISTANCE) {
                prefetch_node(&nodes[self.internal[ahead] as usize]);
                for c in self.children[ahead] {
                    if c & LEAF_CHILD != 0 {
                        prefetch_node(&nodes[(c & !LEAF_CHILD) as usize]);
                    }
                }
            }
            let mut child = |c: u32| -> (Aabb, u32) {
                if c & LEAF_CHILD != 0 {
                    let leaf = &mut nodes[(c & !LEAF_CHILD) as usize];
                    if leaf.flags & (FLAG_DIRTY | FLAG_JUMPED) != 0 {
                        leaf.flags &= !(FLAG_DIRTY | FLAG_JUMPED);
                    }
                    (leaf.aabb, 0)
                } else {
                    (self.boxes[c as usize], self.heights[c as usize])
                }
            };
            let [a, b] = self.children[e];
            let (box_a, height_a) = child(a);
            let (box_b, height_b) = child(b);
            let aabb = box_a.union(&box_b);
            let height = 1 + height_a.max(height_b);
            self.boxes[e] = aabb;
            self.heights[e] = height;
            let i = self.internal[e];
            let n = &mut nodes[i as usize];
            n.aabb = aabb;
            n.height = height;
            internal_area += f64::from(aabb.half_area());
            order.push(i);
        }
        internal_area
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.internal.capacity() * 4
            + self.children.capacity() * 8
            + self.queue.capacity() * 12
            + self.boxes.capacity() * core::mem::size_of::<Aabb>()
            + self.heights.capacity() * 4
    }
}
