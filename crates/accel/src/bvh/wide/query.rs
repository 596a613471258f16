//! [`SpatialQuery`] for wide trees: rays through the SIMD traversal, the rest per slot.

use super::ray::visit_ray;
use super::{WideBvh, WideLayout};
use crate::query::RayWalk;
use crate::query::TraversalStack;
use crate::query::views::{ViewClassification, ViewMasks};
use crate::{Aabb, Containment, Frustum, Ray, SpatialQuery, Sphere};
use core::cmp::Reverse;
use core::ops::ControlFlow;
use glam::Vec3A;
use std::collections::BinaryHeap;

impl<const N: usize, L: WideLayout<N>> WideBvh<N, L> {
    /// Visits the primitives of every leaf slot whose box passes `slot_test`.
    fn for_each_leaf_primitive<P, F>(&self, mut slot_test: P, mut visit: F) -> ControlFlow<()>
    where
        P: FnMut(&Aabb) -> bool,
        F: FnMut(u32) -> ControlFlow<()>,
    {
        if self.nodes.is_empty() || !slot_test(&self.bounds) {
            return ControlFlow::Continue(());
        }
        let mut stack: TraversalStack<u32> = TraversalStack::new();
        stack.push(0);
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n as usize];
            for slot in (0..N).filter(|&s| node.is_used(s)) {
                if !slot_test(&node.child_aabb(slot)) {
                    continue;
                }
                if node.is_leaf(slot) {
                    self.visit_slot_primitives(n, slot, &mut visit)?;
                } else {
                    stack.push(node.child(slot));
                }
            }
        }
        ControlFlow::Continue(())
    }

    fn visit_slot_primitives<F>(&self, node: u32, slot: usize, visit: &mut F) -> ControlFlow<()>
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        let n = &self.nodes[node as usize];
        let first = n.child(slot) as usize;
        for &p in &self.primitive_indices[first..first + n.count(slot) as usize] {
            visit(p)?;
        }
        ControlFlow::Continue(())
    }

    /// Everything below a slot, without tests (a subtree the frustum fully contains).
    fn visit_slot_subtree<F>(&self, node: u32, slot: usize, visit: &mut F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        let n = &self.nodes[node as usize];
        if n.is_leaf(slot) {
            let _ = self.visit_slot_primitives(node, slot, visit);
            return;
        }
        let mut stack: TraversalStack<u32> = TraversalStack::new();
        stack.push(n.child(slot));
        while let Some(c) = stack.pop() {
            let cn = &self.nodes[c as usize];
            for s in (0..N).filter(|&s| cn.is_used(s)) {
                if cn.is_leaf(s) {
                    let _ = self.visit_slot_primitives(c, s, visit);
                } else {
                    stack.push(cn.child(s));
                }
            }
        }
    }
}

impl<const N: usize, L: WideLayout<N>> WideBvh<N, L> {
    /// A walk that announces nothing, sorted or not (`ORDERED`, see `visit_ray`).
    #[inline(always)]
    fn walk_ray_plain<const ORDERED: bool, V>(&self, ray: &mut Ray, visit: V)
    where
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        // 16-wide trees' node tests run 8 lanes wide where the walk is compiled with AVX2 (see
        // `SlotRayTest::intersect_slots_wide`); narrower trees gain nothing from the copy.
        #[cfg(target_arch = "x86_64")]
        if N >= 16 && std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma")
        {
            // SAFETY: the CPU has AVX2 and FMA.
            unsafe { visit_ray_avx2::<N, false, ORDERED, L, _, _>(self, ray, |_| {}, visit) };
            return;
        }
        visit_ray::<N, false, false, ORDERED, L, _, _>(self, ray, |_| {}, visit)
    }
}

impl<const N: usize, L: WideLayout<N>> RayWalk for WideBvh<N, L> {
    fn walk_ray<V>(&self, ray: &mut Ray, visit: V)
    where
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        self.walk_ray_plain::<true, V>(ray, visit);
    }

    fn walk_ray_any_order<V>(&self, ray: &mut Ray, visit: V)
    where
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        self.walk_ray_plain::<false, V>(ray, visit);
    }

    fn walk_ray_announcing<A, V>(&self, ray: &mut Ray, announce: A, visit: V)
    where
        A: FnMut(u32),
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        // Announcing walks are those of closest-hit queries (`closest_hit` announces to a hook
        // that does nothing), the picking casts' over entity trees among them. Their loop runs
        // a second time compiled with AVX2 where the CPU has it: the VEX encoding's
        // three-operand forms drop the register copies of the node test (1.5-2% a ray at 10^5
        // entities, paired), and 16-wide nodes are tested 8 lanes at a time
        // (`SlotRayTest::intersect_slots_wide`; about 4% more, where `_mm256` intrinsics had
        // cost 5-9%).
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
            // SAFETY: the CPU has AVX2 and FMA.
            unsafe { visit_ray_avx2::<N, true, true, L, _, _>(self, ray, announce, visit) };
            return;
        }
        visit_ray::<N, true, false, true, L, _, _>(self, ray, announce, visit)
    }
}

/// The walk compiled with AVX2, for announcing walks and for plain walks of 16-wide trees
/// (see `walk_ray_announcing` and `walk_ray`), and with FMA, which only the fused node test
/// of 16-wide trees uses (`slab_test_flat`): its node tests are conservative but not the
/// baseline's bits, so it may visit a grazed box the baseline skips or the reverse; the
/// answers are the same. Every other operation is the baseline's.
///
/// # Safety
/// The CPU must have AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn visit_ray_avx2<const N: usize, const COSTLY_LEAVES: bool, const ORDERED: bool, L, A, V>(
    tree: &WideBvh<N, L>,
    ray: &mut Ray,
    announce: A,
    visit: V,
) where
    L: WideLayout<N>,
    A: FnMut(u32),
    V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
{
    visit_ray::<N, COSTLY_LEAVES, true, ORDERED, L, _, _>(tree, ray, announce, visit)
}

impl<const N: usize, L: WideLayout<N>> SpatialQuery for WideBvh<N, L> {
    fn for_each_overlapping_aabb<F>(&self, aabb: &Aabb, visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        let _ = self.for_each_leaf_primitive(|b| b.intersects_aabb(aabb), visit);
    }

    fn for_each_overlapping_sphere<F>(&self, sphere: &Sphere, visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        let _ = self.for_each_leaf_primitive(|b| sphere.intersects_aabb(b), visit);
    }

    fn for_each_containing_point<F>(&self, point: Vec3A, visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        let _ = self.for_each_leaf_primitive(|b| b.contains_point(point), visit);
    }

    fn for_each_in_frustum<F>(&self, frustum: &Frustum, mut visit: F)
    where
        F: FnMut(u32, Containment),
    {
        if self.nodes.is_empty() || !frustum.intersects_aabb(&self.bounds) {
            return;
        }
        let mut stack: TraversalStack<u32> = TraversalStack::new();
        stack.push(0);
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n as usize];
            for slot in (0..N).filter(|&s| node.is_used(s)) {
                match frustum.classify_aabb(&node.child_aabb(slot)) {
                    Containment::Outside => {}
                    Containment::Inside => self.visit_slot_subtree(n, slot, &mut |p| {
                        visit(p, Containment::Inside);
                        ControlFlow::Continue(())
                    }),
                    Containment::Intersecting if node.is_leaf(slot) => {
                        let _ = self.visit_slot_primitives(n, slot, &mut |p| {
                            visit(p, Containment::Intersecting);
                            ControlFlow::Continue(())
                        });
                    }
                    Containment::Intersecting => stack.push(node.child(slot)),
                }
            }
        }
    }

    fn for_each_in_views<C, F>(&self, views: u32, mut classify: C, mut visit: F)
    where
        C: FnMut(&Aabb, u32) -> ViewClassification,
        F: FnMut(u32, ViewMasks),
    {
        if self.nodes.is_empty() || views == 0 {
            return;
        }
        // As the binary walk (`query::views`), per slot: each entry carries its node's masks.
        let mut stack: TraversalStack<(u32, ViewMasks)> = TraversalStack::new();
        stack.push((0, ViewMasks::undecided(views)));
        while let Some((n, above)) = stack.pop() {
            let node = &self.nodes[n as usize];
            for slot in (0..N).filter(|&s| node.is_used(s)) {
                let c = classify(&node.child_aabb(slot), above.crossing);
                let Some(masks) = above.below(c) else {
                    continue;
                };
                if masks.crossing == 0 {
                    self.visit_slot_subtree(n, slot, &mut |p| {
                        visit(p, masks);
                        ControlFlow::Continue(())
                    });
                } else if node.is_leaf(slot) {
                    let _ = self.visit_slot_primitives(n, slot, &mut |p| {
                        visit(p, masks);
                        ControlFlow::Continue(())
                    });
                } else {
                    stack.push((node.child(slot), masks));
                }
            }
        }
    }

    fn nearest_k<F>(&self, point: Vec3A, k: usize, mut distance_squared: F) -> Vec<(u32, f32)>
    where
        F: FnMut(u32) -> f32,
    {
        if self.nodes.is_empty() || k == 0 {
            return Vec::new();
        }
        // Best-first over slots: (box distance, node, slot); slot N stands for "the root".
        let key = |d2: f32| d2.to_bits();
        let mut frontier: BinaryHeap<Reverse<(u32, u32, usize)>> = BinaryHeap::new();
        let mut best: BinaryHeap<(u32, u32)> = BinaryHeap::new(); // (d2 bits, id): max-heap
        frontier.push(Reverse((
            key(self.bounds.distance_squared_to_point(point)),
            0,
            N,
        )));
        while let Some(Reverse((d2, n, slot))) = frontier.pop() {
            if best.len() == k && best.peek().is_some_and(|w| d2 > w.0) {
                break;
            }
            let node = &self.nodes[n as usize];
            if slot == N {
                for s in (0..N).filter(|&s| node.is_used(s)) {
                    let d = node.child_aabb(s).distance_squared_to_point(point);
                    frontier.push(Reverse((key(d), n, s)));
                }
            } else if node.is_leaf(slot) {
                let _ = self.visit_slot_primitives(n, slot, &mut |p| {
                    let d = distance_squared(p);
                    if !d.is_nan() {
                        let cand = (key(d.max(0.0)), p);
                        if best.len() < k {
                            best.push(cand);
                        } else if best.peek().is_some_and(|w| cand < *w) {
                            best.pop();
                            best.push(cand);
                        }
                    }
                    ControlFlow::Continue(())
                });
            } else {
                frontier.push(Reverse((d2, node.child(slot), N)));
            }
        }
        // Non-negative floats order like their bit patterns, so the heaps compared bits.
        let mut out: Vec<(u32, f32)> = best
            .into_iter()
            .map(|(d, id)| (id, f32::from_bits(d)))
            .collect();
        out.sort_unstable_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
        out
    }
}
