//! One query interface for every spatial structure in the crate.
//!
//! [`SpatialQuery`] is what picking, culling and the preview call; the BVHs, the dynamic BVH,
//! the loose octree and quadtree, the uniform grid and the flat lists all implement it. Trees only *find candidates*: each query calls
//! back per primitive, and the caller runs the exact test (a triangle, an entity filter), so one
//! tree serves boxes, meshes and entities alike.
//!
//! - [`BoundingTree`]: the view of a hierarchy (a node's children and their volumes, the
//!   primitives stored at a node) that every query is written once over, in [`walks`] and
//!   [`views`], whatever the tree's branching factor and volume ([`NodeVolume`]).
//! - [`RayWalk`]: how a structure visits what a ray reaches; the closest, any and all hit
//!   queries are built on it ([`ray_walk`]).
//! - [`DynamicIndex`]: an index over moving boxes (insert, update and remove by handle,
//!   per-frame upkeep with a budget, stats, its nodes by depth for overlays), and
//!   [`AnyIndex`], the one chosen at run time; [`IndexAdvisor`] chooses it from the
//!   observed workload. Every index names its entries by a generational [`Handle`].
//! - [`NodeView`] and [`visit_tree_nodes`]: the nodes of any [`BoundingTree`] level by level,
//!   as [`DynamicIndex::visit_nodes`] gives those of a dynamic index.
//! - [`TriangleQuery`]: exact ray hits and overlap on one mesh's triangles.
//! - [`BruteForceIndex`] and [`BruteForceMesh`]: flat lists answering every query by testing
//!   everything, the oracles of the conformance suite (`crates/spatial_accel/tests/conformance`),
//!   which every structure runs; [`KeyedList`], a flat list found by the caller's keys, for
//!   objects that move every frame.

mod brute_force;
mod brute_force_mesh;
mod dynamic_index;
mod flat_loops;
mod handle;
mod index_advisor;
mod index_choice;
mod keyed_chunks;
mod keyed_list;
mod nodes;
pub mod ray_walk;
mod stack;
mod tree;
mod triangle_query;
pub mod views;
mod volume;
pub mod walks;

pub use brute_force::{BruteForceIndex, FlatHandle};
pub use brute_force_mesh::BruteForceMesh;
pub(crate) use brute_force_mesh::mesh_triangles;
pub use dynamic_index::{DynamicIndex, IndexError, IndexStats, UpkeepReport};
pub use handle::Handle;
pub use index_advisor::{IndexAdvice, IndexAdvisor, IndexWorkload};
pub use index_choice::{AnyHandle, AnyIndex, IndexKind};
pub use keyed_chunks::CHUNK_LEN;
pub use keyed_list::{ConcurrentMoves, KeyedChunk, KeyedEntry, KeyedList};
pub use nodes::{NodeView, visit_tree_nodes};
pub(crate) use nodes::{count as node_entry_count, visit_levels};
pub use ray_walk::RayWalk;
pub(crate) use stack::TraversalStack;
pub use tree::{BoundingTree, Subtree};
pub use triangle_query::TriangleQuery;
pub use volume::NodeVolume;
pub use walks::sort_hits;

use crate::{Aabb, Containment, Frustum, Ray, Sphere};
use core::ops::ControlFlow;
use glam::Vec3A;

/// The closest primitive a ray query found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayHit {
    /// The primitive id (the caller's index).
    pub primitive: u32,
    /// The ray parameter of the hit.
    pub t: f32,
}

/// Queries every spatial structure answers.
///
/// Primitive ids are the caller's: the index of the primitive in the build input, or the id it
/// was inserted with. Callbacks receive candidates whose bounds pass the query; they decide.
///
/// **Duplicates.** Each query reports a primitive at most once, whatever the structure: one
/// that stores a primitive in several cells (a grid) removes the repeats itself, so callers
/// never need to. The one exception is a caller who inserted the same id twice (two entries
/// with one id are two primitives to the structure).
///
/// ```
/// use spatial_accel::{Aabb, Bvh, BuildConfig, Ray, SpatialQuery};
/// use glam::Vec3A;
/// let boxes: Vec<Aabb> = (0..100)
///     .map(|i| Aabb::new(Vec3A::new(i as f32, 0.0, 0.0), Vec3A::new(i as f32 + 0.5, 1.0, 1.0)))
///     .collect();
/// let bvh = Bvh::build(&boxes, &BuildConfig::default());
/// let ray = Ray::new(Vec3A::new(-1.0, 0.5, 0.5), Vec3A::X);
/// // The callback runs the exact test; here the primitives are the boxes themselves.
/// let hit = bvh.cast_ray(&ray, |i, ray| ray.intersect_aabb(&boxes[i as usize])).unwrap();
/// // The entry distance is conservative: a few ulps short of the exact 1.0.
/// assert_eq!(hit.primitive, 0);
/// assert!((hit.t - 1.0).abs() < 1e-5);
/// ```
///
/// A structure implements [`RayWalk`] (how it visits what a ray reaches) and gets the three ray
/// queries from it, so their acceptance rules are the same everywhere.
pub trait SpatialQuery: RayWalk {
    /// The closest hit: `hit(primitive, ray)` returns the exact hit parameter, if any, within
    /// the ray's (shrinking) range. Subtrees farther than the best hit so far are skipped.
    fn cast_ray<F>(&self, ray: &Ray, hit: F) -> Option<RayHit>
    where
        F: FnMut(u32, &Ray) -> Option<f32>,
    {
        ray_walk::closest_hit(self, ray, hit)
    }

    /// Any hit (occlusion): stops at the first primitive for which `hit` returns true.
    fn cast_ray_any<F>(&self, ray: &Ray, hit: F) -> Option<u32>
    where
        F: FnMut(u32, &Ray) -> bool,
    {
        ray_walk::any_hit(self, ray, hit)
    }

    /// Every hit within the ray's range, appended to `out` sorted by `t` (ties by id).
    fn cast_ray_all<F>(&self, ray: &Ray, hit: F, out: &mut Vec<RayHit>)
    where
        F: FnMut(u32, &Ray) -> Option<f32>,
    {
        ray_walk::all_hits(self, ray, hit, out)
    }

    /// Calls `visit` for each primitive whose tree bounds overlap `aabb`; it may stop early.
    fn for_each_overlapping_aabb<F>(&self, aabb: &Aabb, visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>;

    /// Calls `visit` for each primitive whose tree bounds overlap the sphere.
    fn for_each_overlapping_sphere<F>(&self, sphere: &Sphere, visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>;

    /// Calls `visit` for each primitive whose tree bounds contain the point.
    fn for_each_containing_point<F>(&self, point: Vec3A, visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>;

    /// Calls `visit(primitive, containment)` for each primitive whose tree bounds are not
    /// outside the frustum. `Containment::Inside` means a whole subtree was accepted at once:
    /// the primitive is certainly inside and needs no test. `Intersecting` means its leaf
    /// crossed a plane and the caller should test it exactly.
    fn for_each_in_frustum<F>(&self, frustum: &Frustum, visit: F)
    where
        F: FnMut(u32, Containment);

    /// Walks several views at once (up to 32, one bit each in `views`), calling
    /// `visit(primitive, masks)` once for each primitive that some view reaches, with the views
    /// that hold its bounds wholly and those that cross them. `classify(bounds, undecided)`
    /// says how a node's bounds stand with the views still undecided above it; it must be
    /// monotone (see [`views::for_each_in_views`], the walk of every [`BoundingTree`]).
    fn for_each_in_views<C, F>(&self, views: u32, classify: C, visit: F)
    where
        C: FnMut(&Aabb, u32) -> views::ViewClassification,
        F: FnMut(u32, views::ViewMasks);

    /// The `k` primitives nearest to `point`, nearest first, as `(id, squared distance)`.
    /// `distance_squared(id)` is the exact squared distance of a primitive; subtrees whose box
    /// is farther than the k-th best so far are skipped. Ties are broken by id.
    fn nearest_k<F>(&self, point: Vec3A, k: usize, distance_squared: F) -> Vec<(u32, f32)>
    where
        F: FnMut(u32) -> f32;
}
