//! Triangle meshes (the bottom level) and scenes of mesh instances (the top level).
//!
//! - [`MeshBvh`]: a 16-wide BVH over one mesh's indexed triangles, with the watertight test.
//! - [`MeshHit`]: where a ray met a mesh, with interpolation of vertex attributes.
//! - [`InstancedScene`]: instances of shared meshes under transforms, under a top-level BVH,
//!   updated in place as instances move ([`InstancedScene::update_instances`]).

mod hit;
mod leaf_merge;
mod mesh_bvh;
mod packets;
mod presplit;
mod sbvh;
mod sbvh_spatial;
mod scene;
mod scene_update;

pub use hit::MeshHit;
pub use mesh_bvh::{MeshBvh, MeshError};
pub use sbvh::SpatialSplits;
pub use scene::{Instance, InstanceHit, InstancedScene};
pub use scene_update::SceneUpdateError;
