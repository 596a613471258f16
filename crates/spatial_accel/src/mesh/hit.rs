//! The record of a ray/mesh hit.

use glam::{Vec2, Vec3, Vec3A};

/// Where a ray met a mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshHit {
    /// Ray parameter of the hit (in the units of the ray that was cast).
    pub t: f32,
    /// Index of the triangle in the mesh's index buffer (triangle `i` uses indices
    /// `3i..3i + 3`).
    pub triangle: u32,
    /// Barycentric weights of the triangle's three vertices, in index order.
    pub barycentrics: [f32; 3],
    /// Unit geometric normal of the triangle's front face (counter-clockwise winding), in the
    /// mesh's space.
    pub geometric_normal: Vec3A,
    /// True when the ray met the front face.
    pub front_face: bool,
}

impl MeshHit {
    /// Interpolates a per-vertex attribute at the hit with the barycentric weights.
    #[inline]
    pub fn interpolate<T>(&self, indices: [u32; 3], attribute: &[T]) -> T
    where
        T: Copy + core::ops::Mul<f32, Output = T> + core::ops::Add<Output = T>,
    {
        let [a, b, c] = indices.map(|i| attribute[i as usize]);
        let [wa, wb, wc] = self.barycentrics;
        a * wa + b * wb + c * wc
    }

    /// The interpolated, normalised vertex normal (falls back to the geometric normal when
    /// the interpolation cancels out).
    pub fn interpolated_normal(&self, indices: [u32; 3], normals: &[Vec3]) -> Vec3 {
        self.interpolate(indices, normals)
            .try_normalize()
            .unwrap_or(self.geometric_normal.into())
    }

    /// The interpolated texture coordinate.
    pub fn interpolated_uv(&self, indices: [u32; 3], uvs: &[Vec2]) -> Vec2 {
        self.interpolate(indices, uvs)
    }
}
