//! The BVH collapsed to 4-, 8- or 16-wide nodes, child boxes laid out for SIMD.
//!
//! A binary tree spends one memory fetch and one stack decision per two boxes; a wide node
//! tests all its children's boxes in a handful of SIMD instructions from one or two cache
//! lines (Wald et al. 2008, "Getting rid of packets"; Dammertz et al. 2008, "Shallow bounding
//! volume hierarchies"). The collapse keeps the binary tree's SAH partition and only removes
//! levels, so quality is unchanged while depth drops to a half (4-wide), a third (8-wide) or a
//! quarter (16-wide).

mod collapse;
mod layout;
mod node;
mod plan;
mod quantized;
mod query;
mod ray;
mod refit;

pub use layout::WideLayout;
pub use node::{EMPTY_SLOT, INLINE_PRIMITIVE, WideNode};
pub use quantized::QuantizedNode;
pub use query::WideSlots;
pub use refit::RefitPaths;

use super::Bvh;
use crate::Aabb;

/// A BVH with `N` children per node (`N` = 4, 8 or 16), built by collapsing a binary [`Bvh`].
///
/// Answers every [`crate::SpatialQuery`]; ray queries test all children of a node at once.
///
/// ```
/// use spatial_accel::{Aabb, BuildConfig, Bvh, Ray, SpatialQuery};
/// use spatial_accel::bvh::wide::WideBvh;
/// use glam::Vec3A;
/// let boxes: Vec<Aabb> = (0..500)
///     .map(|i| Aabb::new(Vec3A::new(i as f32, 0.0, 0.0), Vec3A::new(i as f32 + 0.5, 1.0, 1.0)))
///     .collect();
/// let wide = WideBvh::<8>::from_bvh(&Bvh::build(&boxes, &BuildConfig::default()));
/// wide.validate(&boxes).unwrap();
/// let ray = Ray::new(Vec3A::new(100.7, 0.5, 0.5), Vec3A::X);
/// let hit = wide.cast_ray(&ray, |i, r| r.intersect_aabb(&boxes[i as usize])).unwrap();
/// assert_eq!(hit.primitive, 101);
/// ```
///
/// The node layout `L` is [`WideNode`] (exact `f32` child boxes) by default, or
/// [`QuantizedNode`] (8-bit child boxes, half the memory: see [`QBvh8`]).
#[derive(Clone, Debug, Default)]
pub struct WideBvh<const N: usize, L = WideNode<N>> {
    pub(crate) nodes: Vec<L>,
    pub(crate) primitive_indices: Vec<u32>,
    pub(crate) bounds: Aabb,
    /// True when [`Self::primitive_indices`] is `0, 1, 2, ...` (a mesh BVH's packets are
    /// stored in leaf order): a ray walk then takes a leaf's primitive ids from its range and
    /// skips the array. Reading a leaf's ids from the array is one more dependent load between
    /// the node's and the primitive's; skipping it makes incoherent rays on the
    /// million-triangle mesh faster and costs other rays nothing (BENCHMARKS.md, Rays on
    /// meshes).
    pub(crate) ids_are_positions: bool,
}

/// The 4-wide layout (one SSE register per coordinate).
pub type Bvh4 = WideBvh<4>;
/// The 8-wide layout (one AVX register, or two SSE registers, per coordinate).
pub type Bvh8 = WideBvh<8>;
/// The 16-wide layout (512-byte nodes): a tree a quarter shallower than the 8-wide one, for
/// single rays through large trees whose nodes come from memory one level at a time. Where
/// the CPU has AVX2 its node test runs 8 lanes at a time. The entity trees' ray copies and the
/// mesh BVHs use it: rays through entity trees are faster on it than on `Bvh8` even with the
/// 4-lane test, and diffuse and incoherent mesh rays gain most from the 8-lane one
/// (BENCHMARKS.md, Picking and Rays on meshes).
pub type Bvh16 = WideBvh<16>;
/// The 8-wide layout with quantized child boxes: 128-byte nodes (two cache lines) instead of
/// 256, for trees traced by many incoherent rays (mesh BVHs), where node fetches from memory
/// dominate (Ylitie et al. 2017, "Efficient incoherent ray traversal on GPUs through
/// compressed wide BVHs"; Embree's QBVH8).
pub type QBvh8 = WideBvh<8, QuantizedNode<8>>;

impl<const N: usize, L: WideLayout<N>> WideBvh<N, L> {
    /// Collapses a binary tree. The primitive order is the binary tree's.
    pub fn from_bvh(bvh: &Bvh) -> Self {
        const {
            assert!(
                N == 4 || N == 8 || N == 16,
                "wide BVHs are 4-, 8- or 16-wide"
            )
        };
        collapse::collapse(bvh)
    }

    /// The node array; node 0 is the root.
    pub fn nodes(&self) -> &[L] {
        &self.nodes
    }

    /// Primitive ids in leaf order.
    pub fn primitive_indices(&self) -> &[u32] {
        &self.primitive_indices
    }

    /// Number of primitives.
    pub fn primitive_count(&self) -> usize {
        self.primitive_indices.len()
    }

    /// True when the tree holds nothing.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The box around everything.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Memory held by the tree, in bytes.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * core::mem::size_of::<L>() + self.primitive_indices.len() * 4
    }

    /// The expected number of slot boxes a random ray through the tree's box enters (the
    /// surface area heuristic's count: each used slot's surface area over the root's, summed).
    /// A measure of how loose the tree is, for deciding when refits have made it worth a
    /// rebuild: it only compares trees over the same primitives. Zero for an empty tree; every
    /// slot counts once where the root's box has no area.
    pub fn slot_area_cost(&self) -> f32 {
        let root = f64::from(self.bounds.half_area());
        if root > 0.0 {
            (self.slot_area_sum() / root) as f32
        } else {
            self.nodes
                .iter()
                .map(|node| (0..N).filter(|&slot| node.is_used(slot)).count())
                .sum::<usize>() as f32
        }
    }

    /// Every used slot's surface area (half area), summed: the
    /// [`slot_area_cost`](Self::slot_area_cost) before the division by the root's.
    pub fn slot_area_sum(&self) -> f64 {
        let every_slot = (1u32 << N) - 1;
        self.nodes
            .iter()
            .map(|node| used_slot_area(node, every_slot))
            .sum()
    }

    /// Checks that every slot's box contains what is below it and that every valid primitive
    /// of `bounds` is reachable exactly once.
    pub fn validate(&self, bounds: &[Aabb]) -> Result<(), super::validate::ValidationError> {
        collapse::validate(self, bounds.len(), |p| {
            bounds.get(p as usize).copied().filter(Aabb::is_valid)
        })
    }

    /// [`WideBvh::validate`] with each primitive's box given by `bounds(id)`, `None` for ids
    /// that should not be in the tree (an empty box is a known primitive that no leaf needs
    /// to grow for: one a refit found no finite bounds for).
    pub(crate) fn validate_with(
        &self,
        primitive_count: usize,
        bounds: impl Fn(u32) -> Option<Aabb>,
    ) -> Result<(), super::validate::ValidationError> {
        collapse::validate(self, primitive_count, bounds)
    }
}

/// The summed surface area (half areas) of the used slots of `node` named in `mask` (bit `s`:
/// slot `s`): what [`WideBvh::slot_area_sum`] adds up, and what a path refit compares before
/// and after.
fn used_slot_area<const N: usize, L: WideLayout<N>>(node: &L, mask: u32) -> f64 {
    (0..N)
        .filter(|&slot| mask & (1 << slot) != 0 && node.is_used(slot))
        .map(|slot| f64::from(node.child_aabb(slot).half_area()))
        .sum()
}

/// True when every primitive id equals its position in leaf order.
fn ids_are_positions(ids: &[u32]) -> bool {
    ids.iter().enumerate().all(|(i, &id)| id as usize == i)
}

impl<const N: usize> WideBvh<N> {
    /// Stores the id of every single-primitive leaf's primitive in its node (as
    /// [`INLINE_PRIMITIVE`]` | id` in the slot's count), so that ray walks read it there.
    ///
    /// Why: reaching a leaf's primitive through the primitive array is one more dependent
    /// load after the node's, and on trees whose leaves are mostly single primitives scattered
    /// over a large array (entity trees: 400 KB of ids at 10^5 entities) it misses the cache.
    /// Rays through the picking benchmark's entity trees are faster with the ids inlined
    /// (BENCHMARKS.md, Picking). Everything else (the primitive array, each slot's
    /// position in it, refits) is unchanged. Ids at or above 2^31 stay in the array.
    ///
    /// Call it again after rewriting [`Self::primitive_indices`]' ids in place (it also
    /// notes whether the ids are still their positions, which lets walks skip the array).
    pub fn inline_single_leaves(&mut self) {
        self.ids_are_positions = ids_are_positions(&self.primitive_indices);
        for node in &mut self.nodes {
            for slot in 0..N {
                if WideLayout::count(node, slot) != 1 {
                    continue;
                }
                let id = self.primitive_indices[node.child[slot] as usize];
                node.count[slot] = if id < INLINE_PRIMITIVE {
                    INLINE_PRIMITIVE | id
                } else {
                    1
                };
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::BuildConfig;
    use crate::bvh::validate::ValidationError;

    /// The validator catches an inlined id that is not its slot's primitive.
    #[test]
    fn validation_catches_a_wrong_inlined_id() {
        let boxes: Vec<Aabb> = (0..40)
            .map(|i| {
                let p = glam::Vec3A::new(i as f32 * 3.0, (i % 5) as f32, 0.0);
                Aabb::new(p, p + 1.0)
            })
            .collect();
        let config = BuildConfig {
            max_leaf_size: 1,
            ..BuildConfig::default()
        };
        let mut wide = Bvh8::from_bvh(&Bvh::build(&boxes, &config));
        wide.inline_single_leaves();
        wide.validate(&boxes).unwrap();
        let (node, slot) = wide
            .nodes
            .iter()
            .enumerate()
            .find_map(|(n, node)| {
                (0..8)
                    .find(|&s| node.inline_primitive(s).is_some())
                    .map(|s| (n, s))
            })
            .expect("an inlined leaf");
        let id = wide.nodes[node].inline_primitive(slot).unwrap();
        wide.nodes[node].count[slot] = INLINE_PRIMITIVE | ((id + 1) % 40);
        assert!(matches!(
            wide.validate(&boxes),
            Err(ValidationError::InlinePrimitiveMismatch { .. })
        ));
    }
}
