//! Skinned and morphed meshes: CPU skinning against an `f64` reference, the conservative
//! bound against every posed vertex, and the posed tree against brute force over the posed
//! triangles, on seeded random rigs.
//!
//! - `pose`: [`skin_positions`](spatial_accel::mesh::skin_positions) and its errors.
//! - `bounds`: [`SkinBounds`](spatial_accel::mesh::SkinBounds).
//! - `rays`: [`PosedMeshBvh`](spatial_accel::mesh::PosedMeshBvh) through refits and
//!   rebuilds.

mod bounds;
mod pose;
mod rays;

use accel_testkit::Rng;
use glam::{DMat4, DQuat, DVec3, Mat4, Vec3};

/// A skeleton: each joint's parent (before it in the list) and its bind pose.
struct Rig {
    parents: Vec<Option<usize>>,
    /// The inverse of each joint's global bind transform, in `f32` as a mesh asset stores it.
    inverse_bindposes: Vec<Mat4>,
}

/// How the joints of a random rig hang together.
#[derive(Clone, Copy, Debug)]
enum Shape {
    /// Each joint the child of the one before.
    Chain,
    /// Each joint the child of a random earlier one, or a root.
    Tree,
}

/// A random local transform: a rotation of up to `angle` radians about a random axis, a
/// translation in `[-reach, reach)^3`, and a non-uniform scale in `[0.5, 1.6)` per axis whose
/// sign flips on one axis (a mirror) with probability `mirror`.
fn random_local(rng: &mut Rng, angle: f64, reach: f32, mirror: f32) -> DMat4 {
    let axis = rng.unit_vector_f64().as_dvec3();
    let rotation = DQuat::from_axis_angle(axis.normalize(), rng.range_f64(-angle, angle));
    let mut scale = rng.vec3(0.5, 1.6).as_dvec3();
    if rng.chance(mirror) {
        scale[rng.below(3)] *= -1.0;
    }
    DMat4::from_scale_rotation_translation(scale, rotation, rng.vec3(-reach, reach).as_dvec3())
}

/// Every joint's global transform from the local ones, in `f64`.
fn globals(parents: &[Option<usize>], locals: &[DMat4]) -> Vec<DMat4> {
    let mut out: Vec<DMat4> = Vec::with_capacity(locals.len());
    for (parent, local) in parents.iter().zip(locals) {
        out.push(parent.map_or(*local, |p| out[p] * *local));
    }
    out
}

impl Rig {
    /// `joints` joints hanging together as `shape` says, bound in a random pose.
    fn random(rng: &mut Rng, joints: usize, shape: Shape) -> Self {
        let parents: Vec<Option<usize>> = (0..joints)
            .map(|k| match shape {
                _ if k == 0 => None,
                Shape::Chain => Some(k - 1),
                Shape::Tree if rng.chance(0.1) => None,
                Shape::Tree => Some(rng.below(k)),
            })
            .collect();
        let locals: Vec<DMat4> = (0..joints)
            .map(|_| random_local(rng, 1.0, 1.0, 0.2))
            .collect();
        let inverse_bindposes = globals(&parents, &locals)
            .iter()
            .map(|g| g.inverse().as_mat4())
            .collect();
        Self {
            parents,
            inverse_bindposes,
        }
    }

    /// The joints' global transforms of a random pose, as the `f32` matrices an engine
    /// hands over.
    fn random_pose(&self, rng: &mut Rng, angle: f64, mirror: f32) -> Vec<Mat4> {
        let locals: Vec<DMat4> = (0..self.parents.len())
            .map(|_| random_local(rng, angle, 1.0, mirror))
            .collect();
        globals(&self.parents, &locals)
            .iter()
            .map(DMat4::as_mat4)
            .collect()
    }
}

/// Per-vertex skinning attributes: one to four slots of non-zero weight on random joints of
/// `joints`, the other slots weight zero on a random index (past the joints, sometimes, as
/// glTF padding may be). Weights in `[0, 1)`, summing to one when `normalised`, and each
/// negative with probability `negative`.
fn random_weights(
    rng: &mut Rng,
    n: usize,
    joints: usize,
    normalised: bool,
    negative: f32,
) -> (Vec<[u16; 4]>, Vec<[f32; 4]>) {
    let mut indices = Vec::with_capacity(n);
    let mut weights = Vec::with_capacity(n);
    for _ in 0..n {
        let used = 1 + rng.below(4);
        let mut i = [0u16; 4];
        let mut w = [0.0f32; 4];
        for slot in 0..4 {
            if slot < used {
                i[slot] = rng.below(joints) as u16;
                w[slot] = rng.range(0.05, 1.0);
                if rng.chance(negative) {
                    w[slot] = -w[slot];
                }
            } else if rng.chance(0.3) {
                i[slot] = u16::MAX - rng.below(100) as u16;
            } else {
                i[slot] = rng.below(joints) as u16;
            }
        }
        if normalised {
            let sum: f32 = w.iter().sum();
            w.iter_mut().for_each(|x| *x /= sum);
        }
        // Slots in a random order: a zero-weight slot need not come last.
        for slot in (1..4).rev() {
            let other = rng.below(slot + 1);
            i.swap(slot, other);
            w.swap(slot, other);
        }
        indices.push(i);
        weights.push(w);
    }
    (indices, weights)
}

/// `targets` morph targets over `n` vertices (target-major) and their weights in `[-1, 1)`;
/// the last target, if there are two or more, weighs zero and displaces by NaN (the shader
/// skips it, so must skinning).
fn random_morph(rng: &mut Rng, n: usize, targets: usize) -> (Vec<Vec3>, Vec<f32>) {
    let mut displacements: Vec<Vec3> = (0..n * targets).map(|_| rng.vec3(-0.3, 0.3)).collect();
    let mut weights: Vec<f32> = (0..targets).map(|_| rng.range(-1.0, 1.0)).collect();
    if targets >= 2 {
        weights[targets - 1] = 0.0;
        displacements[(targets - 1) * n..].fill(Vec3::NAN);
    }
    (displacements, weights)
}

/// The `f64` product of two `f32` matrices.
fn product64(a: &Mat4, b: &Mat4) -> DMat4 {
    a.as_dmat4() * b.as_dmat4()
}

/// `|a| * |b| * (|p|, 1)`, `xyz`: the magnitude of the terms of `(a * b * (p, 1)).xyz`, which
/// bounds every rounding of computing it in `f32`.
fn magnitude(a: &Mat4, b: &Mat4, p: DVec3) -> DVec3 {
    (a.as_dmat4().abs() * b.as_dmat4().abs() * p.abs().extend(1.0)).truncate()
}
