//! Triangle meshes (the bottom level) and scenes of mesh instances (the top level).
//!
//! - [`MeshBvh`]: a 16-wide BVH over one mesh's indexed triangles, with the watertight test,
//!   built over pre-split triangles or with spatial splits ([`SpatialSplits`]); it also
//!   answers box selection by touching ([`MeshBvh::any_triangle_in_frustum`]).
//! - [`MeshHit`]: where a ray met a mesh, with interpolation of vertex attributes.
//! - [`TraversalCost`]: the work of one ray's walk, counted by a separate walk
//!   ([`MeshBvh::cast_ray_counted`], [`InstancedScene::cast_ray_counted`]) for heat maps.
//! - [`InstancedScene`]: instances of shared meshes under transforms, under a top-level BVH,
//!   updated in place as instances move ([`InstancedScene::update_instances`]).
//! - Skinned and morphed meshes, picked where they are drawn: [`skin_positions`] and
//!   [`morph_positions`] pose a mesh's vertices as Bevy's vertex shader does (from
//!   [`SkinnedVertices`], [`MorphTargets`] and the skin's [`joint_matrices`]), failing with a
//!   [`SkinningError`]; [`PosedMeshBvh`] is a tree over the posed vertices that each pose
//!   refits (and rebuilds once refits have loosened it); [`SkinBounds`] bounds a pose from
//!   the joints alone, for a broad phase that skins only the meshes a ray may hit.

mod counted;
mod frustum_query;
mod hit;
mod leaf_merge;
mod mesh_bvh;
mod packets;
mod posed;
mod presplit;
mod sbvh;
mod sbvh_spatial;
mod scene;
mod scene_update;
mod skin_bounds;
mod skin_segments;
mod skinning;

pub use counted::{CountedHit, TraversalCost};
pub use hit::MeshHit;
pub use mesh_bvh::{MeshBvh, MeshError};
pub use posed::PosedMeshBvh;
pub use sbvh::SpatialSplits;
pub use scene::{Instance, InstanceHit, InstancedScene};
pub(crate) use scene::{instance_world_box, is_placeable};
pub use scene_update::SceneUpdateError;
pub use skin_bounds::SkinBounds;
pub use skin_segments::SkinSegments;
pub use skinning::{
    MorphTargets, SkinnedVertices, SkinningError, SkinningInput, joint_matrices, morph_positions,
    skin_positions,
};
