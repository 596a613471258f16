//! The four kinds of rays of BENCHMARKS.md's "Rays on meshes", each prepared once in every
//! crate's own ray type, so that no contender's timing includes converting rays (each type
//! precomputes its reciprocal direction at construction).

use crate::suites::{camera_rays, incoherent_rays};
use accel_testkit::{Rng, TRI_EXTENT};
use glam::Vec3A;
use spatial_accel::mesh::MeshBvh;
use spatial_accel::{Backfaces, Ray};

/// One kind of ray, in our type and the peers'.
pub struct RaySet {
    /// Its row's name.
    pub name: &'static str,
    /// Any hit (shadow rays) instead of the closest.
    pub any_hit: bool,
    /// Our rays.
    pub ours: Vec<Ray>,
    /// The same rays for obvhs.
    pub obvhs: Vec<obvhs::ray::Ray>,
    /// The same rays for the `bvh` crate (which has no range: the tracer applies `t_max`).
    pub bvh: Vec<bvh::ray::Ray<f32, 3>>,
}

impl RaySet {
    fn new(name: &'static str, any_hit: bool, ours: Vec<Ray>) -> Self {
        let obvhs = ours
            .iter()
            .map(|r| obvhs::ray::Ray::new(r.origin, r.direction, r.t_min, r.t_max))
            .collect();
        let bvh = ours
            .iter()
            .map(|r| {
                bvh::ray::Ray::new(
                    nalgebra::Point3::new(r.origin.x, r.origin.y, r.origin.z),
                    nalgebra::Vector3::new(r.direction.x, r.direction.y, r.direction.z),
                )
            })
            .collect();
        Self {
            name,
            any_hit,
            ours,
            obvhs,
            bvh,
        }
    }

    /// The rays as tinybvh's peer reads them: origin, unit direction, `t_max`.
    pub fn for_peer(&self) -> Vec<(Vec3A, Vec3A, f32)> {
        self.ours
            .iter()
            .map(|r| (r.origin, r.direction, r.t_max))
            .collect()
    }
}

/// The primary hits of `primary` in `mesh`: the point, and the geometric normal turned to
/// the side the ray came from. Rays that miss are skipped.
fn surfaces(primary: &[Ray], mesh: &MeshBvh) -> Vec<(Vec3A, Vec3A, Vec3A)> {
    primary
        .iter()
        .filter_map(|r| {
            let hit = mesh.cast_ray(r, Backfaces::Include)?;
            let n = hit.geometric_normal;
            let n = if n.dot(r.direction) > 0.0 { -n } else { n };
            Some((r.origin, r.at(hit.t), n))
        })
        .collect()
}

/// From each primary hit (moved back 1e-3 along the primary ray) towards a point light above
/// the scene, limited to the light's distance; the hits are cycled to make `n` rays.
fn shadow(hits: &[(Vec3A, Vec3A, Vec3A)], n: usize) -> Vec<Ray> {
    let light = Vec3A::new(0.3, 4.0, 0.2) * TRI_EXTENT;
    (0..n)
        .map(|i| {
            let (o, p, _) = hits[i % hits.len()];
            let p = p - (p - o).normalize() * 1e-3;
            let to_light = light - p;
            Ray::with_range(p, to_light.normalize(), 0.0, to_light.length())
        })
        .collect()
}

/// One bounce from each primary hit (moved off the surface by 1e-3 along its normal): a
/// cosine-weighted direction about the normal (Malley's method: uniform on the disc, lifted
/// to the hemisphere), the secondary rays of a path tracer; cycled to make `n` rays.
fn diffuse(hits: &[(Vec3A, Vec3A, Vec3A)], n: usize) -> Vec<Ray> {
    let mut rng = Rng::new(0x2545_f491_4f6c_dd1d);
    (0..n)
        .map(|i| {
            let (_, p, normal) = hits[i % hits.len()];
            let tangent = if normal.x.abs() > 0.9 {
                Vec3A::Y
            } else {
                Vec3A::X
            }
            .cross(normal)
            .normalize();
            let bitangent = normal.cross(tangent);
            let (r, phi) = (rng.f32().sqrt(), std::f32::consts::TAU * rng.f32());
            let lift = (1.0 - r * r).max(0.0).sqrt();
            let d = tangent * (r * phi.cos()) + bitangent * (r * phi.sin()) + normal * lift;
            Ray::new(p + normal * 1e-3, d.normalize())
        })
        .collect()
}

/// The four kinds, `n` rays each: primary (a pinhole camera's pixel grid in scanline order
/// from outside the scene cube, closest hit), shadow (any hit), diffuse (closest hit) and
/// incoherent (origins uniform in the scene cube, directions uniform; closest hit). `mesh`
/// finds the primary hits the secondary rays start from.
pub fn ray_sets(n: usize, mesh: &MeshBvh) -> Vec<RaySet> {
    let primary = camera_rays(n, Vec3A::new(0.0, 0.5, 2.5) * TRI_EXTENT);
    let hits = surfaces(&primary, mesh);
    assert!(!hits.is_empty(), "the camera sees the scene");
    vec![
        RaySet::new("primary", false, primary),
        RaySet::new("shadow", true, shadow(&hits, n)),
        RaySet::new("diffuse", false, diffuse(&hits, n)),
        RaySet::new("incoherent", false, incoherent_rays(n, TRI_EXTENT, 3)),
    ]
}
