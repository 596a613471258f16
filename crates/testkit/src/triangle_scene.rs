//! The benchmarks' triangle scene: about a million triangles as copies of the bunny, small and
//! detailed, among large random triangles.

use crate::{Rng, bunny};
use glam::{Mat4, Quat, Vec3, Vec3A};
use spatial_accel::{Aabb, Triangle};

/// Half the side of the cube the triangle scene lives in.
pub const TRI_EXTENT: f32 = 100.0;

/// [`triangle_scene`] before its copies are placed: one bunny, the transform of each copy and
/// the large triangles, for two-level scenes (the same triangles as `triangle_scene` once
/// flattened, to the bit).
pub struct InstancedTriangles {
    /// The bunny, centred on the origin.
    pub mesh: Vec<Triangle>,
    /// Each copy's world-from-local transform.
    pub placements: Vec<Mat4>,
    /// The large triangles, in world space.
    pub loose: Vec<Triangle>,
}

impl InstancedTriangles {
    /// Every copy's triangles in world space, then the large triangles.
    pub fn flatten(&self) -> Vec<Triangle> {
        let mut tris =
            Vec::with_capacity(self.placements.len() * self.mesh.len() + self.loose.len());
        for m in &self.placements {
            let place = |v: Vec3A| Vec3A::from(m.transform_point3(v.into()));
            tris.extend(self.mesh.iter().map(|t| {
                let [a, b, c] = t.vertices;
                Triangle::new(place(a), place(b), place(c))
            }));
        }
        tris.extend_from_slice(&self.loose);
        tris
    }
}

/// About `target` triangles: randomly placed, rotated and scaled copies of the bunny (each about
/// 3 to 12 units across) in a cube of side 200, the remainder as large random triangles (10 to 60
/// units), the mix of small detailed and large simple geometry that real scenes have.
pub fn triangle_scene(target: usize, seed: u64) -> Vec<Triangle> {
    instanced_triangle_scene(target, seed).flatten()
}

/// The parts of [`triangle_scene`]`(target, seed)`.
pub fn instanced_triangle_scene(target: usize, seed: u64) -> InstancedTriangles {
    let bunny = bunny().to_triangles();
    let b = bunny
        .iter()
        .fold(Aabb::EMPTY, |acc, t| acc.union(&t.aabb()));
    let (center, size) = (b.center(), b.extent().max_element());
    let mesh: Vec<Triangle> = bunny
        .iter()
        .map(|t| {
            let [a, b, c] = t.vertices;
            Triangle::new(a - center, b - center, c - center)
        })
        .collect();
    let copies = target.saturating_sub(target / 100) / mesh.len();
    let mut rng = Rng::new(seed);
    let placements = (0..copies)
        .map(|_| {
            let scale = rng.range(3.0, 12.0) / size;
            let rot = Quat::from_axis_angle(
                rng.unit_vector().into(),
                rng.range(0.0, core::f32::consts::TAU),
            );
            let at = rng.vec3(-TRI_EXTENT * 0.95, TRI_EXTENT * 0.95);
            Mat4::from_scale_rotation_translation(Vec3::splat(scale), rot, at)
        })
        .collect();
    let mut loose = Vec::with_capacity(target.saturating_sub(copies * mesh.len()));
    while copies * mesh.len() + loose.len() < target {
        let c = rng.vec3a(-TRI_EXTENT, TRI_EXTENT);
        let r = rng.range(5.0, 30.0);
        loose.push(Triangle::new(
            c + rng.unit_vector() * r,
            c + rng.unit_vector() * r,
            c + rng.unit_vector() * r,
        ));
    }
    InstancedTriangles {
        mesh,
        placements,
        loose,
    }
}
