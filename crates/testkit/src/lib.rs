//! # accel_testkit
//!
//! The inputs that the tests, benchmarks and examples of `spatial_accel` and `bevy_accel` share,
//! each written once:
//!
//! - [`Rng`]: a seeded generator (PCG32) with the draws the tests use: bits, floats in
//!   `[0, 1)`, ranges, indices, points in a box and directions.
//! - [`boxes`]: random box scenes: uniform, clustered, degenerate (adversarial) and the
//!   benchmarks' mixed entity cloud.
//! - [`Mesh`] and [`shapes`]: an indexed triangle mesh with the checks the watertightness
//!   tests need (closedness, winding number, distance to the surface), and the meshes made
//!   from nothing: cube, icosphere, UV sphere and random triangle soups.
//! - [`mod@bunny`]: the Stanford bunny, read from the repository's `assets/bunny.obj`, and the
//!   small OBJ reader that reads it.
//! - [`mod@triangle_scene`]: the benchmarks' ~1M-triangle scene of bunny copies.
//! - [`dynamic_workload`]: the dynamic-tree workload of the bench tool's dynamic BVH rows and
//!   of its parry peer.
//! - [`skinned`]: a procedural skinned character (a 15-joint humanoid of tubes, 2k to 20k
//!   triangles) as plain data, its walk cycle, CPU forward kinematics and skinning, and its
//!   binary glTF form, which the `animated` example loads from `assets/character.glb`.
//! - [`glb`]: the small binary glTF writer behind the generated assets.
//! - [`screen_oracle`]: the selection oracles' clipping and screen-rectangle tests, in f64.
//! - `bevy_apps` (feature `bevy`): the plain headless Bevy app of the plugin's tests and
//!   benches (to which they add the plugin), the culling scenes' grid, and (feature `lights`)
//!   bevy_light in that app.
//!
//! Two binaries regenerate the examples' assets: `bunny_glb` writes `assets/bunny.glb` from
//! the bunny, and `character_glb` writes `assets/character.glb` from [`skinned`]
//! (`cargo run -p accel_testkit --bin character_glb [-- TRIANGLES]`).
//!
//! Everything is deterministic: the same seed gives the same scene on every machine, so a
//! failing case is reproduced by its seed alone.
//!
//! Types from `spatial_accel` (`Aabb`, `Triangle`) are those of the `spatial_accel` library crate. A unit test
//! inside `spatial_accel` is compiled with a second copy of that crate, whose types differ; it can use
//! the items here that return plain numbers and glam types ([`Rng`], [`Mesh`], [`shapes`]).
#![warn(missing_docs)]

#[cfg(feature = "bevy")]
pub mod bevy_apps;
pub mod boxes;
pub mod bunny;
pub mod dynamic_workload;
pub mod glb;
mod mesh;
mod rng;
pub mod screen_oracle;
pub mod shapes;
pub mod skinned;
pub mod triangle_scene;

pub use boxes::{
    BoxScene, ENTITY_EXTENT, box_scene, clustered_boxes, degenerate_boxes, entity_boxes,
    random_box, uniform_boxes,
};
pub use bunny::{bunny, bunny_path, load_obj};
pub use mesh::{Mesh, closest_point_on_triangle};
pub use rng::Rng;
pub use triangle_scene::{
    InstancedTriangles, TRI_EXTENT, instanced_triangle_scene, triangle_scene,
};
