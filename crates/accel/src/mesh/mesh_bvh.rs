//! The bottom level: an 8-wide BVH over one mesh's triangles.

use super::MeshHit;
use crate::bvh::wide::Bvh8;
use crate::{Aabb, Backfaces, BuildConfig, Bvh, Ray, SpatialQuery, WatertightRay};
use core::fmt;
use core::ops::ControlFlow;
use glam::{Vec3, Vec3A};

/// Why a mesh could not be built or refit.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum MeshError {
    /// The index count is not a multiple of three (only triangle lists are supported).
    NotATriangleList {
        /// The number of indices given.
        index_count: usize,
    },
    /// An index names a vertex that does not exist.
    IndexOutOfRange {
        /// The offending index.
        index: u32,
        /// The number of vertices.
        vertex_count: usize,
    },
    /// A refit was given a different number of vertices than the mesh was built with.
    VertexCountChanged {
        /// Vertices at build time.
        expected: usize,
        /// Vertices given.
        got: usize,
    },
}

impl fmt::Display for MeshError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NotATriangleList { index_count } => {
                write!(
                    f,
                    "{index_count} indices is not a triangle list (not a multiple of 3)"
                )
            }
            Self::IndexOutOfRange {
                index,
                vertex_count,
            } => {
                write!(
                    f,
                    "index {index} is out of range for {vertex_count} vertices"
                )
            }
            Self::VertexCountChanged { expected, got } => {
                write!(f, "refit with {got} vertices, but the mesh has {expected}")
            }
        }
    }
}

impl std::error::Error for MeshError {}

/// An 8-wide BVH over the triangles of one indexed mesh, answering exact (watertight) ray
/// queries in the mesh's own space.
///
/// Triangles are copied into leaf order at build time, so a leaf's triangles sit next to each
/// other in memory and a ray reads them in one sweep instead of chasing the index buffer.
/// Triangles with non-finite corners are left out (they cannot be hit).
///
/// ```
/// use accel::{Backfaces, Ray};
/// use accel::mesh::MeshBvh;
/// use glam::{Vec3, Vec3A};
/// // A unit quad in the z = 0 plane, facing +z.
/// let vertices = [Vec3::new(0., 0., 0.), Vec3::new(1., 0., 0.), Vec3::new(1., 1., 0.), Vec3::new(0., 1., 0.)];
/// let mesh = MeshBvh::new(&vertices, &[0, 1, 2, 0, 2, 3]).unwrap();
/// let ray = Ray::new(Vec3A::new(0.25, 0.75, 5.0), Vec3A::NEG_Z);
/// let hit = mesh.cast_ray(&ray, Backfaces::Cull).unwrap();
/// assert_eq!((hit.t, hit.triangle, hit.front_face), (5.0, 1, true));
/// ```
#[derive(Clone, Debug)]
pub struct MeshBvh {
    tree: Bvh8,
    /// Corners of each triangle, in leaf order.
    triangles: Vec<[Vec3A; 3]>,
    /// Vertex indices of each triangle, in leaf order (for refits).
    indices: Vec<[u32; 3]>,
    /// The caller's triangle index of each leaf-order slot.
    triangle_ids: Vec<u32>,
    vertex_count: usize,
}

impl MeshBvh {
    /// Builds with the default configuration (binned SAH, 8-wide).
    pub fn new(vertices: &[Vec3], indices: &[u32]) -> Result<Self, MeshError> {
        Self::with_config(vertices, indices, &BuildConfig::default())
    }

    /// Builds with a chosen configuration.
    pub fn with_config(
        vertices: &[Vec3],
        indices: &[u32],
        config: &BuildConfig,
    ) -> Result<Self, MeshError> {
        if !indices.len().is_multiple_of(3) {
            return Err(MeshError::NotATriangleList {
                index_count: indices.len(),
            });
        }
        if let Some(&index) = indices.iter().find(|&&i| i as usize >= vertices.len()) {
            return Err(MeshError::IndexOutOfRange {
                index,
                vertex_count: vertices.len(),
            });
        }
        let corners = |t: &[u32]| [0, 1, 2].map(|k| Vec3A::from(vertices[t[k] as usize]));
        let boxes: Vec<Aabb> = indices
            .chunks_exact(3)
            .map(|t| triangle_bounds(&corners(t)))
            .collect();
        let bvh = Bvh::build(&boxes, config);
        let triangle_ids = bvh.primitive_indices().to_vec();
        let triangles = triangle_ids
            .iter()
            .map(|&t| corners(&indices[3 * t as usize..3 * t as usize + 3]))
            .collect();
        let leaf_indices = triangle_ids
            .iter()
            .map(|&t| [0, 1, 2].map(|k| indices[3 * t as usize + k]))
            .collect();
        let mut tree = Bvh8::from_bvh(&bvh);
        // Leaves now name leaf-order slots, so a traversal reads `triangles` sequentially.
        tree.primitive_indices = (0..triangle_ids.len() as u32).collect();
        Ok(Self {
            tree,
            triangles,
            indices: leaf_indices,
            triangle_ids,
            vertex_count: vertices.len(),
        })
    }

    /// The box around the mesh.
    pub fn bounds(&self) -> Aabb {
        self.tree.bounds()
    }

    /// Number of triangles in the tree.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// The tree (its primitive ids are leaf-order slots, see [`MeshBvh::triangle_index`]).
    pub fn tree(&self) -> &Bvh8 {
        &self.tree
    }

    /// The caller's triangle index of a leaf-order slot.
    pub fn triangle_index(&self, slot: u32) -> u32 {
        self.triangle_ids[slot as usize]
    }

    /// Memory held, in bytes.
    pub fn memory_bytes(&self) -> usize {
        self.tree.memory_bytes() + self.triangles.len() * (48 + 12 + 4)
    }

    fn hit_record(&self, slot: u32, hit: crate::TriangleHit) -> MeshHit {
        let [a, b, c] = self.triangles[slot as usize];
        MeshHit {
            t: hit.t,
            triangle: self.triangle_ids[slot as usize],
            barycentrics: hit.barycentrics(),
            geometric_normal: (b - a).cross(c - a).normalize_or_zero(),
            front_face: hit.front_face,
        }
    }

    /// The closest hit along the ray, or `None`.
    pub fn cast_ray(&self, ray: &Ray, backfaces: Backfaces) -> Option<MeshHit> {
        let mut wt = WatertightRay::new(ray);
        let mut best: Option<(u32, crate::TriangleHit)> = None;
        self.tree.cast_ray(ray, |slot, r| {
            let [a, b, c] = self.triangles[slot as usize];
            wt.set_t_max(r.t_max);
            let h = wt.intersect_vertices(a, b, c, backfaces)?;
            if best.is_none_or(|(_, b)| h.t < b.t) {
                best = Some((slot, h));
            }
            Some(h.t)
        })?;
        best.map(|(slot, h)| self.hit_record(slot, h))
    }

    /// True when anything blocks the ray (shadow rays: stops at the first hit found).
    pub fn cast_ray_any(&self, ray: &Ray, backfaces: Backfaces) -> bool {
        let wt = WatertightRay::new(ray);
        self.tree
            .cast_ray_any(ray, |slot, _| {
                let [a, b, c] = self.triangles[slot as usize];
                wt.intersect_vertices(a, b, c, backfaces).is_some()
            })
            .is_some()
    }

    /// Every hit along the ray, nearest first (ties by triangle index), appended to `out`.
    pub fn cast_ray_all(&self, ray: &Ray, backfaces: Backfaces, out: &mut Vec<MeshHit>) {
        let wt = WatertightRay::new(ray);
        let start = out.len();
        // An any-hit traversal that never accepts visits every leaf the ray reaches.
        self.tree.cast_ray_any(ray, |slot, _| {
            let [a, b, c] = self.triangles[slot as usize];
            if let Some(h) = wt.intersect_vertices(a, b, c, backfaces) {
                out.push(self.hit_record(slot, h));
            }
            false
        });
        out[start..].sort_unstable_by(|a, b| a.t.total_cmp(&b.t).then(a.triangle.cmp(&b.triangle)));
    }

    /// The box of a leaf-order slot's triangle; empty when a corner is not finite, so such a
    /// triangle (a NaN in a skinned pose, say) drops out of the tree instead of poisoning it.
    fn triangle_aabb(&self, slot: u32) -> Aabb {
        triangle_bounds(&self.triangles[slot as usize])
    }

    /// Calls `visit(triangle index)` for each triangle whose box overlaps `aabb`.
    pub fn for_each_triangle_overlapping(&self, aabb: &Aabb, mut visit: impl FnMut(u32)) {
        self.tree.for_each_overlapping_aabb(aabb, |slot| {
            if self.triangle_aabb(slot).intersects_aabb(aabb) {
                visit(self.triangle_ids[slot as usize]);
            }
            ControlFlow::Continue(())
        });
    }

    /// Checks the tree against the mesh's current triangles (see [`Bvh8::validate`]).
    pub fn validate(&self) -> Result<(), crate::bvh::validate::ValidationError> {
        let boxes: Vec<Aabb> = (0..self.triangles.len() as u32)
            .map(|s| self.triangle_aabb(s))
            .collect();
        self.tree.validate(&boxes)
    }

    /// Moves the vertices (a skinned or morphed pose) and refits the tree to them, keeping
    /// its topology: fast, but the tree degrades if the pose strays far from the build pose.
    pub fn refit(&mut self, vertices: &[Vec3]) -> Result<(), MeshError> {
        if vertices.len() != self.vertex_count {
            return Err(MeshError::VertexCountChanged {
                expected: self.vertex_count,
                got: vertices.len(),
            });
        }
        for (tri, idx) in self.triangles.iter_mut().zip(&self.indices) {
            *tri = idx.map(|i| Vec3A::from(vertices[i as usize]));
        }
        let triangles = &self.triangles;
        self.tree
            .refit(|slot| triangle_bounds(&triangles[slot as usize]));
        Ok(())
    }
}

fn triangle_bounds(corners: &[Vec3A; 3]) -> Aabb {
    if corners.iter().all(|v| v.is_finite()) {
        Aabb::from_points(*corners)
    } else {
        Aabb::EMPTY
    }
}
