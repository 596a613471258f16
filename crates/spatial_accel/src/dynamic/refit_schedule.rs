//! The whole-tree refit as a flat schedule: the tree's shape compiled once into arrays, then
//! replayed bottom-up every frame in which most leaves moved, for as long as the shape holds.
//!
//! A depth-first refit over the arena is a chain of dependent loads: each node's children are
//! known only once the node has arrived, and the arena's order is random after insertions, so
//! in a large tree every step waits a full memory latency, far longer than a line costs when
//! the loads are independent and prefetched (BENCHMARKS.md, Dynamic BVH). The schedule turns the refit into independent
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
//! - **In parallel** (cargo feature `rayon`): compilation also records where each
//!   breadth-first level starts. Entries of one level never depend on each other (their
//!   children are a level deeper), so a large level is cut into fixed chunks replayed on
//!   rayon's pool, deepest level first. The chunks are the same on one thread, and their
//!   area sums are added in chunk order either way, so both replays give the same bits.
//!
//! Any edit of links (insertion, removal, rotation, reinsertion, rebuild) invalidates the
//! schedule; the next whole-tree refit compiles it again. A frame whose motion only refits
//! (the common case for a crowd that keeps moving) replays it as is.

use super::node::{NULL, Node};
use crate::Aabb;
use crate::prefetch::prefetch_node;

/// Marks a child reference that names a leaf's arena slot rather than a schedule entry.
/// Arena slots stay below 2^31 ([`super::node::MAX_NODES`]), so the bit is free.
const LEAF_CHILD: u32 = 1 << 31;

/// How many entries ahead the replay asks for the nodes it will read and write. Why 40:
/// shorter distances leave part of each load's latency uncovered, longer ones are slower too,
/// and 40 is the fastest of those tried on the whole-tree refit benchmark (BENCHMARKS.md,
/// Dynamic BVH).
const PREFETCH_DISTANCE: usize = 40;

/// How many queue entries ahead compilation asks for nodes: its steps are short, so it must
/// look further ahead than the replay to cover a memory latency.
const COMPILE_PREFETCH_DISTANCE: usize = 48;

/// Entries per chunk of a level: each chunk is one task on the pool, and the unit the area
/// sum is added in.
const CHUNK: usize = 2048;

/// A level is replayed in parallel from this many chunks up (a level of one chunk has
/// nothing to share).
const PARALLEL_MIN_CHUNKS: usize = 2;

/// The compiled shape of a [`super::DynamicBvh`] and the scratch its replay uses.
#[derive(Debug, Default)]
pub(super) struct RefitSchedule {
    /// The tree's internal nodes in breadth-first order (arena indices).
    internal: Vec<u32>,
    /// For each entry of `internal`, its two children: an entry index, or a leaf's arena slot
    /// tagged with [`LEAF_CHILD`].
    children: Vec<[u32; 2]>,
    /// Where each breadth-first level starts in `internal` (the root's level first).
    levels: Vec<u32>,
    /// Whether `internal` and `children` describe the tree's current links.
    valid: bool,
    /// Compilation's queue: (arena index, parent entry, child slot).
    queue: Vec<(u32, u32, u8)>,
    /// Replay scratch, per entry: the box just computed. (Heights are not recomputed: they
    /// change only with links, and every edit of links keeps them exact.)
    boxes: Vec<Aabb>,
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
        self.levels.clear();
        self.queue.push((root, NULL, 0));
        let mut k = 0;
        // The queue holds whole levels one after another: the current level ends where the
        // queue ended when its first node was taken.
        let mut level_end = 0;
        while k < self.queue.len() {
            if k == level_end {
                self.levels.push(self.internal.len() as u32);
                level_end = self.queue.len();
            }
            // The queue names its nodes long before they are read: ask for the one a fixed
            // distance ahead. (Asking when a node is queued, a whole level ahead, would fetch
            // megabytes early at the wide levels, and the lines would be evicted before use.)
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

    /// Recomputes every internal node below `root` (an internal node) from its children
    /// (reading the leaves, never writing them), and appends the internal nodes, children before
    /// parents, to `order`. Compiles first if the shape changed since the last replay. With
    /// `parallel` (and the `rayon` feature), large levels run on rayon's pool; the result is
    /// the same bits either way. Returns the sum of the internal nodes' half areas.
    pub fn replay(
        &mut self,
        nodes: &mut [Node],
        root: u32,
        order: &mut Vec<u32>,
        parallel: bool,
    ) -> f64 {
        if !self.valid {
            self.compile(nodes, root);
        }
        let m = self.internal.len();
        self.boxes.resize(m, Aabb::EMPTY);
        let shared = SharedReplay {
            nodes: nodes.as_mut_ptr(),
            node_count: nodes.len(),
            boxes: self.boxes.as_mut_ptr(),
            internal: &self.internal,
            children: &self.children,
        };
        let mut internal_area = 0.0f64;
        for (level, &start) in self.levels.iter().enumerate().rev() {
            let end = self.levels.get(level + 1).map_or(m, |&e| e as usize);
            internal_area += shared.replay_level(start as usize..end, parallel);
        }
        order.reserve(m);
        order.extend(self.internal.iter().rev());
        internal_area
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.internal.capacity() * 4
            + self.children.capacity() * 8
            + self.queue.capacity() * 12
            + self.boxes.capacity() * core::mem::size_of::<Aabb>()
            + self.levels.capacity() * 4
    }
}

/// What one replay shares between the tasks of a level: raw pointers to the arena and the
/// scratch, because tasks write disjoint entries of both at once.
///
/// Why this is sound: within a level, entry `e` writes only `boxes[e]`, its own
/// arena node, and reads only its leaf children (a leaf has one parent) and
/// entries of the level below, which no task of this level writes. Levels run one after
/// another.
struct SharedReplay<'a> {
    nodes: *mut Node,
    node_count: usize,
    boxes: *mut Aabb,
    internal: &'a [u32],
    children: &'a [[u32; 2]],
}

// SAFETY: see the type's documentation: tasks touch disjoint elements.
unsafe impl Sync for SharedReplay<'_> {}

impl SharedReplay<'_> {
    /// Replays the entries in `range` (one level), in fixed chunks; returns their half-area
    /// sum, added chunk by chunk in order.
    fn replay_level(&self, range: core::ops::Range<usize>, parallel: bool) -> f64 {
        let chunk = |k: usize| {
            let start = range.start + k * CHUNK;
            start..(start + CHUNK).min(range.end)
        };
        let chunks = range.len().div_ceil(CHUNK);
        #[cfg(feature = "rayon")]
        if parallel && chunks >= PARALLEL_MIN_CHUNKS {
            use rayon::prelude::*;
            let mut sums = vec![0.0f64; chunks];
            sums.par_iter_mut()
                .enumerate()
                .for_each(|(k, sum)| *sum = self.replay_chunk(chunk(k)));
            return sums.iter().sum();
        }
        #[cfg(not(feature = "rayon"))]
        let _ = (parallel, PARALLEL_MIN_CHUNKS);
        (0..chunks).map(|k| self.replay_chunk(chunk(k))).sum()
    }

    /// Replays one chunk of a level, last entry first; returns its half-area sum. Touches only
    /// the arena nodes of the chunk's own entries and their leaf children.
    fn replay_chunk(&self, range: core::ops::Range<usize>) -> f64 {
        let node = |i: u32| {
            assert!((i as usize) < self.node_count);
            // SAFETY: in bounds (checked above); disjoint per entry (see the type's docs).
            unsafe { &mut *self.nodes.add(i as usize) }
        };
        let mut area = 0.0f64;
        for e in range.clone().rev() {
            // Only entries of this chunk are prefetched: a node of another chunk may be
            // written by another task right now, and no reference to it may exist here.
            if let Some(ahead) = e
                .checked_sub(PREFETCH_DISTANCE)
                .filter(|a| *a >= range.start)
            {
                prefetch_node(node(self.internal[ahead]));
                for c in self.children[ahead] {
                    if c & LEAF_CHILD != 0 {
                        prefetch_node(node(c & !LEAF_CHILD));
                    }
                }
            }
            let child = |c: u32| -> Aabb {
                if c & LEAF_CHILD != 0 {
                    node(c & !LEAF_CHILD).aabb
                } else {
                    let c = c as usize;
                    assert!(c < self.internal.len());
                    // SAFETY: in bounds; a deeper level's entry, written before this level.
                    unsafe { *self.boxes.add(c) }
                }
            };
            let [a, b] = self.children[e];
            let aabb = child(a).union(&child(b));
            // SAFETY: `e` is in bounds (it indexes `children`) and only this entry writes it.
            unsafe { *self.boxes.add(e) = aabb };
            node(self.internal[e]).aabb = aabb;
            area += aabb.half_area_f64();
        }
        area
    }
}

#[cfg(all(test, feature = "rayon"))]
mod tests {
    use super::CHUNK;
    use crate::Aabb;
    use crate::dynamic::{DynamicBvh, DynamicBvhConfig};
    use glam::Vec3A;

    /// The parallel whole-tree refit writes the same bits as the one-thread refit: every
    /// node's box and height, and the internal-area sum the quality monitor reads.
    #[test]
    fn parallel_replay_matches_one_thread_bit_for_bit() {
        let mut next = crate::test_floats(0x9e37_79b9_7f4a_7c15);
        // Enough boxes that some level is wide enough to be split across threads whatever
        // the random draws (with 40,000 the widest level came out near 4,096 nodes, the
        // threshold, and on which side depended on the generator).
        let boxes: Vec<Aabb> = (0..60_000)
            .map(|_| {
                let c = Vec3A::new(next(), next(), next()) * 400.0;
                Aabb::from_center_half_extents(c, Vec3A::splat(0.5 + next()))
            })
            .collect();
        let steps: Vec<Vec3A> = (0..boxes.len())
            .map(|_| Vec3A::new(next(), next(), next()) * 4.0 - 2.0)
            .collect();
        let trees = [true, false].map(|parallel_refit| {
            let mut t = DynamicBvh::with_config(DynamicBvhConfig {
                parallel_refit,
                // Rotations and the optimiser are left out: only the refit may differ.
                rotations: false,
                ..DynamicBvhConfig::default()
            });
            let handles: Vec<_> = boxes
                .iter()
                .enumerate()
                .map(|(i, b)| t.insert(i as u32, *b).unwrap())
                .collect();
            t.refit();
            for round in 0..3 {
                for ((h, b), step) in handles.iter().zip(&boxes).zip(&steps) {
                    let offset = *step * (round + 1) as f32;
                    let moved = Aabb::new(b.min + offset, b.max + offset);
                    t.update(*h, moved).unwrap();
                }
                assert!(t.refit() > 0);
            }
            t.validate().unwrap();
            t
        });
        let [parallel, serial] = &trees;
        let widest = parallel
            .schedule
            .levels
            .windows(2)
            .map(|w| (w[1] - w[0]) as usize)
            .max()
            .unwrap();
        assert!(
            widest >= 2 * CHUNK,
            "no level wide enough to run in parallel"
        );
        assert_eq!(parallel.arena.nodes.len(), serial.arena.nodes.len());
        for (i, (a, b)) in parallel
            .arena
            .nodes
            .iter()
            .zip(&serial.arena.nodes)
            .enumerate()
        {
            assert_eq!(
                (a.aabb.min.to_array(), a.aabb.max.to_array(), a.height),
                (b.aabb.min.to_array(), b.aabb.max.to_array(), b.height),
                "node {i}"
            );
        }
        assert_eq!(
            parallel.internal_area.to_bits(),
            serial.internal_area.to_bits()
        );
    }
}
