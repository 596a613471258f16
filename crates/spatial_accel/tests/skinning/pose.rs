//! CPU skinning against an `f64` reference and against the shader's formula in `f32`, and
//! every malformed input an error.

use super::{Rig, Shape, magnitude, product64, random_morph, random_weights};
use accel_testkit::Rng;
use glam::{DVec3, Mat4, Vec3};
use spatial_accel::mesh::{
    MorphTargets, SkinnedVertices, SkinningError, SkinningInput, joint_matrices, morph_positions,
    skin_positions,
};

/// Skins random vertices on random rigs (chains and trees; rotations, translations,
/// non-uniform and mirrored scales; one to four weights, normalised or not; up to three morph
/// targets) and checks each posed vertex against the same pose computed in `f64` from the
/// same `f32` inputs, within a few units in the last place of the terms summed.
#[test]
fn skinning_matches_an_f64_reference() {
    let mut rng = Rng::new(0x5c1e);
    let (mut out, mut joints) = (Vec::new(), Vec::new());
    let mut mirrored = 0;
    for round in 0..120 {
        let shape = if round % 2 == 0 {
            Shape::Chain
        } else {
            Shape::Tree
        };
        let joint_count = 1 + rng.below(40);
        let rig = Rig::random(&mut rng, joint_count, shape);
        let n = 1 + rng.below(400);
        let positions: Vec<Vec3> = (0..n).map(|_| rng.vec3(-3.0, 3.0)).collect();
        let (indices, weights) = random_weights(&mut rng, n, joint_count, round % 3 == 0, 0.05);
        let (displacements, morph_weights) = {
            let targets = rng.below(4);
            random_morph(&mut rng, n, targets)
        };
        let globals = rig.random_pose(&mut rng, 3.0, 0.2);
        joint_matrices(&globals, &rig.inverse_bindposes, &mut joints);
        mirrored += joints.iter().filter(|j| j.determinant() < 0.0).count();

        let vertices = SkinnedVertices {
            positions: &positions,
            joint_indices: &indices,
            joint_weights: &weights,
        };
        let morph = MorphTargets {
            weights: &morph_weights,
            displacements: &displacements,
        };
        let morph = (!morph_weights.is_empty()).then_some(morph);
        skin_positions(&vertices, &joints, morph, &mut out).unwrap();
        assert_eq!(out.len(), n);

        for v in 0..n {
            // The morphed position, and the size of its terms.
            let (mut p, mut p_size) = (positions[v].as_dvec3(), positions[v].as_dvec3().abs());
            for (t, &w) in morph_weights.iter().enumerate().filter(|(_, w)| **w != 0.0) {
                let d = f64::from(w) * displacements[t * n + v].as_dvec3();
                (p, p_size) = (p + d, p_size + d.abs());
            }
            let (mut want, mut size) = (DVec3::ZERO, DVec3::ZERO);
            for (&joint, &w) in indices[v].iter().zip(&weights[v]) {
                let Some(global) = globals.get(usize::from(joint)) else {
                    assert_eq!(w, 0.0);
                    continue;
                };
                let bindpose = &rig.inverse_bindposes[usize::from(joint)];
                let j = product64(global, bindpose);
                want += f64::from(w) * j.transform_point3(p);
                size += f64::from(w.abs()) * magnitude(global, bindpose, p_size);
            }
            let error = (out[v].as_dvec3() - want).abs();
            let tolerance = size * 64.0 * f64::from(f32::EPSILON) + 1e-30;
            assert!(
                error.cmple(tolerance).all(),
                "round {round}, vertex {v}: {} against {want} (error {error}, tolerance {tolerance})",
                out[v]
            );
        }
    }
    assert!(mirrored > 100, "too few mirrored joints: {mirrored}");
}

/// The shader's formula evaluated in `f32` (matrices scaled, summed in slot order, the
/// product's `w` dropped) gives the same bits: skinning follows it step by step.
#[test]
fn skinning_follows_the_shaders_formula() {
    let mut rng = Rng::new(0xb1e5);
    let rig = Rig::random(&mut rng, 12, Shape::Tree);
    let n = 500;
    let positions: Vec<Vec3> = (0..n).map(|_| rng.vec3(-3.0, 3.0)).collect();
    let (indices, weights) = random_weights(&mut rng, n, 12, false, 0.1);
    let (displacements, morph_weights) = random_morph(&mut rng, n, 3);
    let mut joints = Vec::new();
    joint_matrices(
        &rig.random_pose(&mut rng, 3.0, 0.3),
        &rig.inverse_bindposes,
        &mut joints,
    );
    let morph = MorphTargets {
        weights: &morph_weights,
        displacements: &displacements,
    };
    let vertices = SkinnedVertices {
        positions: &positions,
        joint_indices: &indices,
        joint_weights: &weights,
    };
    let mut out = Vec::new();
    skin_positions(&vertices, &joints, Some(morph), &mut out).unwrap();
    let mut morphed = Vec::new();
    morph_positions(&positions, morph, &mut morphed).unwrap();
    for v in 0..n {
        let mut p = positions[v];
        for t in 0..2 {
            p += morph_weights[t] * displacements[t * n + v];
        }
        assert_eq!(morphed[v], p);
        let j = |s: usize| {
            joints
                .get(usize::from(indices[v][s]))
                .copied()
                .unwrap_or(Mat4::ZERO)
        };
        let w = weights[v];
        let m = j(0) * w[0] + j(1) * w[1] + j(2) * w[2] + j(3) * w[3];
        assert_eq!(out[v], (m * p.extend(1.0)).truncate(), "vertex {v}");
    }
    // No allocation once the output has room: the buffer is reused as it is.
    let before = out.as_ptr();
    skin_positions(&vertices, &joints, None, &mut out).unwrap();
    assert_eq!(out.as_ptr(), before);
}

/// Each joint's matrix is the global transform times the inverse bindpose, or the identity
/// where the bindpose is missing.
#[test]
fn joint_matrices_multiply_or_fall_back_to_identity() {
    let mut rng = Rng::new(7);
    let rig = Rig::random(&mut rng, 9, Shape::Chain);
    let globals = rig.random_pose(&mut rng, 3.0, 0.3);
    let mut out = vec![Mat4::ZERO; 40];
    joint_matrices(&globals, &rig.inverse_bindposes[..6], &mut out);
    assert_eq!(out.len(), 9);
    for k in 0..6 {
        assert_eq!(out[k], globals[k] * rig.inverse_bindposes[k]);
    }
    assert!(out[6..].iter().all(|m| *m == Mat4::IDENTITY));
}

/// A one-vertex skin with the given attributes, posed by `joints`.
fn skin_one(
    indices: [u16; 4],
    weights: [f32; 4],
    position: Vec3,
    joints: &[Mat4],
) -> Result<Vec<Vec3>, SkinningError> {
    let mut out = Vec::new();
    let vertices = SkinnedVertices {
        positions: &[position],
        joint_indices: &[indices],
        joint_weights: &[weights],
    };
    skin_positions(&vertices, joints, None, &mut out).map(|()| out)
}

/// Every malformed input is its error, never a panic.
#[test]
fn malformed_inputs_are_errors() {
    let p = [Vec3::ONE, Vec3::X];
    let i = [[0u16; 4]; 2];
    let w = [[1.0f32, 0.0, 0.0, 0.0]; 2];
    let joints = [Mat4::IDENTITY, Mat4::from_translation(Vec3::Y)];
    let mut out = Vec::new();
    let mismatch = |input, expected, got| SkinningError::LengthMismatch {
        input,
        expected,
        got,
    };
    let skin = |i: &[[u16; 4]], w: &[[f32; 4]], morph, out: &mut Vec<Vec3>| {
        let vertices = SkinnedVertices {
            positions: &p,
            joint_indices: i,
            joint_weights: w,
        };
        skin_positions(&vertices, &joints, morph, out)
    };
    assert_eq!(
        skin(&i[..1], &w, None, &mut out),
        Err(mismatch(SkinningInput::JointIndices, 2, 1))
    );
    assert_eq!(
        skin(&i, &[w[0]; 3], None, &mut out),
        Err(mismatch(SkinningInput::JointWeights, 2, 3))
    );
    let displacements = [Vec3::X; 3];
    let morph = MorphTargets {
        weights: &[0.5, 0.5],
        displacements: &displacements,
    };
    assert_eq!(
        skin(&i, &w, Some(morph), &mut out),
        Err(mismatch(SkinningInput::MorphDisplacements, 4, 3))
    );
    assert_eq!(
        morph_positions(&p, morph, &mut out),
        Err(mismatch(SkinningInput::MorphDisplacements, 4, 3))
    );

    // A joint past the skin: an error with a weight, nothing without one.
    assert_eq!(
        skin_one([1, 2, 0, 0], [0.5, 0.5, 0.0, 0.0], Vec3::ONE, &joints),
        Err(SkinningError::JointOutOfRange {
            vertex: 0,
            joint: 2,
            joint_count: 2,
        })
    );
    assert_eq!(
        skin_one([1, 9, 0, 0], [f32::NAN, 0.0, 0.0, 0.0], Vec3::ONE, &[]),
        Err(SkinningError::JointOutOfRange {
            vertex: 0,
            joint: 1,
            joint_count: 0,
        })
    );
    assert_eq!(
        skin_one([1, 900, 65535, 7], [0.5, 0.0, 0.0, 0.0], Vec3::ONE, &joints),
        Ok(vec![Vec3::new(0.5, 1.0, 0.5)])
    );
    // A joint-less skin whose weights are all zero poses every vertex at the origin.
    assert_eq!(
        skin_one([3; 4], [0.0; 4], Vec3::ONE, &[]),
        Ok(vec![Vec3::ZERO])
    );

    // Non-finite results: a NaN or infinite matrix in use, a NaN weight, an infinite
    // position, a NaN morph weight.
    let nan = Mat4::from_cols_array(&[f32::NAN; 16]);
    let mut inf = Mat4::IDENTITY;
    inf.w_axis.x = f32::INFINITY;
    let non_finite = Err(SkinningError::NonFinite { vertex: 0 });
    assert_eq!(
        skin_one([0; 4], [1.0, 0.0, 0.0, 0.0], Vec3::ONE, &[nan]),
        non_finite
    );
    // A zero weight on a NaN matrix is NaN, on the GPU as here.
    assert_eq!(skin_one([0; 4], [0.0; 4], Vec3::ONE, &[nan]), non_finite);
    assert_eq!(
        skin_one([0; 4], [1.0, 0.0, 0.0, 0.0], Vec3::ONE, &[inf]),
        non_finite
    );
    assert_eq!(
        skin_one([0; 4], [f32::NAN, 0.0, 0.0, 0.0], Vec3::ONE, &joints),
        non_finite
    );
    assert_eq!(
        skin_one([0; 4], [1.0, 0.0, 0.0, 0.0], Vec3::INFINITY, &joints),
        non_finite
    );
    let joints_nan = [Mat4::IDENTITY, nan];
    let vertices = SkinnedVertices {
        positions: &p,
        joint_indices: &[[0; 4], [1, 0, 0, 0]],
        joint_weights: &w,
    };
    assert_eq!(
        skin_positions(&vertices, &joints_nan, None, &mut out),
        Err(SkinningError::NonFinite { vertex: 1 })
    );
    let morph = MorphTargets {
        weights: &[f32::NAN],
        displacements: &[Vec3::X, Vec3::ZERO],
    };
    let vertices = SkinnedVertices {
        positions: &p,
        joint_indices: &i,
        joint_weights: &w,
    };
    assert_eq!(
        skin_positions(&vertices, &joints, Some(morph), &mut out),
        Err(SkinningError::NonFinite { vertex: 0 })
    );
    assert_eq!(
        morph_positions(&p, morph, &mut out),
        Err(SkinningError::NonFinite { vertex: 0 })
    );

    // Empty meshes pose to nothing.
    let empty = SkinnedVertices {
        positions: &[],
        joint_indices: &[],
        joint_weights: &[],
    };
    assert_eq!(skin_positions(&empty, &[], None, &mut out), Ok(()));
    assert!(out.is_empty());

    // Every error explains itself.
    for e in [
        mismatch(SkinningInput::PosedPositions, 3, 2),
        SkinningError::JointOutOfRange {
            vertex: 1,
            joint: 2,
            joint_count: 2,
        },
        SkinningError::NonFinite { vertex: 4 },
        SkinningError::NonFiniteBound,
    ] {
        let e: Box<dyn std::error::Error> = Box::new(e);
        assert!(!e.to_string().is_empty());
    }
}
