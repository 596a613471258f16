//! Refitting a wide tree in place after its primitives moved (skinned meshes, morphs, moving
//! entities): the whole tree, or only the paths above the primitives that moved.

use super::{WideBvh, WideLayout, used_slot_area};
use crate::Aabb;

/// No parent (the root).
const NO_PARENT: u32 = u32::MAX;

/// Bits of a packed (node, slot) reference taken by the slot (up to 16 slots).
const SLOT_BITS: u32 = 4;

/// Recomputes the slot boxes of node `n` named in `mask` (bit `s`: slot `s`; layouts that
/// cannot set slots alone get all of them): leaf slots from `bounds_at` (called with each
/// primitive's position in the leaf order), inner slots from their child node's slots, which
/// must be refitted already. With `AREA`, returns how much the recomputed slots' summed
/// surface area (half areas) grew; zero otherwise.
#[inline]
fn refit_node<const N: usize, const AREA: bool, L: WideLayout<N>>(
    nodes: &mut [L],
    n: usize,
    mask: u32,
    bounds_at: &mut impl FnMut(usize) -> Aabb,
) -> f64 {
    let mask = if L::SETS_SLOTS_ALONE {
        mask
    } else {
        (1 << N) - 1
    };
    let before = if AREA {
        used_slot_area(&nodes[n], mask)
    } else {
        0.0
    };
    let node = &nodes[n];
    let mut boxes = [Aabb::EMPTY; N];
    for (slot, b) in boxes.iter_mut().enumerate() {
        if mask & (1 << slot) == 0 || !node.is_used(slot) {
            continue;
        }
        *b = if node.is_leaf(slot) {
            let first = node.child(slot) as usize;
            (first..first + node.count(slot) as usize)
                .fold(Aabb::EMPTY, |acc, k| acc.union(&bounds_at(k)))
        } else {
            // The child's stored slots: for a quantized layout, the rounded-out boxes its
            // parent must enclose.
            nodes[node.child(slot) as usize].bounds()
        };
    }
    nodes[n].set_slot_boxes(mask, &boxes);
    // Read back, not taken from `boxes`: a quantized layout stores them rounded out.
    if AREA {
        used_slot_area(&nodes[n], mask) - before
    } else {
        0.0
    }
}

impl<const N: usize, L: WideLayout<N>> WideBvh<N, L> {
    /// Recomputes every slot box from new primitive boxes, keeping the topology.
    ///
    /// The collapse appends children after their parent, so one reverse sweep over the nodes
    /// sees every child before its parent: no recursion, no parent links, one pass, and a
    /// child's box is read back from its already refitted slots (no scratch array to allocate
    /// per refit). `primitive_bounds` is called exactly once per primitive, so it may also
    /// update the primitive. The tree's quality is that of the pose it was built in; rebuild
    /// when motion is large.
    pub fn refit(&mut self, mut primitive_bounds: impl FnMut(u32) -> Aabb) {
        let prims = core::mem::take(&mut self.primitive_indices);
        self.refit_at(|k| primitive_bounds(prims[k]));
        self.primitive_indices = prims;
    }

    /// [`refit`](Self::refit) with the boxes given by position in the leaf order (see
    /// [`primitive_indices`](Self::primitive_indices)) rather than by primitive id.
    pub fn refit_at(&mut self, mut bounds_at: impl FnMut(usize) -> Aabb) {
        for n in (0..self.nodes.len()).rev() {
            refit_node::<N, false, L>(&mut self.nodes, n, (1 << N) - 1, &mut bounds_at);
        }
        self.bounds = self.nodes.first().map_or(Aabb::EMPTY, L::bounds);
    }

    /// Recomputes only the slots above the primitives at the `moved` positions of the leaf
    /// order (see [`primitive_indices`](Self::primitive_indices)); `bounds_at` gives the box
    /// of the primitive at a position. `paths` must come from [`RefitPaths::of`] on this tree.
    ///
    /// Why: when a few of many primitives move (a handful of moving entities in a large
    /// world), a whole refit reads every primitive's box, most of them unchanged, at one
    /// cache miss each. This recomputes the one slot on each level of a moved primitive's
    /// path, shared slots once (children before parents), reading the child node just
    /// written, not its seven siblings (a little faster than recomputing every slot of the
    /// nodes on the paths when a few of many entities move: the misses along the paths
    /// dominate; BENCHMARKS.md, Picking).
    ///
    /// ```
    /// use spatial_accel::{Aabb, BuildConfig, Bvh, Ray, SpatialQuery};
    /// use spatial_accel::bvh::wide::{Bvh8, RefitPaths};
    /// use glam::Vec3A;
    /// let mut boxes: Vec<Aabb> = (0..1000)
    ///     .map(|i| Aabb::new(Vec3A::splat(i as f32), Vec3A::splat(i as f32 + 0.5)))
    ///     .collect();
    /// let mut wide = Bvh8::from_bvh(&Bvh::build(&boxes, &BuildConfig::default()));
    /// let mut paths = RefitPaths::of(&wide);
    /// boxes[7] = Aabb::new(Vec3A::splat(-10.0), Vec3A::splat(-9.0));
    /// let position = wide.primitive_indices().iter().position(|&p| p == 7).unwrap();
    /// let order = wide.primitive_indices().to_vec();
    /// wide.refit_moved(&mut paths, [position as u32], |k| boxes[order[k] as usize]);
    /// wide.validate(&boxes).unwrap();
    /// ```
    pub fn refit_moved(
        &mut self,
        paths: &mut RefitPaths,
        moved: impl IntoIterator<Item = u32>,
        bounds_at: impl FnMut(usize) -> Aabb,
    ) {
        self.refit_moved_paths::<false>(paths, moved, bounds_at);
    }

    /// [`refit_moved`](Self::refit_moved), returning how much the sum of every slot's
    /// surface area (half areas, not divided by the root's) grew: with that sum kept from
    /// the build, the tree's [`slot_area_cost`](Self::slot_area_cost) follows refits without
    /// a pass over every node.
    pub fn refit_moved_area_change(
        &mut self,
        paths: &mut RefitPaths,
        moved: impl IntoIterator<Item = u32>,
        bounds_at: impl FnMut(usize) -> Aabb,
    ) -> f64 {
        self.refit_moved_paths::<true>(paths, moved, bounds_at)
    }

    fn refit_moved_paths<const AREA: bool>(
        &mut self,
        paths: &mut RefitPaths,
        moved: impl IntoIterator<Item = u32>,
        mut bounds_at: impl FnMut(usize) -> Aabb,
    ) -> f64 {
        let mut growth = 0.0;
        for position in moved {
            let mut at = paths.slot_of_position[position as usize];
            while at != NO_PARENT && !paths.mark(at) {
                at = paths.parent_slot[(at >> SLOT_BITS) as usize];
            }
        }
        // Children come after their parents in the node array: highest marked node first.
        for w in (0..paths.marked.len()).rev() {
            let mut bits = core::mem::take(&mut paths.marked[w]);
            while bits != 0 {
                let b = 63 - bits.leading_zeros() as usize;
                bits &= !(1u64 << b);
                let n = w * 64 + b;
                let mask = core::mem::take(&mut paths.dirty_slots[n]);
                growth +=
                    refit_node::<N, AREA, L>(&mut self.nodes, n, u32::from(mask), &mut bounds_at);
            }
        }
        self.bounds = self.nodes.first().map_or(Aabb::EMPTY, L::bounds);
        growth
    }
}

/// The links [`WideBvh::refit_moved`] climbs: the slot holding each primitive position and
/// the parent slot of each node (packed as `node << 4 | slot`), with marks. Valid for the
/// tree it was made from until that tree is rebuilt (refits keep it valid).
#[derive(Clone, Debug, Default)]
pub struct RefitPaths {
    slot_of_position: Vec<u32>,
    parent_slot: Vec<u32>,
    /// Per node, the slots marked for recomputation (all clear between refits).
    dirty_slots: Vec<u16>,
    /// One bit per node: some of its slots are marked.
    marked: Vec<u64>,
}

impl RefitPaths {
    /// The links of `tree` (one pass over its nodes).
    pub fn of<const N: usize, L: WideLayout<N>>(tree: &WideBvh<N, L>) -> Self {
        const { assert!(N <= 1 << SLOT_BITS, "slots must fit in SLOT_BITS") };
        let mut paths = Self {
            slot_of_position: vec![NO_PARENT; tree.primitive_indices.len()],
            parent_slot: vec![NO_PARENT; tree.nodes.len()],
            dirty_slots: vec![0; tree.nodes.len()],
            marked: vec![0; tree.nodes.len().div_ceil(64)],
        };
        for (n, node) in tree.nodes.iter().enumerate() {
            for slot in (0..N).filter(|&s| node.is_used(s)) {
                let at = (n as u32) << SLOT_BITS | slot as u32;
                let child = node.child(slot) as usize;
                if node.is_leaf(slot) {
                    let end = child + node.count(slot) as usize;
                    paths.slot_of_position[child..end].fill(at);
                } else {
                    paths.parent_slot[child] = at;
                }
            }
        }
        paths
    }

    /// Marks the packed slot `at`; returns whether it was marked already.
    #[inline]
    fn mark(&mut self, at: u32) -> bool {
        let n = (at >> SLOT_BITS) as usize;
        let bit = 1u16 << (at & ((1 << SLOT_BITS) - 1));
        let was = self.dirty_slots[n] & bit != 0;
        if self.dirty_slots[n] == 0 {
            self.marked[n / 64] |= 1u64 << (n % 64);
        }
        self.dirty_slots[n] |= bit;
        was
    }

    /// Memory held, in bytes.
    pub fn memory_bytes(&self) -> usize {
        4 * (self.slot_of_position.len() + self.parent_slot.len())
            + 2 * self.dirty_slots.len()
            + 8 * self.marked.len()
    }
}

#[cfg(test)]
mod tests {
    use crate::bvh::wide::{Bvh8, RefitPaths};
    use crate::{Aabb, BuildConfig, Bvh};
    use glam::Vec3A;

    /// Boxes at random in a cube of side 100, each up to `scale` a side.
    fn random_boxes(seed: u64) -> impl FnMut(f32) -> Aabb {
        let mut next = crate::test_floats(seed);
        move |scale| {
            let c = Vec3A::new(next(), next(), next()) * 100.0;
            Aabb::new(c, c + Vec3A::new(next(), next(), next()) * scale + 0.1)
        }
    }

    /// Refitting the paths above the moved primitives leaves the same node boxes, bit for
    /// bit, as refitting everything; with few movers and with most of them, with leaves of
    /// one primitive and of several; the paths stay usable for the next refit.
    #[test]
    fn path_refit_equals_whole_refit() {
        let mut random_box = random_boxes(0x7e57_0f4e_5f17);
        for max_leaf_size in [1, 4] {
            let mut boxes: Vec<Aabb> = (0..3_000).map(|_| random_box(2.0)).collect();
            let config = BuildConfig {
                max_leaf_size,
                ..BuildConfig::default()
            };
            let mut by_paths = Bvh8::from_bvh(&Bvh::build(&boxes, &config));
            let mut whole = by_paths.clone();
            let mut paths = RefitPaths::of(&by_paths);
            let order = by_paths.primitive_indices().to_vec();
            for (round, movers) in [5usize, 1, 200, 2_900, 17].into_iter().enumerate() {
                let moved: Vec<u32> = (0..movers)
                    .map(|k| ((k * 7_919 + round * 31) % order.len()) as u32)
                    .collect();
                for &position in &moved {
                    boxes[order[position as usize] as usize] = random_box(5.0);
                }
                by_paths.refit_moved(&mut paths, moved.iter().copied(), |k| {
                    boxes[order[k] as usize]
                });
                whole.refit(|p| boxes[p as usize]);
                by_paths.validate(&boxes).unwrap();
                assert_eq!(by_paths.bounds(), whole.bounds(), "round {round}");
                for (a, b) in by_paths.nodes().iter().zip(whole.nodes()) {
                    for slot in 0..8 {
                        assert_eq!(a.child_aabb(slot), b.child_aabb(slot), "round {round}");
                    }
                }
            }
        }
    }

    /// The area change a path refit reports keeps the summed slot area equal to a fresh
    /// count over every node, for the float and the quantized layout (whose stored boxes are
    /// rounded out), refit after refit.
    #[test]
    fn tracked_slot_area_follows_path_refits() {
        let mut random_box = random_boxes(0x00a4_ea0f_5107);
        let mut boxes: Vec<Aabb> = (0..2_000).map(|_| random_box(2.0)).collect();
        let bvh = Bvh::build(&boxes, &BuildConfig::default());
        let mut float = Bvh8::from_bvh(&bvh);
        let mut quantized = crate::bvh::wide::QBvh8::from_bvh(&bvh);
        let (mut float_paths, mut quantized_paths) =
            (RefitPaths::of(&float), RefitPaths::of(&quantized));
        let (mut float_sum, mut quantized_sum) = (float.slot_area_sum(), quantized.slot_area_sum());
        let order = float.primitive_indices().to_vec();
        assert_eq!(order, quantized.primitive_indices());
        for round in 0..6usize {
            let moved: Vec<u32> = (0..40 * round + 1)
                .map(|k| ((k * 7_919 + round * 31) % order.len()) as u32)
                .collect();
            for &position in &moved {
                boxes[order[position as usize] as usize] = random_box(6.0);
            }
            let at = |k: usize| boxes[order[k] as usize];
            float_sum += float.refit_moved_area_change(&mut float_paths, moved.clone(), at);
            quantized_sum +=
                quantized.refit_moved_area_change(&mut quantized_paths, moved.clone(), at);
            for (tracked, fresh) in [
                (float_sum, float.slot_area_sum()),
                (quantized_sum, quantized.slot_area_sum()),
            ] {
                assert!(
                    (tracked - fresh).abs() <= 1e-9 * fresh,
                    "round {round}: tracked {tracked}, counted {fresh}"
                );
            }
        }
    }
}
