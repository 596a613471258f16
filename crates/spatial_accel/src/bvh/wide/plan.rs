//! Which binary nodes become wide nodes: the plan the collapse writes out.
//!
//! The greedy collapse (open the largest interior child until the node is full, Wald et al.
//! 2008) fills the top of the tree and starves its bottom: a binary tree of single-primitive
//! leaves is about 17 levels deep at 10^5 primitives, 17 is not a multiple of 3, and the last
//! wide level, which holds most of the nodes, gets two binary levels: four children in eight
//! slots. The greedy plan then makes about twice as many nodes as full ones need, and rays
//! fetch about twice as many from memory as they have to.
//!
//! Here the plan is the one of least SAH cost instead (the dynamic programme of Ylitie et al.
//! 2017, "Efficient incoherent ray traversal on GPUs through compressed wide BVHs", section
//! 3.1, without its leaf merging: the binary tree's leaves stay as they are). The leaves'
//! costs do not depend on the plan (each is tested when its own box is hit), so the cost to
//! minimise is the sum of the surface areas of the binary nodes made wide nodes: the expected
//! number of wide nodes a random ray visits.

use crate::bvh::BvhNode;

/// A slot of a wide node being planned: the binary node it takes, and (for an interior one)
/// the wide node made from it.
#[derive(Clone, Copy)]
pub(super) struct PlannedSlot {
    pub binary: u32,
    pub wide: u32,
}

/// For each wide node (node 0 the root, children after their parent), its slots in order.
pub(super) fn plan_slots<const N: usize>(binary: &[BvhNode]) -> Vec<[Option<PlannedSlot>; N]> {
    const {
        assert!(
            N <= MAX_WIDTH,
            "the plan packs its choices for at most 16 slots"
        )
    };
    let choices = least_cost_choices::<N>(binary);
    let mut stack = Vec::new();
    plan_from(binary, |root, covered| {
        cover_children(binary, &choices, root, N, &mut stack, covered);
    })
}

/// Lays out the wide nodes of a plan, given which binary nodes cover the children of each
/// binary node made a wide node (`cover` appends them, at most `N`, left to right).
fn plan_from<const N: usize>(
    binary: &[BvhNode],
    mut cover: impl FnMut(usize, &mut Vec<usize>),
) -> Vec<[Option<PlannedSlot>; N]> {
    let mut plan: Vec<[Option<PlannedSlot>; N]> = Vec::with_capacity(binary.len() / N + 1);
    plan.push([None; N]);
    // (wide node to fill, binary node it is made from)
    let mut work = vec![(0usize, 0usize)];
    let mut covered = Vec::with_capacity(N);
    while let Some((wide, root)) = work.pop() {
        covered.clear();
        if binary[root].is_leaf() {
            // Only a one-leaf tree has a leaf root: it becomes a node with one leaf slot.
            covered.push(root);
        } else {
            cover(root, &mut covered);
        }
        for (i, &s) in covered.iter().enumerate() {
            let mut planned = PlannedSlot {
                binary: s as u32,
                wide: 0,
            };
            if !binary[s].is_leaf() {
                planned.wide = plan.len() as u32;
                work.push((plan.len(), s));
                plan.push([None; N]);
            }
            plan[wide][i] = Some(planned);
        }
    }
    plan
}

/// The widest node the packed [`Choice`] describes.
const MAX_WIDTH: usize = 16;

/// For `k` slots, the left child's possible shares `1..k`, the most even first.
const EVEN_FIRST: [[u8; MAX_WIDTH - 1]; MAX_WIDTH + 1] = {
    let mut table = [[0u8; MAX_WIDTH - 1]; MAX_WIDTH + 1];
    let mut k = 2;
    while k <= MAX_WIDTH {
        let mut n = 0;
        let mut distance = 0;
        while n < k - 1 {
            let mut i = 1;
            while i < k {
                if (2 * i).abs_diff(k) == distance {
                    table[k][n] = i as u8;
                    n += 1;
                }
                i += 1;
            }
            distance += 1;
        }
        k += 1;
    }
    table
};

/// What the least-cost plan does with an interior binary node given `k` slots, for each `k`
/// in `2..=16`: whether it is opened (its children spread over the `k` slots) or made a wide
/// node of its own (one slot), and, opened, how many of the slots its left child takes.
///
/// Packed in one word: the left share less one in 4 bits for each `k` in `3..=16` (with two
/// slots it is always one), and the least `k` that opens the node in the top 5 bits. One
/// threshold is enough because a subtree spread over more slots never costs more (each split
/// of `k` slots is still there with `k + 1`, one child given a slot more), so once opening
/// beats a node of its own it does for every larger `k`. Why so tight: the choices of every
/// binary node are kept until the plan is laid out, two million of them at a million
/// primitives.
#[derive(Clone, Copy)]
struct Choice(u64);

impl Default for Choice {
    fn default() -> Self {
        Self(Self::NEVER_OPENS << Self::THRESHOLD_SHIFT)
    }
}

impl Choice {
    const THRESHOLD_SHIFT: u32 = 59;
    /// A threshold no `k` reaches.
    const NEVER_OPENS: u64 = 31;

    #[inline]
    fn opens(self, k: usize) -> bool {
        k >= 2 && k as u64 >= self.0 >> Self::THRESHOLD_SHIFT
    }

    #[inline]
    fn left_share(self, k: usize) -> usize {
        if k <= 2 {
            return 1;
        }
        ((self.0 >> (4 * (k - 3))) & 15) as usize + 1
    }

    /// Records the choice for `k` slots; called for `k` in increasing order.
    #[inline]
    fn set(&mut self, k: usize, left_share: usize, opens: bool) {
        if k > 2 {
            self.0 |= ((left_share - 1) as u64) << (4 * (k - 3));
        }
        if opens && !self.opens(k) {
            let kept = self.0 & ((1 << Self::THRESHOLD_SHIFT) - 1);
            self.0 = kept | (k as u64) << Self::THRESHOLD_SHIFT;
        }
    }
}

/// Runs the dynamic programme bottom-up and returns each interior node's [`Choice`].
///
/// A subtree's costs are `least[k - 1]`: the least total area of the wide nodes needed to
/// cover it with at most `k` slots (0 for a leaf: one slot, no node). They are needed only
/// until its parent's turn, so they live on a stack in a post-order walk, not in an array by
/// node: at a million primitives such an array would be 64 MB, whose page faults alone would
/// cost more than the greedy collapse.
///
/// A subtree with `s <= N` leaves costs nothing from `k = s` on, so the splits tried are capped
/// by the children's leaf counts: most nodes of a tree sit near its leaves and have few, and
/// the programme then costs a few operations for them instead of the `N(N - 1) / 2` of full
/// splits (28 for eight slots).
fn least_cost_choices<const N: usize>(binary: &[BvhNode]) -> Vec<Choice> {
    let mut choices = vec![Choice::default(); binary.len()];
    if binary.is_empty() {
        return choices;
    }
    // (costs, leaf slots capped at N + 1) of the subtrees whose parents are still to come.
    let mut done: Vec<([f32; N], usize)> = Vec::new();
    // (node, whether its children are done)
    let mut walk = vec![(0usize, false)];
    while let Some((b, children_done)) = walk.pop() {
        let node = &binary[b];
        if node.is_leaf() {
            done.push(([0.0; N], 1));
            continue;
        }
        if !children_done {
            walk.push((b, true));
            walk.push((node.first as usize + 1, false));
            walk.push((node.first as usize, false));
            continue;
        }
        // The left child was walked first, so its result lies under the right one's.
        let (right, sr) = done.pop().expect("the right child's costs");
        let (left, sl) = done.pop().expect("the left child's costs");
        let mut split = [f32::INFINITY; MAX_WIDTH + 1];
        let mut share = [1u8; MAX_WIDTH + 1];
        for k in 2..=N {
            // Shares past a child's leaf count cost what that count costs: left out.
            let lo = k.saturating_sub(sr).max(1);
            let hi = (k - 1).min(sl);
            let (mut best, mut best_share) = (split[k - 1], share[k - 1]);
            if lo <= hi {
                best = f32::INFINITY;
                // Tried most even first, and kept only if strictly cheaper: of the splits of
                // least cost, the most even wins. Why: boxes of equal areas (a crowd of
                // identical entities, zero-area points) tie everywhere, and taking the first
                // tie would give the left child one slot at every step: wide nodes that each
                // split off half of their primitives, a tree as deep as the binary one.
                for &i in &EVEN_FIRST[k][..k - 1] {
                    let i = i as usize;
                    let c = if (lo..=hi).contains(&i) {
                        left[i - 1] + right[k - i - 1]
                    } else {
                        f32::INFINITY
                    };
                    let cheaper = c < best;
                    best = if cheaper { c } else { best };
                    best_share = if cheaper { i as u8 } else { best_share };
                }
            }
            // (Otherwise more slots than leaves: every leaf has a slot already.)
            split[k] = best;
            share[k] = best_share;
        }
        // Made a wide node, the subtree takes one slot, costs its own area, and spreads its
        // children over the node's N slots.
        let as_node = node.aabb().half_area() + split[N];
        let mut costs = [as_node; N];
        let mut choice = Choice::default();
        for k in 2..=N {
            // `<=`: on a tie (zero-area boxes) opening the node saves a node. `split` never
            // grows with `k`, so this holds from some `k` on (what `Choice` packs).
            let opens = split[k] <= as_node;
            debug_assert!(
                !choice.opens(k - 1) || opens,
                "opening pays for every larger k"
            );
            if opens {
                costs[k - 1] = split[k];
            }
            choice.set(k, share[k] as usize, opens);
        }
        choices[b] = choice;
        done.push((costs, (sl + sr).min(N + 1)));
    }
    choices
}

/// Appends the binary nodes that cover the children of interior node `root` with at most
/// `slots` slots, as the least-cost plan chose, left to right (so a node's leaves keep the
/// primitive order).
fn cover_children(
    binary: &[BvhNode],
    choices: &[Choice],
    root: usize,
    slots: usize,
    work: &mut Vec<(usize, usize, bool)>,
    out: &mut Vec<usize>,
) {
    // (binary node, slots it may take, whether it is opened rather than taking one slot)
    work.push((root, slots, true));
    while let Some((b, k, opened)) = work.pop() {
        if !opened {
            out.push(b);
            continue;
        }
        let first = binary[b].first as usize;
        let i = choices[b].left_share(k);
        // Right pushed first: the left child's slots come out first.
        for (child, share) in [(first + 1, k - i), (first, i)] {
            let opens = !binary[child].is_leaf() && choices[child].opens(share);
            work.push((child, share, opens));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{PlannedSlot, plan_from, plan_slots};
    use crate::bvh::wide::Bvh8;
    use crate::bvh::{BuildConfig, Bvh, BvhNode, SplitStrategy};
    use crate::{Aabb, SahCosts};
    use glam::Vec3A;

    /// The greedy collapse (open the interior slot of largest area until the node is full):
    /// a feasible plan, so the least-cost one must never cost more.
    fn plan_slots_greedy<const N: usize>(binary: &[BvhNode]) -> Vec<[Option<PlannedSlot>; N]> {
        let area = |s: usize| binary[s].aabb().half_area();
        plan_from(binary, |root, slots| {
            slots.extend([binary[root].first as usize, binary[root].first as usize + 1]);
            while slots.len() < N {
                let Some(open) = (0..slots.len())
                    .filter(|&i| !binary[slots[i]].is_leaf())
                    .max_by(|&a, &b| area(slots[a]).total_cmp(&area(slots[b])))
                else {
                    break;
                };
                let first = binary[slots[open]].first as usize;
                slots[open] = first;
                slots.push(first + 1);
            }
        })
    }

    /// Total half area of the binary nodes a plan makes wide nodes (the root among them);
    /// also checks that every binary leaf has exactly one slot and no node overflows.
    fn plan_cost<const N: usize>(binary: &[BvhNode], plan: &[[Option<PlannedSlot>; N]]) -> f64 {
        let mut cost = f64::from(binary[0].aabb().half_area());
        let mut leaves = vec![0u32; binary.len()];
        for node in plan {
            assert!(node[0].is_some(), "a wide node has at least one slot");
            for slot in node.iter().flatten() {
                let b = slot.binary as usize;
                if binary[b].is_leaf() {
                    leaves[b] += 1;
                } else {
                    cost += f64::from(binary[b].aabb().half_area());
                }
            }
        }
        for (b, node) in binary.iter().enumerate() {
            let expected = u32::from(node.is_leaf() && (binary.len() == 1 || b != 0));
            assert_eq!(leaves[b], expected, "binary leaf {b} has one slot");
        }
        cost
    }

    /// Floats in `[0, 1)` from a linear congruential generator: fixed scenes for every run.
    fn unit_floats(seed: u32) -> impl FnMut() -> f32 {
        let mut state = seed;
        move || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32
        }
    }

    fn scenes() -> Vec<(&'static str, Vec<Aabb>)> {
        let mut next = unit_floats(0x2545_f491);
        let mut scenes = Vec::new();
        for n in [1usize, 2, 3, 9, 64, 100, 1000, 3000] {
            let uniform = (0..n)
                .map(|_| {
                    let c = Vec3A::new(next(), next(), next()) * 100.0;
                    Aabb::from_center_half_extents(c, Vec3A::splat(0.1 + next()))
                })
                .collect();
            scenes.push(("uniform", uniform));
            let clustered = (0..n)
                .map(|i| {
                    let centre = Vec3A::splat((i % 5) as f32 * 40.0);
                    let c = centre + Vec3A::new(next(), next(), next());
                    Aabb::from_center_half_extents(c, Vec3A::splat(0.01 + next() * 3.0))
                })
                .collect();
            scenes.push(("clustered", clustered));
            scenes.push(("identical", vec![Aabb::new(Vec3A::ZERO, Vec3A::ONE); n]));
            scenes.push(("points", vec![Aabb::new(Vec3A::ONE, Vec3A::ONE); n]));
        }
        scenes
    }

    fn configs() -> [BuildConfig; 3] {
        [
            BuildConfig {
                max_leaf_size: 1,
                ..BuildConfig::default()
            },
            BuildConfig::default(),
            BuildConfig {
                split: SplitStrategy::PLOC_FASTEST,
                max_leaf_size: 4,
                sah: SahCosts {
                    traversal: 1.0,
                    intersection: 4.0,
                },
                ..BuildConfig::default()
            },
        ]
    }

    /// The plan is the least-cost one: on every scene and build it costs no more than the
    /// greedy plan (to rounding).
    #[test]
    fn least_cost_plan_never_costs_more_than_the_greedy_one() {
        fn check<const N: usize>(name: &str, binary: &[BvhNode]) {
            let least = plan_cost::<N>(binary, &plan_slots::<N>(binary));
            let greedy = plan_cost::<N>(binary, &plan_slots_greedy::<N>(binary));
            assert!(
                least <= greedy * (1.0 + 1e-6) + 1e-9,
                "{name}, {N} wide: least-cost plan {least} against greedy {greedy}"
            );
        }
        for (name, boxes) in scenes() {
            for config in configs() {
                let bvh = Bvh::build(&boxes, &config);
                if !bvh.nodes.is_empty() {
                    check::<4>(name, &bvh.nodes);
                    check::<8>(name, &bvh.nodes);
                    check::<16>(name, &bvh.nodes);
                }
            }
        }
    }

    /// On the plugin's entity trees (PLOC, leaves of one entity) the plan makes far fewer
    /// nodes than the greedy one, full ones where the binary tree allows (a perfect binary
    /// tree of 2^12 leaves), and equal boxes (which tie every cost) still give a tree of
    /// logarithmic depth, not one as deep as the binary tree.
    #[test]
    fn nodes_are_fuller_and_ties_stay_shallow() {
        let grid: Vec<Aabb> = (0..4096)
            .map(|i| {
                let c = Vec3A::new((i % 16) as f32, (i / 16 % 16) as f32, (i / 256) as f32);
                Aabb::from_center_half_extents(c * 2.0, Vec3A::splat(0.5))
            })
            .collect();
        // As on the picking bench: one entity per 64 cubic units.
        let mut next = unit_floats(7);
        let half = (20_000.0f32 * 64.0).cbrt() / 2.0;
        let entities: Vec<Aabb> = (0..20_000)
            .map(|_| {
                let c = (Vec3A::new(next(), next(), next()) * 2.0 - 1.0) * half;
                Aabb::from_center_half_extents(c, Vec3A::splat(1.5))
            })
            .collect();
        let identical = vec![Aabb::new(Vec3A::ZERO, Vec3A::ONE); 20_000];
        let points = vec![Aabb::new(Vec3A::ONE, Vec3A::ONE); 20_000];
        let single = BuildConfig {
            max_leaf_size: 1,
            ..BuildConfig::default()
        };
        let entity_tree = configs()[2];
        // (scene, build, least children per node, most nodes against the greedy plan's)
        let scenes = [
            ("grid", grid, single, 7.0, 1.0),
            ("entities", entities, entity_tree, 5.0, 0.9),
            ("identical", identical, single, 5.0, 1.0),
            ("points", points, single, 5.0, 1.0),
        ];
        for (name, boxes, config, least_per_node, most_against_greedy) in scenes {
            let bvh = Bvh::build(&boxes, &config);
            let greedy_nodes = plan_slots_greedy::<8>(&bvh.nodes).len();
            let wide = Bvh8::from_bvh(&bvh);
            wide.validate(&boxes).unwrap();
            let nodes = wide.nodes.len();
            assert!(
                nodes as f64 <= most_against_greedy * greedy_nodes as f64,
                "{name}: {nodes} nodes against the greedy plan's {greedy_nodes}"
            );
            let leaf_slots: usize = wide
                .nodes
                .iter()
                .map(|n| (0..8).filter(|&i| n.is_used(i) && n.is_leaf(i)).count())
                .sum();
            let per_node = (nodes - 1 + leaf_slots) as f64 / nodes as f64;
            assert!(
                per_node >= least_per_node,
                "{name}: {per_node:.2} children per node"
            );
            let mut depth = 0;
            let mut stack = vec![(0u32, 1)];
            while let Some((node, d)) = stack.pop() {
                depth = depth.max(d);
                let n = &wide.nodes[node as usize];
                for i in (0..8).filter(|&i| n.is_used(i) && !n.is_leaf(i)) {
                    stack.push((n.child[i], d + 1));
                }
            }
            // log8(20,000) is 4.8.
            assert!(depth <= 7, "{name}: {depth} levels");
        }
    }
}
