//! [`SpatialQuery`](crate::SpatialQuery) for wide trees: rays through the SIMD traversal,
//! the rest through the shared walks over a slot-by-slot [`BoundingTree`] view.

use super::ray::visit_ray;
use super::{WideBvh, WideLayout};
use crate::query::{BoundingTree, RayWalk};
use crate::{Aabb, Ray};
use core::ops::ControlFlow;

/// The node id of the root in the [`BoundingTree`] view; every other id is a slot,
/// `node * N + slot`.
const ROOT: u32 = u32::MAX;

/// The used slots of one node, as the [`BoundingTree`] view's ids (`node * N + slot`).
#[derive(Clone, Copy, Debug)]
pub struct WideSlots {
    base: u32,
    /// Bit `s`: slot `s` is used and not yet yielded.
    mask: u32,
}

impl Iterator for WideSlots {
    type Item = u32;

    #[inline]
    fn next(&mut self) -> Option<u32> {
        (self.mask != 0).then(|| {
            let slot = self.mask.trailing_zeros();
            self.mask &= self.mask - 1;
            self.base + slot
        })
    }
}

impl DoubleEndedIterator for WideSlots {
    #[inline]
    fn next_back(&mut self) -> Option<u32> {
        (self.mask != 0).then(|| {
            let slot = 31 - self.mask.leading_zeros();
            self.mask &= !(1 << slot);
            self.base + slot
        })
    }
}

impl<const N: usize, L: WideLayout<N>> WideBvh<N, L> {
    /// The used slots of node `n`.
    #[inline]
    fn slots_of(&self, n: u32) -> WideSlots {
        let node = &self.nodes[n as usize];
        let mask = (0..N)
            .filter(|&s| node.is_used(s))
            .fold(0u32, |m, s| m | (1 << s));
        WideSlots {
            base: n * N as u32,
            mask,
        }
    }
}

/// The tree seen one slot at a time: a slot is a node of the view, with its box, and its
/// children are the used slots of the node it points to. Every query but rays walks this
/// view through the shared code; rays keep the SIMD walk, which tests a node's slots at once.
impl<const N: usize, L: WideLayout<N>> BoundingTree for WideBvh<N, L> {
    type Volume = Aabb;
    type Children<'a>
        = WideSlots
    where
        Self: 'a;

    #[inline]
    fn root(&self) -> Option<u32> {
        debug_assert!(self.nodes.len() < (ROOT as usize) / N);
        (!self.nodes.is_empty()).then_some(ROOT)
    }

    #[inline]
    fn node_bounds(&self, id: u32) -> Aabb {
        if id == ROOT {
            return self.bounds;
        }
        let slot = id as usize % N;
        self.nodes[id as usize / N].child_aabb(slot)
    }

    #[inline]
    fn node_children(&self, id: u32) -> Option<WideSlots> {
        if id == ROOT {
            return Some(self.slots_of(0));
        }
        let node = &self.nodes[id as usize / N];
        let slot = id as usize % N;
        (!node.is_leaf(slot)).then(|| self.slots_of(node.child(slot)))
    }

    #[inline]
    fn node_primitives(&self, id: u32) -> &[u32] {
        if id == ROOT {
            return &[];
        }
        let node = &self.nodes[id as usize / N];
        let slot = id as usize % N;
        if node.is_leaf(slot) {
            let first = node.child(slot) as usize;
            &self.primitive_indices[first..first + node.count(slot) as usize]
        } else {
            &[]
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
        // three-operand forms drop the register copies of the node test, and 16-wide nodes
        // are tested 8 lanes at a time (`SlotRayTest::intersect_slots_wide`; `_mm256`
        // intrinsics, which a generic walk cannot inline, are slower). Each makes picking rays
        // faster (BENCHMARKS.md, Picking).
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

crate::impl_spatial_query_for_tree!(@queries impl[const N: usize, L: WideLayout<N>] WideBvh<N, L>);
