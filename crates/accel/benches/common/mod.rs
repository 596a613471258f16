//! Deterministic benchmark inputs shared by the BVH benchmarks: entity boxes, a ~1M-triangle
//! scene of bunny copies, incoherent rays and a camera frustum; plus the adapters that let our
//! own statistics (SAH cost, memory) be computed on the peer crates' trees.
#![allow(dead_code)]

pub mod peers;
pub mod tinybvh;

use accel::{Aabb, Frustum, Triangle};
use glam::{Mat4, Quat, Vec3, Vec3A};
use std::path::PathBuf;

/// PCG32: reproducible streams with no dependency.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        let mut r = Rng(seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407));
        r.next_u32();
        r
    }
    pub fn next_u32(&mut self) -> u32 {
        let old = self.0;
        self.0 = old
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }
    /// Uniform in [0, 1).
    pub fn f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }
    pub fn below(&mut self, n: u32) -> u32 {
        ((self.next_u32() as u64 * n as u64) >> 32) as u32
    }
    pub fn vec3(&mut self, lo: f32, hi: f32) -> Vec3A {
        Vec3A::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
    pub fn unit_vector(&mut self) -> Vec3A {
        loop {
            let v = self.vec3(-1.0, 1.0);
            let l = v.length_squared();
            if l > 1e-4 && l <= 1.0 {
                return v / l.sqrt();
            }
        }
    }
}

/// Half the side of the cube the entity boxes live in.
pub const ENTITY_EXTENT: f32 = 500.0;

/// `n` entity boxes: 80% spread uniformly, 20% in 32 dense clusters (crowds, forests), sizes
/// from 0.2 to 4 units.
pub fn entity_boxes(n: usize, seed: u64) -> Vec<Aabb> {
    let mut rng = Rng::new(seed);
    let clusters: Vec<Vec3A> = (0..32)
        .map(|_| rng.vec3(-ENTITY_EXTENT * 0.9, ENTITY_EXTENT * 0.9))
        .collect();
    (0..n)
        .map(|i| {
            let c = if i % 5 == 4 {
                clusters[rng.below(32) as usize] + rng.vec3(-20.0, 20.0)
            } else {
                rng.vec3(-ENTITY_EXTENT, ENTITY_EXTENT)
            };
            Aabb::from_center_half_extents(c, rng.vec3(0.1, 2.0))
        })
        .collect()
}

/// Where the bunny is: `ACCEL_BUNNY_OBJ`, else `shared/models/bunny.obj` found upwards from the
/// crate. Panics (loudly) if it is missing: a benchmark on a stand-in mesh would mislead.
pub fn bunny_path() -> PathBuf {
    if let Ok(p) = std::env::var("ACCEL_BUNNY_OBJ") {
        return PathBuf::from(p);
    }
    let manifest = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    for rel in [
        "../../../shared/models/bunny.obj",
        "../../shared/models/bunny.obj",
        "../shared/models/bunny.obj",
    ] {
        let p = manifest.join(rel);
        if p.is_file() {
            return p;
        }
    }
    panic!(
        "bunny.obj not found: set ACCEL_BUNNY_OBJ or put it at shared/models/bunny.obj \
         beside the repository (looked upwards from {})",
        manifest.display()
    );
}

/// The triangles of a Wavefront OBJ (positions and faces only; polygons are fanned).
pub fn load_obj(path: &std::path::Path) -> Vec<Triangle> {
    let text = std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    let mut verts: Vec<Vec3A> = Vec::new();
    let mut tris = Vec::new();
    for line in text.lines() {
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let c: Vec<f32> = it.take(3).map(|s| s.parse().expect("bad vertex")).collect();
                verts.push(Vec3A::new(c[0], c[1], c[2]));
            }
            Some("f") => {
                let idx: Vec<usize> = it
                    .map(|s| {
                        let i: i64 = s.split('/').next().unwrap().parse().expect("bad face");
                        if i < 0 {
                            (verts.len() as i64 + i) as usize
                        } else {
                            i as usize - 1
                        }
                    })
                    .collect();
                for k in 1..idx.len() - 1 {
                    tris.push(Triangle::new(
                        verts[idx[0]],
                        verts[idx[k]],
                        verts[idx[k + 1]],
                    ));
                }
            }
            _ => {}
        }
    }
    assert!(!tris.is_empty(), "{} has no triangles", path.display());
    tris
}

/// Half the side of the cube the triangle scene lives in.
pub const TRI_EXTENT: f32 = 100.0;

/// About `target` triangles: randomly placed, rotated and scaled copies of the bunny (each about
/// 3 to 12 units across) in a cube of side 200, the remainder as large random triangles (10 to 60
/// units), the mix of small detailed and large simple geometry that real scenes have.
pub fn triangle_scene(target: usize, seed: u64) -> Vec<Triangle> {
    instanced_triangle_scene(target, seed).flatten()
}

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

/// The parts of [`triangle_scene`]`(target, seed)`.
pub fn instanced_triangle_scene(target: usize, seed: u64) -> InstancedTriangles {
    let bunny = load_obj(&bunny_path());
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
            Mat4::from_scale_rotation_translation(Vec3::splat(scale), rot, at.into())
        })
        .collect();
    let mut loose = Vec::with_capacity(target.saturating_sub(copies * mesh.len()));
    while copies * mesh.len() + loose.len() < target {
        let c = rng.vec3(-TRI_EXTENT, TRI_EXTENT);
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

/// Incoherent rays: origins uniform in the scene cube, directions uniform on the sphere
/// (unit length, so every crate measures `t` in the same units).
pub fn incoherent_rays(n: usize, extent: f32, seed: u64) -> Vec<(Vec3A, Vec3A)> {
    let mut rng = Rng::new(seed);
    (0..n)
        .map(|_| (rng.vec3(-extent, extent), rng.unit_vector()))
        .collect()
}

/// A perspective camera inside the entity cloud whose far plane is chosen (by bisection, not
/// by hand) so that `fraction` of the boxes are not outside the frustum.
pub fn frustum_selecting(boxes: &[Aabb], fraction: f64) -> (Frustum, usize) {
    let view = Mat4::look_at_rh(
        Vec3::new(-0.8, 0.1, -0.7) * ENTITY_EXTENT,
        Vec3::new(0.3, -0.1, 0.2) * ENTITY_EXTENT,
        Vec3::Y,
    );
    let make = |far: f32| {
        // Bevy's projections are reverse-z; a standard 0..1 depth one is what `Frustum` reads
        // as near/far planes either way.
        let proj = Mat4::perspective_rh(1.0, 16.0 / 9.0, 0.1, far);
        Frustum::from_clip_from_world(&(proj * view))
    };
    let count = |f: &Frustum| boxes.iter().filter(|b| f.intersects_aabb(b)).count();
    let want = (boxes.len() as f64 * fraction) as usize;
    let (mut lo, mut hi) = (1.0f32, 4.0 * ENTITY_EXTENT);
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if count(&make(mid)) < want {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let f = make(hi);
    let n = count(&f);
    (f, n)
}

/// `size_of::<T>() * len`: the memory of a node or index array.
pub fn bytes_of<T>(v: &[T]) -> usize {
    core::mem::size_of_val(v)
}
