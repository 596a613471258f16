//! # spatial_accel
//!
//! Acceleration data structures and robust geometry, engine-independent (glam only).
//!
//! - [`geometry`]: [`Aabb`], [`Sphere`], [`Ray`], [`Frustum`], [`Triangle`] and the tests between
//!   them: a conservative slab test (no ray slips between boxes), a numerically stable
//!   ray/sphere quadratic, the watertight ray/triangle test, and three-way frustum
//!   classification. Box selection: the frustum of a rectangle on the screen
//!   ([`Frustum::from_clip_rect`]) and the tests a [`SelectionMode`] names (centre, enclosed,
//!   and touching by an exact triangle test, [`Frustum::touches_triangle`]).
//!
//! - [`bsp`]: the polygon-aligned BSP tree over one mesh's triangles (painter's orders from
//!   any eye point, robust cuts that share their points, exact ray queries).
//! - [`bvh`]: the static BVH with every textbook build choice (midpoint, median, binned and
//!   sweep SAH top-down, LBVH, PLOC bottom-up; leaf size, depth and cost stopping rules), and
//!   its 4-, 8- and 16-wide SIMD forms.
//! - [`dynamic`]: the dynamic BVH (insert, remove and update by handle, batched refit, SAH
//!   insertion with rotations, incremental optimisation, rebuilds) and the static/dynamic pair.
//! - [`grid`]: the uniform grid over moving boxes (a hashed sparse grid, cell size from the
//!   entries' density, rays by 3D DDA, each entry reported once per query without shared state).
//! - [`kdtree`]: the SAH kd-tree over one mesh's triangles (Wald and Havran's O(N log N) event
//!   sweep, perfect splits, the empty-space bonus; rays front to back with the watertight
//!   test).
//! - [`mesh`]: the 16-wide BVH over one mesh's triangles (pre-split or spatial-split builds,
//!   4-wide triangle packets, refit to new poses), the two-level scene of mesh instances,
//!   updated in place as they move, and skinned and morphed meshes posed on the CPU as Bevy's
//!   vertex shader poses them, under a tree refit to each pose.
//! - [`octree`]: the loose octree and quadtree over moving boxes (an object at the depth its
//!   size gives, O(depth) edits, a move inside its loose cell one box write).
//! - [`prefetch`]: cache prefetch hints for reads at scattered addresses known ahead (the
//!   next nodes of a tree walk, the next items' slots).
//! - [`preview`]: a progressive CPU ray-traced preview (shaded, ambient occlusion, path
//!   traced, and views of normals, depth, ids and traversal cost) over any scene.
//! - [`query`]: the [`SpatialQuery`] interface every structure answers (closest, any and all
//!   ray hits; box, sphere and point overlap; frustum; k nearest), the
//!   [`DynamicIndex`](query::DynamicIndex) interface of the indexes over moving boxes and the
//!   generational [`Handle`](query::Handle) they name entries by.
//!
//! Every test is NaN-safe: a NaN ray is a miss, a NaN box reports itself invalid, and nothing
//! panics on non-finite input.
#![warn(missing_docs)]

pub mod bsp;
pub mod bvh;
pub mod dynamic;
pub mod geometry;
pub mod grid;
pub mod kdtree;
pub mod mesh;
pub mod octree;
pub mod prefetch;
pub mod preview;
pub mod query;
pub mod sort;

pub use bvh::{BuildConfig, Bvh, SahCosts, SplitStrategy};
pub use dynamic::{DynamicBvh, DynamicBvhConfig, LeafHandle};
pub use geometry::*;
pub use grid::{GridConfig, GridHandle, UniformGrid};
pub use kdtree::{KdBuild, KdTree, KdTreeConfig};
pub use octree::{LooseOctree, OctreeConfig, OctreeHandle, Quadtree};
pub use query::{BoundingTree, NodeVolume, RayHit, SpatialQuery};

/// A seeded stream of floats in `[0, 1)` for the unit tests: the test kit's generator, so
/// that the crate's tests and benches draw from one.
#[cfg(test)]
pub(crate) fn test_floats(seed: u64) -> impl FnMut() -> f32 {
    let mut rng = accel_testkit::Rng::new(seed);
    move || rng.f32()
}
