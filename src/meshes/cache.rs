//! Per-mesh triangle BVHs, built the first time a ray reaches a mesh and kept until the mesh
//! asset changes.
//!
//! Bevy's `MeshRayCast` scans every triangle of every candidate mesh on every ray. Here each
//! mesh asset gets one [`MeshBvh`] (shared by every entity that uses the asset), so a ray costs
//! a tree descent instead. Building is lazy: a scene with 10^5 meshes that rays never reach
//! builds nothing.

use bevy::asset::AssetId;
use bevy::mesh::{Indices, PrimitiveTopology, VertexAttributeValues};
use bevy::platform::collections::{HashMap, HashSet};
use bevy::prelude::*;
use spatial_accel::mesh::MeshBvh;
use std::sync::{Arc, PoisonError, RwLock};

/// One mesh asset's triangles, ready for exact ray casts in the mesh's own space.
#[derive(Debug)]
pub struct CachedMesh {
    /// The BVH over the triangles (triangle `i` is indices `3i..3i + 3`, as in the asset).
    pub bvh: MeshBvh,
    /// Vertex positions, as in the asset.
    pub positions: Vec<Vec3>,
    /// The triangle list's vertex indices (for non-indexed meshes, `0..n`).
    pub indices: Vec<u32>,
    /// Vertex normals, when the asset has `Float32x3` normals.
    pub normals: Option<Vec<Vec3>>,
    /// First texture coordinates, when the asset has `Float32x2` ones.
    pub uvs: Option<Vec<Vec2>>,
}

impl CachedMesh {
    /// Reads the triangles of a mesh asset; `Err` says why the mesh cannot be ray cast
    /// exactly (rays then hit its bounds).
    pub fn from_mesh(mesh: &Mesh) -> Result<Self, String> {
        const RENDER_WORLD_ONLY: &str = "has its vertex data in the render world only \
            (its RenderAssetUsages lack MAIN_WORLD)";
        if mesh.primitive_topology() != PrimitiveTopology::TriangleList {
            return Err(format!(
                "is a {:?} mesh, not a triangle list",
                mesh.primitive_topology()
            ));
        }
        let positions: Vec<Vec3> = match mesh.try_attribute_option(Mesh::ATTRIBUTE_POSITION) {
            Err(_) => return Err(RENDER_WORLD_ONLY.into()),
            Ok(None) => return Err("has no vertex positions".into()),
            Ok(Some(values)) => match values.as_float3() {
                Some(p) => p.iter().copied().map(Vec3::from).collect(),
                None => return Err("has positions that are not Float32x3".into()),
            },
        };
        let mut indices: Vec<u32> = match mesh.try_indices_option() {
            Err(_) => return Err(RENDER_WORLD_ONLY.into()),
            Ok(Some(Indices::U16(i))) => i.iter().map(|&i| u32::from(i)).collect(),
            Ok(Some(Indices::U32(i))) => i.clone(),
            // Bevy reads a non-indexed list in whole triangles and ignores a trailing remainder.
            Ok(None) => (0..(positions.len() / 3 * 3) as u32).collect(),
        };
        let collapsed = collapse_triangles_out_of_range(&mut indices, positions.len());
        if collapsed > 0 {
            warn!(
                "bevy_accel picking: {collapsed} triangles of a mesh name vertices it does not \
                 have; rays skip them, as Bevy's do"
            );
        }
        let bvh = MeshBvh::new(&positions, &indices).map_err(|e| format!("is malformed: {e}"))?;
        let normals = mesh
            .try_attribute_option(Mesh::ATTRIBUTE_NORMAL)
            .ok()
            .flatten()
            .and_then(VertexAttributeValues::as_float3)
            .map(|n| n.iter().copied().map(Vec3::from).collect());
        let uvs = match mesh.try_attribute_option(Mesh::ATTRIBUTE_UV_0) {
            Ok(Some(VertexAttributeValues::Float32x2(uvs))) => {
                Some(uvs.iter().copied().map(Vec2::from).collect())
            }
            _ => None,
        };
        Ok(Self {
            bvh,
            positions,
            indices,
            normals,
            uvs,
        })
    }

    /// The vertex indices of triangle `triangle`.
    #[inline]
    pub fn triangle_indices(&self, triangle: u32) -> [u32; 3] {
        let i = 3 * triangle as usize;
        [self.indices[i], self.indices[i + 1], self.indices[i + 2]]
    }
}

/// Makes every triangle that names a vertex past `vertex_count` a point at vertex 0, which no
/// ray hits (the watertight test rejects a zero determinant). Why: Bevy's ray cast skips such a
/// triangle and keeps the rest of the mesh, and numbers hits by their place in the index list;
/// a zero-area stand-in keeps both, where a build error would lose the whole mesh to its
/// bounds. Returns how many triangles were collapsed. A count that is not a multiple of three
/// is left for the build to refuse (Bevy skips such a mesh whole).
fn collapse_triangles_out_of_range(indices: &mut [u32], vertex_count: usize) -> usize {
    if vertex_count == 0 || !indices.len().is_multiple_of(3) {
        return 0;
    }
    let mut collapsed = 0;
    for triangle in indices.chunks_exact_mut(3) {
        if triangle.iter().any(|&i| i as usize >= vertex_count) {
            triangle.fill(0);
            collapsed += 1;
        }
    }
    collapsed
}

/// What a ray is tested against for one mesh asset.
#[derive(Clone, Debug)]
pub enum MeshShape {
    /// The mesh's triangles.
    Triangles(Arc<CachedMesh>),
    /// The entity's `Aabb`: the mesh cannot be read (not a triangle list, render-world only,
    /// malformed). A warning was logged once for the asset.
    Bounds,
}

/// The per-asset cache of mesh BVHs behind [`AccelRayCast`](crate::picking::AccelRayCast).
///
/// The map sits behind a lock so that ray casts, which only read the world, can fill it from
/// a shared `Res` and systems using the ray cast stay free to run in parallel. Entries are
/// dropped when Bevy reports the asset modified or removed (in `PostUpdate`, after
/// `AssetEventSystems`), so a mesh edited this frame is seen by ray casts from the next one.
#[derive(Resource, Default)]
pub struct AccelMeshCache {
    entries: RwLock<HashMap<AssetId<Mesh>, MeshShape>>,
    /// Counts [`Self::invalidate`] and [`Self::clear`] calls, so that copies of shapes held
    /// elsewhere (the [`SlotMeshTable`](super::SlotMeshTable)'s) know to drop theirs.
    generation: u64,
}

impl AccelMeshCache {
    /// The shape of a mesh asset, built and cached on first use; `None` when the asset is not
    /// (yet) in `meshes`, like Bevy, which skips meshes whose handle does not resolve.
    pub fn get_or_build(&self, id: AssetId<Mesh>, meshes: &Assets<Mesh>) -> Option<MeshShape> {
        if let Some(shape) = self
            .entries
            .read()
            .unwrap_or_else(PoisonError::into_inner)
            .get(&id)
        {
            return Some(shape.clone());
        }
        let mesh = meshes.get(id)?;
        let shape = match CachedMesh::from_mesh(mesh) {
            Ok(cached) => MeshShape::Triangles(Arc::new(cached)),
            Err(reason) => {
                // Logged once per asset version: the entry stays until the asset changes.
                warn!("bevy_accel picking: mesh {id:?} {reason}; rays hit its bounds instead");
                MeshShape::Bounds
            }
        };
        let mut entries = self.entries.write().unwrap_or_else(PoisonError::into_inner);
        // Another system may have built it meanwhile; keep the first so Arcs stay shared.
        Some(entries.entry(id).or_insert(shape).clone())
    }

    /// Drops the cached shape of a mesh asset (it is rebuilt at the next ray that reaches it).
    pub fn invalidate(&mut self, id: AssetId<Mesh>) {
        self.generation += 1;
        self.entries
            .get_mut()
            .unwrap_or_else(PoisonError::into_inner)
            .remove(&id);
    }

    /// Drops every cached shape.
    pub fn clear(&mut self) {
        self.generation += 1;
        self.entries
            .get_mut()
            .unwrap_or_else(PoisonError::into_inner)
            .clear();
    }

    /// How many times entries were dropped ([`Self::invalidate`], [`Self::clear`]).
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// Number of mesh assets with a cached shape.
    pub fn len(&self) -> usize {
        self.entries
            .read()
            .unwrap_or_else(PoisonError::into_inner)
            .len()
    }

    /// True when nothing is cached.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// True when the asset has a cached shape.
    pub fn contains(&self, id: AssetId<Mesh>) -> bool {
        self.entries
            .read()
            .unwrap_or_else(PoisonError::into_inner)
            .contains_key(&id)
    }
}

/// Drops the cache entries of mesh assets that were modified or removed.
pub(crate) fn invalidate_changed_meshes(
    mut events: MessageReader<AssetEvent<Mesh>>,
    mut cache: ResMut<AccelMeshCache>,
    mut table: ResMut<super::SlotMeshTable>,
    posed: Res<super::AccelPosedMeshes>,
) {
    // Collect first: taking `cache` mutably only when something changed keeps its change tick
    // quiet in the common frame where no mesh was edited.
    let stale: HashSet<AssetId<Mesh>> = events
        .read()
        .filter_map(|event| match *event {
            AssetEvent::Modified { id } | AssetEvent::Removed { id } => Some(id),
            _ => None,
        })
        .collect();
    for id in stale {
        posed.forget_mesh(id);
        if cache.contains(id) {
            cache.invalidate(id);
        }
    }
    // Also after `AccelMeshCache::invalidate` or `clear` called by hand. No reader watches the
    // table's change tick, so it is not marked.
    table.bypass_change_detection().follow_cache(&cache);
}
