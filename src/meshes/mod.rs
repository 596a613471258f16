//! What rays need of the world's meshes, beside the trees: a triangle BVH per mesh asset
//! ([`AccelMeshCache`]), each tree slot's mesh ([`SlotMeshTable`]), and each skinned
//! entity's posed triangles ([`AccelPosedMeshes`]). Picking reads both;
//! so will the ray-traced preview.
//!
//! Compiled with the cargo feature `picking` for now: the cache needs bevy_mesh, and the
//! table follows bevy_picking's `SimplifiedMesh` and `RayCastBackfaces` (which mesh a ray
//! tests, and whether its back faces count) and is kept by the rule of
//! [`AccelPickingSettings`](crate::picking::AccelPickingSettings). A second user needs a
//! feature that brings in the same.

mod cache;
mod posed;
mod slot_table;

pub(crate) use cache::invalidate_changed_meshes;
pub use cache::{AccelMeshCache, CachedMesh, MeshShape};
pub use posed::{AccelPosedMeshes, SkinnedShape};
pub(crate) use posed::{PosedState, Posing, SkinInputs, forget_unposed};
pub(crate) use slot_table::{
    PendingSlotMeshes, SlotMeshLookup, add_slot_mesh_observers, keep_slot_mesh_table,
    ray_cast_mesh, slot_mesh_table_in_use,
};
pub use slot_table::{SlotMeshTable, SlotMeshTableMode};
