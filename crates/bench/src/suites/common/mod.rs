//! What the suites share besides `accel_testkit`'s scenes (entity boxes, the
//! ~1M-triangle scene of bunny copies): incoherent rays and a camera frustum, both
//! deterministic; plus the adapters that let our own statistics (SAH cost, memory) be computed
//! on the peer crates' trees.
#![allow(dead_code)]

pub mod peers;
pub mod tinybvh;

use accel_testkit::Rng;
use accel_testkit::boxes::ENTITY_EXTENT;
use glam::{Mat4, Vec3, Vec3A};
use spatial_accel::{Aabb, Frustum};

/// Incoherent rays: origins uniform in the scene cube, directions uniform on the sphere
/// (unit length, so every crate measures `t` in the same units).
pub fn incoherent_rays(n: usize, extent: f32, seed: u64) -> Vec<(Vec3A, Vec3A)> {
    let mut rng = Rng::new(seed);
    (0..n)
        .map(|_| (rng.vec3a(-extent, extent), rng.unit_vector()))
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
