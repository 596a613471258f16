//! Meshes made from nothing: closed solids for the watertightness tests, a UV sphere for the
//! mesh trees, and random triangle soups.

use crate::{Mesh, Rng};
use glam::{DVec3, Vec3A};
use std::collections::HashMap;

/// The cube `[-1, 1]^3` as 8 shared corners and 12 outward triangles.
pub fn cube() -> Mesh {
    let vertices = (0..8)
        .map(|i| {
            let s = |bit: u32| if i & bit == 0 { -1.0 } else { 1.0 };
            Vec3A::new(s(1), s(2), s(4))
        })
        .collect();
    // Corner index = x + 2y + 4z; each face as two counter-clockwise triangles seen from outside.
    let quads = [
        [0, 4, 6, 2], // -x
        [1, 3, 7, 5], // +x
        [0, 1, 5, 4], // -y
        [2, 6, 7, 3], // +y
        [0, 2, 3, 1], // -z
        [4, 5, 7, 6], // +z
    ];
    let indices = quads
        .iter()
        .flat_map(|&[a, b, c, e]| [[a, b, c], [a, c, e]])
        .collect();
    Mesh { vertices, indices }
}

/// The unit icosahedron subdivided `levels` times and pushed onto the unit sphere. Midpoints are
/// shared through an edge cache, so the result is welded and closed (20 * 4^levels triangles).
pub fn icosphere(levels: u32) -> Mesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut verts: Vec<DVec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|&v| DVec3::from(v).normalize())
    .collect();
    let mut faces: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut cache: HashMap<(u32, u32), u32> = HashMap::new();
        let mut mid = |a: u32, b: u32, verts: &mut Vec<DVec3>| {
            *cache.entry((a.min(b), a.max(b))).or_insert_with(|| {
                verts.push(((verts[a as usize] + verts[b as usize]) * 0.5).normalize());
                verts.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(faces.len() * 4);
        for [a, b, c] in faces {
            let (ab, bc, ca) = (
                mid(a, b, &mut verts),
                mid(b, c, &mut verts),
                mid(c, a, &mut verts),
            );
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        faces = next;
    }
    Mesh {
        vertices: verts.iter().map(|v| v.as_vec3a()).collect(),
        indices: faces,
    }
}

/// A UV sphere of `radius` about the origin with shared vertices: `rings + 1` rings of
/// `segments` vertices from pole to pole (each pole a ring of coincident vertices, so the
/// triangles there are degenerate, as in many real meshes), `2 * rings * segments` triangles.
pub fn uv_sphere(rings: u32, segments: u32, radius: f32) -> Mesh {
    let mut vertices = Vec::new();
    for r in 0..=rings {
        let phi = core::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..segments {
            let theta = core::f32::consts::TAU * s as f32 / segments as f32;
            vertices.push(
                Vec3A::new(phi.sin() * theta.cos(), phi.cos(), phi.sin() * theta.sin()) * radius,
            );
        }
    }
    let mut indices = Vec::new();
    for r in 0..rings {
        for s in 0..segments {
            let (a, b) = (r * segments + s, r * segments + (s + 1) % segments);
            let (c, d) = (a + segments, b + segments);
            indices.extend([[a, c, b], [b, c, d]]);
        }
    }
    Mesh { vertices, indices }
}

/// A random triangle soup of `n` unshared triangles: small ones (corners within 0.4 of their
/// centre) scattered in `[-5, 5)^3`, every 50th (from the first) a large one (within 4.0).
pub fn triangle_soup(rng: &mut Rng, n: usize) -> Mesh {
    let mut vertices = Vec::with_capacity(3 * n);
    for i in 0..n {
        let c = rng.vec3a(-5.0, 5.0);
        let size = if i % 50 == 0 { 4.0 } else { 0.4 };
        for _ in 0..3 {
            vertices.push(c + rng.vec3a(-size, size));
        }
    }
    Mesh {
        indices: (0..n as u32)
            .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
            .collect(),
        vertices,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solids_are_closed() {
        cube().check_closed().unwrap();
        let ico = icosphere(2);
        ico.check_closed().unwrap();
        assert_eq!(ico.indices.len(), 320);
        assert!((ico.winding_number(DVec3::ZERO) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn counts() {
        let s = uv_sphere(4, 6, 2.0);
        assert_eq!((s.vertices.len(), s.indices.len()), (30, 48));
        assert!(s.vertices.iter().all(|v| (v.length() - 2.0).abs() < 1e-5));
        let soup = triangle_soup(&mut Rng::new(1), 7);
        assert_eq!(
            (soup.vertices.len(), soup.flat_indices()),
            (21, (0..21).collect())
        );
    }
}
