//! Ray traversal of wide nodes: all child boxes of a node tested at once, four lanes per
//! SIMD register.

use super::{WideBvh, WideLayout, WideNode};
use crate::prefetch::prefetch_node;
use crate::query::TraversalStack;
use crate::{Ray, SLAB_WIDENING};
use core::ops::ControlFlow;
use glam::Vec4;

/// A ray splatted across four lanes, with the slab-plane choice made once per ray: a ray's
/// direction signs decide which face of every box it enters by, so the per-node test needs no
/// per-lane select.
///
/// The choice is kept as plane indices, not signs. Node layouts store their six plane arrays
/// in one order (the three minimum axes, then the three maximum ones), so the test loads the
/// entry and exit planes straight from the node at those indices. Choosing between two loaded
/// values by the sign instead makes the compiler copy the node's planes to the stack at every
/// visit, which slows picking rays (BENCHMARKS.md, Picking).
pub struct RayLanes {
    pub(super) origin: [Vec4; 3],
    pub(super) inv_direction: [Vec4; 3],
    /// Per axis, the index (0..6) of the plane array the ray enters every box by: the
    /// minimum's (`axis`) for a non-negative direction, the maximum's (`3 + axis`) otherwise.
    pub(super) entry_plane: [usize; 3],
    /// Per axis, the index of the plane array the ray leaves every box by.
    pub(super) exit_plane: [usize; 3],
    pub(super) t_min: Vec4,
    /// Per axis, `-origin * inv_direction` moved down by a bound on its rounding error: the
    /// constant term of the fused entry distance `fma(plane, inv_direction, offset)` (see
    /// [`slab_test_flat`]).
    pub(super) fused_entry_offset: [f32; 3],
    /// Per axis, the same constant moved up: the fused exit distance's.
    pub(super) fused_exit_offset: [f32; 3],
    /// Whether every fused offset is finite. An axis-parallel ray (an infinite reciprocal)
    /// has none, and `plane * inf - inf` would be NaN, an axis that no longer prunes: such
    /// rays take the unfused test.
    pub(super) fused: bool,
}

/// The rounding slack of a fused offset, relative to `|origin * inv_direction|`: four
/// `f32::EPSILON` is eight units of roundoff, where the product and the shift round twice.
const FUSED_OFFSET_SLACK: f32 = 4.0 * f32::EPSILON;

/// The ray test of a node layout: every slot at once. Lives in this private module so the
/// public [`WideLayout`] can require it without making it part of the API (a sealed trait).
pub trait SlotRayTest<const N: usize> {
    /// The hit mask (bit i = slot i); each slot's entry distance is written to `entry_t`.
    ///
    /// An out parameter rather than a returned array: returned, the array is written four
    /// lanes at a time and copied on in wider moves, whose loads then wait for the narrower
    /// stores to retire, a stall at every node visit.
    fn intersect_slots(&self, ray: &RayLanes, t_max: f32, entry_t: &mut [f32; N]) -> u32;
    /// [`Self::intersect_slots`] for a walk compiled with 8-lane vectors (the AVX2 copy of the
    /// walk); the same hits, or conservative ones where the fused test runs.
    #[inline(always)]
    fn intersect_slots_wide(&self, ray: &RayLanes, t_max: f32, entry_t: &mut [f32; N]) -> u32 {
        self.intersect_slots(ray, t_max, entry_t)
    }
    /// Bit i set when slot i is a leaf.
    fn leaf_mask(&self) -> u32;
}

impl<const N: usize> SlotRayTest<N> for WideNode<N> {
    #[inline(always)]
    fn intersect_slots(&self, ray: &RayLanes, t_max: f32, entry_t: &mut [f32; N]) -> u32 {
        let planes = self.planes();
        let entry = ray.entry_plane.map(|p| &planes[p]);
        let exit = ray.exit_plane.map(|p| &planes[p]);
        slab_test_lanes::<N>(
            |chunk| {
                (
                    entry.map(|plane| lanes(plane, chunk)),
                    exit.map(|plane| lanes(plane, chunk)),
                )
            },
            ray,
            t_max,
            entry_t,
        )
    }

    /// 16-wide nodes take [`slab_test_flat`], which the compiler vectorises 8 lanes at a time
    /// where the walk is compiled with AVX2 (faster picking rays: BENCHMARKS.md, Picking), in
    /// its fused form unless the ray is axis-parallel. Narrower nodes keep the 4-lane test: for
    /// 8-wide mesh BVH nodes the flat test's mask building costs more than the wider lanes
    /// save (BENCHMARKS.md, Rays on meshes).
    #[inline(always)]
    fn intersect_slots_wide(&self, ray: &RayLanes, t_max: f32, entry_t: &mut [f32; N]) -> u32 {
        if N >= 16 {
            if ray.fused {
                slab_test_flat::<N, true>(self.planes(), ray, t_max, entry_t)
            } else {
                slab_test_flat::<N, false>(self.planes(), ray, t_max, entry_t)
            }
        } else {
            self.intersect_slots(ray, t_max, entry_t)
        }
    }

    #[inline(always)]
    fn leaf_mask(&self) -> u32 {
        leaf_mask_of(&self.count)
    }
}

/// The widened slab test of [`slab_test_lanes`] over a float node's six plane arrays, written
/// lane by lane over whole arrays so that the compiler vectorises it at the width the caller
/// is compiled for; 4-lane `glam` vectors stay 4 lanes wide in an AVX2 function, and
/// `_mm256` intrinsics are not inlined into a generic walk (called out of line, 8-lane
/// intrinsics are slower than the 4-lane test). The operations and their order are those of
/// `slab_test_lanes`, so the results are the same bits: `if c > acc { c } else { acc }` is `maxps(c, acc)`, which
/// keeps `acc` when `c` is NaN (see [`max_ignoring_nan`]), and an infinite distance becomes
/// NaN when widened and misses.
///
/// `FUSED` computes each distance as one fused multiply-add, `plane * inv + offset` with
/// `offset = -origin * inv` (tinybvh's and Embree's form), where the unfused form subtracts
/// and multiplies: faster mesh rays (BENCHMARKS.md, Rays on meshes). Only for walks
/// compiled with FMA; elsewhere `mul_add` is a library call. The fused distance is not the
/// unfused one to the bit but stays conservative. The offset's rounding is an absolute error (of the size of
/// `|origin * inv|`, large far from the origin), which the relative widening would not cover,
/// so the offsets are moved outward by a bound on it ([`RayLanes::fused_entry_offset`]); what
/// is left is relative, two roundings (the reciprocal and the fused one) where the unfused
/// form has three, inside the same widening.
#[inline(always)]
fn slab_test_flat<const N: usize, const FUSED: bool>(
    planes: &[[f32; N]; 6],
    r: &RayLanes,
    t_max: f32,
    entry_t: &mut [f32; N],
) -> u32 {
    let mut near = [f32::NEG_INFINITY; N];
    let mut far = [f32::INFINITY; N];
    for axis in 0..3 {
        let entry = &planes[r.entry_plane[axis]];
        let exit = &planes[r.exit_plane[axis]];
        let (o, inv) = (r.origin[axis].x, r.inv_direction[axis].x);
        let (entry_offset, exit_offset) = (r.fused_entry_offset[axis], r.fused_exit_offset[axis]);
        for i in 0..N {
            let t = if FUSED {
                entry[i].mul_add(inv, entry_offset)
            } else {
                (entry[i] - o) * inv
            };
            near[i] = if t > near[i] { t } else { near[i] };
            let t = if FUSED {
                exit[i].mul_add(inv, exit_offset)
            } else {
                (exit[i] - o) * inv
            };
            far[i] = if t < far[i] { t } else { far[i] };
        }
    }
    let t_min = r.t_min.x;
    let mut hits = [0u32; N];
    for i in 0..N {
        let n = near[i] - near[i].abs() * SLAB_WIDENING;
        let f = far[i] + far[i].abs() * SLAB_WIDENING;
        hits[i] = u32::from((n <= f) & (n <= t_max) & (f >= t_min));
        entry_t[i] = if n > t_min { n } else { t_min };
    }
    let mut mask = 0u32;
    for (i, hit) in hits.iter().enumerate() {
        mask |= hit << i;
    }
    mask
}

impl RayLanes {
    pub(super) fn new(ray: &Ray) -> Self {
        let o = ray.origin;
        let inv = ray.inv_direction;
        let offset = (-o) * inv;
        let slack = offset.abs() * FUSED_OFFSET_SLACK;
        let (fused_entry_offset, fused_exit_offset) = (offset - slack, offset + slack);
        Self {
            fused_entry_offset: fused_entry_offset.to_array(),
            fused_exit_offset: fused_exit_offset.to_array(),
            fused: fused_entry_offset.is_finite() && fused_exit_offset.is_finite(),
            origin: [Vec4::splat(o.x), Vec4::splat(o.y), Vec4::splat(o.z)],
            inv_direction: [Vec4::splat(inv.x), Vec4::splat(inv.y), Vec4::splat(inv.z)],
            entry_plane: core::array::from_fn(|axis| if inv[axis] < 0.0 { 3 + axis } else { axis }),
            exit_plane: core::array::from_fn(|axis| if inv[axis] < 0.0 { axis } else { 3 + axis }),
            t_min: Vec4::splat(ray.t_min),
        }
    }
}

/// `max(candidate, acc)` that returns `acc` when `candidate` is NaN.
///
/// A ray parallel to a slab and starting on its plane computes `0 * inf = NaN` there; that axis
/// must then not constrain the ray (see [`Ray::slab_interval`]). SSE's `maxps` returns its
/// second operand when either is NaN, and so does the scalar `f32::max`, so putting the
/// candidate first gets the rule for free; other back ends pay for an explicit select.
#[inline(always)]
pub(super) fn max_ignoring_nan(candidate: Vec4, acc: Vec4) -> Vec4 {
    if cfg!(any(target_arch = "x86", target_arch = "x86_64")) {
        candidate.max(acc)
    } else {
        Vec4::select(candidate.is_nan_mask(), acc, candidate.max(acc))
    }
}

/// `min(candidate, acc)` that returns `acc` when `candidate` is NaN (see [`max_ignoring_nan`]).
#[inline(always)]
fn min_ignoring_nan(candidate: Vec4, acc: Vec4) -> Vec4 {
    if cfg!(any(target_arch = "x86", target_arch = "x86_64")) {
        candidate.min(acc)
    } else {
        Vec4::select(candidate.is_nan_mask(), acc, candidate.min(acc))
    }
}

#[inline(always)]
pub(super) fn lanes<const N: usize>(a: &[f32; N], chunk: usize) -> Vec4 {
    Vec4::from_slice(&a[chunk * 4..chunk * 4 + 4])
}

/// Tests the ray against every child box of a node: returns the hit mask (bit i = slot i) and
/// writes each slot's entry distance to `entry_t`. The same conservative, widened slab test as
/// [`Ray::intersect_aabb`], lane by lane. `boxes(chunk)` gives, per axis, the planes the ray
/// enters and leaves slots `4 * chunk ..4 * chunk + 4` by (see [`RayLanes::entry_plane`]).
#[inline(always)]
pub(super) fn slab_test_lanes<const N: usize>(
    boxes: impl Fn(usize) -> ([Vec4; 3], [Vec4; 3]),
    r: &RayLanes,
    t_max: f32,
    entry_t: &mut [f32; N],
) -> u32 {
    let mut mask = 0u32;
    let t_max = Vec4::splat(t_max);
    let widen = Vec4::splat(SLAB_WIDENING);
    for chunk in 0..N / 4 {
        let (enter, exit) = boxes(chunk);
        let mut near = Vec4::NEG_INFINITY;
        let mut far = Vec4::INFINITY;
        for axis in 0..3 {
            near = max_ignoring_nan((enter[axis] - r.origin[axis]) * r.inv_direction[axis], near);
            far = min_ignoring_nan((exit[axis] - r.origin[axis]) * r.inv_direction[axis], far);
        }
        // Widened additively: an infinite distance (a miss on a parallel axis) becomes
        // inf - inf = NaN, and every comparison below is false for NaN, so it stays a miss.
        let near = near - near.abs() * widen;
        let far = far + far.abs() * widen;
        let hit = near.cmple(far) & near.cmple(t_max) & far.cmpge(r.t_min);
        mask |= hit.bitmask() << (chunk * 4);
        near.max(r.t_min)
            .write_to_slice(&mut entry_t[chunk * 4..chunk * 4 + 4]);
    }
    mask
}

/// Bit i set when `count[i]` is not zero, i.e. slot i is a leaf (written so the compiler can
/// turn it into one SIMD compare and a move-mask).
#[inline(always)]
pub(super) fn leaf_mask_of<T: Copy + Default + PartialEq, const N: usize>(count: &[T; N]) -> u32 {
    let mut mask = 0u32;
    for (i, &c) in count.iter().enumerate() {
        mask |= u32::from(c != T::default()) << i;
    }
    mask
}

/// Visits the leaves the ray reaches, nearer children first, skipping anything that starts
/// beyond `ray.t_max` (which the visitor may shrink). Where a node has more than one leaf in
/// range, their primitives are announced before any is visited (see
/// [`RayWalk::walk_ray_announcing`](crate::query::RayWalk::walk_ray_announcing)).
///
/// The loop descends straight into the nearest child and pushes only the others: with one
/// child hit (the common case deep in a tree) a node costs no stack traffic and no sort
/// (Embree's BVH-N traversal does the same, Wald et al. 2014).
///
/// `COSTLY_LEAVES` says that visiting a primitive takes long next to a node fetch (an
/// announcing walk's, whose primitives are entities with a mesh behind them): the interior
/// children a node's ray hits are then asked for before its leaves are visited, so that their
/// fetch overlaps that work instead of following it, which makes picking rays faster
/// (BENCHMARKS.md, Picking). Every closest-hit query runs as an announcing walk whose hook
/// does nothing ([`closest_hit`](crate::query::ray_walk::closest_hit)), mesh BVHs' included;
/// walking those with it off makes no measurable difference.
///
/// `ORDERED` off visits leaves and descends into children in slot order, unsorted: for walks
/// that stop at the first hit whatever its distance (occlusion), as Embree's and tinybvh's
/// any-hit traversals do; the range still prunes.
///
/// `WIDE_LANES` says that the walk is compiled with 8-lane vectors (the AVX2 copy), so node
/// tests take [`SlotRayTest::intersect_slots_wide`].
///
/// The closures that carry `visit` to the leaves are `#[inline(always)]`, as are those of the
/// queries built on this walk (`query::ray_walk`) and the mesh BVHs' leaf tests: a closure
/// left out of line is a function of its own, compiled for the baseline target, so the mesh
/// BVHs' 4-lane triangle test would run as SSE2 code called from the AVX2 walk. Inlined, it
/// is compiled with the walk, which makes closest-hit mesh rays faster (BENCHMARKS.md, Rays
/// on meshes).
// Always inlined, so that the AVX2 copy of the announcing walk (`query.rs`) compiles this
// loop with AVX2 instead of calling the SSE one.
#[inline(always)]
pub(super) fn visit_ray<
    const N: usize,
    const COSTLY_LEAVES: bool,
    const WIDE_LANES: bool,
    const ORDERED: bool,
    L,
    A,
    F,
>(
    tree: &WideBvh<N, L>,
    ray: &mut Ray,
    mut announce: A,
    mut visit: F,
) where
    L: WideLayout<N>,
    A: FnMut(u32),
    F: FnMut(u32, &mut Ray) -> ControlFlow<()>,
{
    // No test of the root's box first: the root node's test covers its children, whose boxes
    // lie inside it, so a ray that misses the tree finds no child and stops there. An extra
    // scalar test would slow the rays that start inside the tree (every shadow and bounce
    // ray) for nothing.
    //
    // An untraceable ray is turned away here, not left to the slab test: with every
    // reciprocal NaN (a NaN direction) each axis reads as unconstraining, and a degenerate
    // ray's range `[inf, -inf]` then admits the resulting `[-inf, inf]` interval, so every
    // slot hit, the empty ones too, whose child index is `u32::MAX` (an out-of-bounds
    // panic in the node fetch, tests/nan_safety.rs).
    if tree.nodes.is_empty() || !ray.is_traceable() {
        return;
    }
    let lanes = RayLanes::new(ray);
    let mut stack: TraversalStack<(u32, f32)> = TraversalStack::new();
    let mut node_index = 0u32;
    loop {
        let node = &tree.nodes[node_index as usize];
        let mut entry_t = [0.0f32; N];
        let mask = if WIDE_LANES {
            node.intersect_slots_wide(&lanes, ray.t_max, &mut entry_t)
        } else {
            node.intersect_slots(&lanes, ray.t_max, &mut entry_t)
        };
        let leaves = node.leaf_mask();
        // Leaves first: their hits shrink the range before any subtree is chosen. Nearest
        // first among them, so that a near hit cuts off the leaves behind it: since the
        // least-cost collapse (`plan.rs`) fills nodes, a node holds more leaves, and in
        // leaf order rays reach more candidates, which slows picking rays (BENCHMARKS.md,
        // Picking).
        let mut leaf_hits = mask & leaves;
        if COSTLY_LEAVES && leaf_hits != 0 {
            let mut inner = mask & !leaves;
            while inner != 0 {
                let slot = inner.trailing_zeros() as usize;
                inner &= inner - 1;
                prefetch_node(&tree.nodes[node.child(slot) as usize]);
            }
        }
        // One leaf needs no announcement: its first primitive is visited at once anyway.
        // A walk whose hook does nothing (every `walk_ray`, the mesh BVHs' rays among them)
        // compiles this loop away (see `for_each_leaf_id`), but only because the loop is
        // bounded by N: LLVM may not assume that a Rust loop ends, so `while announced != 0`
        // with an empty body would stay in the code as a loop over the bits, with its
        // mispredicted exit, which slows mesh rays, shadow rays most (BENCHMARKS.md, Rays on
        // meshes). (Masks are counted with `x & (x - 1)`, here and below: the
        // baseline x86-64 target has no `popcnt`, and `count_ones` costs a dozen
        // instructions per node without it.)
        if has_several(leaf_hits) {
            let mut announced = leaf_hits;
            for _ in 0..N {
                if announced == 0 {
                    break;
                }
                let slot = announced.trailing_zeros() as usize;
                announced &= announced - 1;
                let _ = for_each_leaf_id(tree, node, slot, |p| {
                    announce(p);
                    ControlFlow::Continue(())
                });
            }
        }
        if !ORDERED {
            // Any order will do (an occlusion test stops at the first hit): leaves in slot
            // order, with no sort.
            while leaf_hits != 0 {
                let slot = leaf_hits.trailing_zeros() as usize;
                leaf_hits &= leaf_hits - 1;
                if entry_t[slot] > ray.t_max {
                    continue;
                }
                if for_each_leaf_id(
                    tree,
                    node,
                    slot,
                    #[inline(always)]
                    |p| visit(p, ray),
                )
                .is_break()
                {
                    return;
                }
            }
        }
        // Insertion sort by entry distance: at most N items. Written out here and again for
        // the interior children below: one shared helper (a sort-order argument and a
        // closure for the stored value) makes rays on the million-triangle scene clearly
        // slower (BENCHMARKS.md, Rays on meshes), so the two loops stay apart.
        let range_before = ray.t_max;
        let mut leaf_order = [(0.0f32, 0u32); N];
        let mut leaf_count = 0;
        while leaf_hits != 0 {
            let slot = leaf_hits.trailing_zeros();
            leaf_hits &= leaf_hits - 1;
            let item = (entry_t[slot as usize], slot);
            let mut j = leaf_count;
            while j > 0 && leaf_order[j - 1].0 > item.0 {
                leaf_order[j] = leaf_order[j - 1];
                j -= 1;
            }
            leaf_order[j] = item;
            leaf_count += 1;
        }
        for &(t, slot) in &leaf_order[..leaf_count] {
            if t > ray.t_max {
                // Sorted: every leaf after this one starts beyond the range too.
                break;
            }
            if for_each_leaf_id(
                tree,
                node,
                slot as usize,
                #[inline(always)]
                |p| visit(p, ray),
            )
            .is_break()
            {
                return;
            }
        }
        let inner = mask & !leaves;
        // Children that now start beyond the shrunk range. Only a hit on a leaf shrinks it;
        // otherwise the node test's range check stands for every child (with the
        // popcount-free counting above, faster picking rays: BENCHMARKS.md, Picking).
        let mut kept = if ray.t_max == range_before {
            inner
        } else {
            let mut kept = 0u32;
            let mut rest = inner;
            while rest != 0 {
                let slot = rest.trailing_zeros();
                rest &= rest - 1;
                if entry_t[slot as usize] <= ray.t_max {
                    kept |= 1 << slot;
                }
            }
            kept
        };
        if kept == 0 {
            // Pop until an entry still starts within the (possibly shrunk) range.
            loop {
                match stack.pop() {
                    None => return,
                    Some((next, t)) if t <= ray.t_max => {
                        node_index = next;
                        break;
                    }
                    Some(_) => {}
                }
            }
        } else if !has_several(kept) {
            node_index = node.child(kept.trailing_zeros() as usize);
        } else if !ORDERED {
            // Descend into the nearest child, push the rest unsorted.
            let mut nearest = kept.trailing_zeros() as usize;
            let mut rest = kept & (kept - 1);
            while rest != 0 {
                let slot = rest.trailing_zeros() as usize;
                rest &= rest - 1;
                nearest = if entry_t[slot] < entry_t[nearest] {
                    slot
                } else {
                    nearest
                };
            }
            node_index = node.child(nearest);
            kept &= !(1 << nearest);
            while kept != 0 {
                let slot = kept.trailing_zeros() as usize;
                kept &= kept - 1;
                let child = node.child(slot);
                prefetch_node(&tree.nodes[child as usize]);
                stack.push((child, entry_t[slot]));
            }
        } else {
            // Sort the hit children farthest first (insertion sort: at most N), push all
            // but the nearest, and descend into the nearest.
            let mut order = [(0.0f32, 0u32); N];
            let mut hits = 0;
            while kept != 0 {
                let slot = kept.trailing_zeros() as usize;
                kept &= kept - 1;
                let item = (entry_t[slot], node.child(slot));
                let mut j = hits;
                while j > 0 && order[j - 1].0 < item.0 {
                    order[j] = order[j - 1];
                    j -= 1;
                }
                order[j] = item;
                hits += 1;
            }
            for &(t, child) in &order[..hits - 1] {
                prefetch_node(&tree.nodes[child as usize]);
                stack.push((child, t));
            }
            node_index = order[hits - 1].1;
        }
    }
}

/// Calls `f` with the primitive ids of leaf slot `slot`: an id inlined in the node, the
/// slot's range itself where ids are positions ([`WideBvh::ids_are_positions`]), else the
/// ids the range names in the primitive array. `get`, not indexing: with no panic to keep, a
/// call whose `f` does nothing compiles away.
#[inline(always)]
fn for_each_leaf_id<const N: usize, L, F>(
    tree: &WideBvh<N, L>,
    node: &L,
    slot: usize,
    mut f: F,
) -> ControlFlow<()>
where
    L: WideLayout<N>,
    F: FnMut(u32) -> ControlFlow<()>,
{
    if let Some(p) = node.inline_primitive(slot) {
        return f(p);
    }
    let (first, count) = (node.child(slot), node.count(slot));
    if tree.ids_are_positions {
        for p in first..first + count {
            f(p)?;
        }
        return ControlFlow::Continue(());
    }
    let (first, count) = (first as usize, count as usize);
    for &p in tree
        .primitive_indices
        .get(first..first + count)
        .unwrap_or(&[])
    {
        f(p)?;
    }
    ControlFlow::Continue(())
}

/// True when `mask` has more than one bit set.
#[inline(always)]
fn has_several(mask: u32) -> bool {
    mask & mask.wrapping_sub(1) != 0
}

#[cfg(test)]
#[path = "ray_tests.rs"]
mod tests;
