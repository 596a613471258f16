//! The bound from the joints alone against every posed vertex.

use super::{Rig, Shape, random_morph, random_weights};
use accel_testkit::Rng;
use glam::{Mat4, Quat, Vec3};
use spatial_accel::Aabb;
use spatial_accel::mesh::{
    MorphTargets, SkinBounds, SkinnedVertices, SkinningError, SkinningInput, joint_matrices,
    skin_positions,
};

/// Over random rigs and poses, with glTF weights (non-negative, summing to one), weights
/// summing to less or more than one, and negative weights, with and without morph targets:
/// every posed vertex lies in the bound.
#[test]
fn the_bound_holds_every_posed_vertex() {
    let mut rng = Rng::new(0xb0d5);
    let (mut out, mut joints) = (Vec::new(), Vec::new());
    for round in 0..150 {
        let shape = if round % 2 == 0 {
            Shape::Chain
        } else {
            Shape::Tree
        };
        let joint_count = 1 + rng.below(30);
        let rig = Rig::random(&mut rng, joint_count, shape);
        let n = 1 + rng.below(300);
        let positions: Vec<Vec3> = (0..n).map(|_| rng.vec3(-3.0, 3.0)).collect();
        let (normalised, negative) = [(true, 0.0), (false, 0.0), (false, 0.2)][round % 3];
        let (indices, weights) = random_weights(&mut rng, n, joint_count, normalised, negative);
        let targets = rng.below(4);
        let (displacements, morph_weights) = random_morph(&mut rng, n, targets);
        let vertices = SkinnedVertices {
            positions: &positions,
            joint_indices: &indices,
            joint_weights: &weights,
        };
        let bounds = SkinBounds::new(&vertices, &displacements, targets).unwrap();
        assert_eq!(bounds.target_count(), targets);
        for _ in 0..4 {
            joint_matrices(
                &rig.random_pose(&mut rng, 3.0, 0.2),
                &rig.inverse_bindposes,
                &mut joints,
            );
            let morph = MorphTargets {
                weights: &morph_weights,
                displacements: &displacements,
            };
            skin_positions(&vertices, &joints, Some(morph), &mut out).unwrap();
            let bound = bounds.bound(&joints, &morph_weights).unwrap();
            for (v, p) in out.iter().enumerate() {
                assert!(
                    bound.contains_point(*p),
                    "round {round}, vertex {v}: {p} outside {bound:?}"
                );
            }
        }
    }
}

/// On the edge of the proof: weights summing to one in `f32` only up to rounding, joints
/// far from the origin (large terms that cancel), and vertices on the joint boxes' corners.
#[test]
fn the_bound_holds_under_rounding() {
    let mut rng = Rng::new(0xed9e);
    let mut out = Vec::new();
    for _ in 0..200 {
        let n = 64;
        // Vertices on the corners of a box, so each is an extreme point of its joint's box.
        let (lo, hi) = (rng.vec3(-1000.0, 0.0), rng.vec3(0.0, 1000.0));
        let positions: Vec<Vec3> = (0..n)
            .map(|v| Vec3::select(glam::BVec3::new(v & 1 != 0, v & 2 != 0, v & 4 != 0), hi, lo))
            .collect();
        let (indices, weights) = random_weights(&mut rng, n, 3, true, 0.0);
        let far = |rng: &mut Rng| {
            let rotation = Quat::from_axis_angle(rng.unit_vector().into(), rng.range(-3.0, 3.0));
            Mat4::from_scale_rotation_translation(rng.vec3(0.5, 2.0), rotation, rng.vec3(-1e4, 1e4))
        };
        let joints: Vec<Mat4> = (0..3).map(|_| far(&mut rng)).collect();
        let vertices = SkinnedVertices {
            positions: &positions,
            joint_indices: &indices,
            joint_weights: &weights,
        };
        skin_positions(&vertices, &joints, None, &mut out).unwrap();
        let bound = SkinBounds::new(&vertices, &[], 0)
            .unwrap()
            .bound(&joints, &[])
            .unwrap();
        assert!(out.iter().all(|p| bound.contains_point(*p)));
    }
}

/// With every joint at its bind pose and one full weight per vertex the bound is the bind
/// pose's box, to within its rounding margin: it is not looser than the boxes it is made of.
#[test]
fn the_bound_is_tight_at_the_bind_pose() {
    let mut rng = Rng::new(3);
    let n = 200;
    let positions: Vec<Vec3> = (0..n).map(|_| rng.vec3(-3.0, 3.0)).collect();
    let indices: Vec<[u16; 4]> = (0..n).map(|v| [(v % 5) as u16, 0, 0, 0]).collect();
    let weights = vec![[1.0, 0.0, 0.0, 0.0]; n];
    let vertices = SkinnedVertices {
        positions: &positions,
        joint_indices: &indices,
        joint_weights: &weights,
    };
    let bound = SkinBounds::new(&vertices, &[], 0)
        .unwrap()
        .bound(&[Mat4::IDENTITY; 5], &[])
        .unwrap();
    let exact = Aabb::from_points(positions.iter().copied());
    assert!(bound.contains_aabb(&exact));
    assert!((bound.min - exact.min).abs().max_element() < 1e-4);
    assert!((bound.max - exact.max).abs().max_element() < 1e-4);

    // All weights zero: every vertex at the origin, and the bound the origin's box.
    let zero = vec![[0.0; 4]; n];
    let vertices = SkinnedVertices {
        joint_weights: &zero,
        ..vertices
    };
    let bound = SkinBounds::new(&vertices, &[], 0)
        .unwrap()
        .bound(&[], &[])
        .unwrap();
    assert!(bound.contains_point(Vec3::ZERO) && bound.extent().max_element() < 1e-30);
}

/// Malformed inputs and non-finite poses are errors.
#[test]
fn bound_errors() {
    let p = [Vec3::ONE, Vec3::X];
    let i = [[0u16, 3, 0, 0], [1, 0, 0, 0]];
    let w = [[0.5, 0.5, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]];
    let vertices = SkinnedVertices {
        positions: &p,
        joint_indices: &i,
        joint_weights: &w,
    };
    assert_eq!(
        SkinBounds::new(&vertices, &[Vec3::X; 3], 2).unwrap_err(),
        SkinningError::LengthMismatch {
            input: SkinningInput::MorphDisplacements,
            expected: 4,
            got: 3,
        }
    );
    let short = SkinnedVertices {
        joint_weights: &w[..1],
        ..vertices
    };
    assert!(matches!(
        SkinBounds::new(&short, &[], 0),
        Err(SkinningError::LengthMismatch {
            input: SkinningInput::JointWeights,
            ..
        })
    ));
    let bounds = SkinBounds::new(&vertices, &[Vec3::X; 2], 1).unwrap();
    let joints = [Mat4::IDENTITY; 4];
    assert!(bounds.bound(&joints, &[0.5]).is_ok());
    assert_eq!(
        bounds.bound(&joints[..3], &[0.5]),
        Err(SkinningError::JointOutOfRange {
            vertex: 0,
            joint: 3,
            joint_count: 3,
        })
    );
    assert_eq!(
        bounds.bound(&joints, &[]),
        Err(SkinningError::LengthMismatch {
            input: SkinningInput::MorphWeights,
            expected: 1,
            got: 0,
        })
    );
    let mut nan = joints;
    nan[1] = Mat4::from_cols_array(&[f32::NAN; 16]);
    assert_eq!(
        bounds.bound(&nan, &[0.5]),
        Err(SkinningError::NonFiniteBound)
    );
    // A NaN joint that moves no vertex is not in the bound's way.
    nan.swap(1, 2);
    assert!(bounds.bound(&nan, &[0.5]).is_ok());
    assert_eq!(
        bounds.bound(&joints, &[f32::NAN]),
        Err(SkinningError::NonFiniteBound)
    );
    // NaN displacements: harmless at weight zero, as in skinning.
    let bounds = SkinBounds::new(&vertices, &[Vec3::NAN; 2], 1).unwrap();
    assert!(bounds.bound(&joints, &[0.0]).is_ok());
    assert_eq!(
        bounds.bound(&joints, &[0.1]),
        Err(SkinningError::NonFiniteBound)
    );
    // A NaN weight fails the bound as it fails skinning.
    let w_nan = [[f32::NAN, 0.0, 0.0, 0.0], w[1]];
    let vertices = SkinnedVertices {
        joint_weights: &w_nan,
        ..vertices
    };
    let bounds = SkinBounds::new(&vertices, &[], 0).unwrap();
    assert_eq!(
        bounds.bound(&joints, &[]),
        Err(SkinningError::NonFiniteBound)
    );
}
