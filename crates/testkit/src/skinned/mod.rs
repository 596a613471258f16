//! A procedural skinned character as plain data: a low-poly humanoid of tubes and boxes on a
//! 15-joint skeleton, with a walk cycle and one morph target.
//!
//! The `animated` example loads it from `assets/character.glb` (written by the `character_glb`
//! binary from [`SkinnedCharacter::to_glb`]) through Bevy's glTF loader; tests and benchmarks
//! take the same character from here without Bevy: [`character`] for the mesh and its skin,
//! [`walk_pose`] and [`globals`] for the skeleton at any time of the walk, and
//! [`SkinnedCharacter::skin`] for the posed vertices that a tree over an animated mesh has to
//! follow.
//!
//! Conventions are glTF's: metres, +Y up, the character facing +Z with its left hand on +X,
//! feet on `y = 0` in the rest pose (arms hanging down). Joints are listed parents first, so
//! one pass over them in order computes every global transform.

mod body;
mod export;

pub use body::character;
pub use export::character_glb_path;

use glam::{Mat4, Quat, Vec3};
use std::f32::consts::TAU;

/// The number of joints of the skeleton.
pub const JOINT_COUNT: usize = 15;

/// The joints' names, which are also the glTF nodes' names (Bevy's animation targets are
/// found by the path of names from the scene root, so they must be unique and stable).
pub const JOINT_NAMES: [&str; JOINT_COUNT] = [
    "hips",
    "spine",
    "chest",
    "neck",
    "head",
    "shoulder_l",
    "upper_arm_l",
    "forearm_l",
    "shoulder_r",
    "upper_arm_r",
    "forearm_r",
    "thigh_l",
    "shin_l",
    "thigh_r",
    "shin_r",
];

/// Each joint's parent (an index into the joint list, always smaller than the joint's own), or
/// `None` for the root (`hips`).
pub const JOINT_PARENTS: [Option<usize>; JOINT_COUNT] = [
    None,
    Some(HIPS),
    Some(SPINE),
    Some(CHEST),
    Some(NECK),
    Some(CHEST),
    Some(SHOULDER_L),
    Some(UPPER_ARM_L),
    Some(CHEST),
    Some(SHOULDER_R),
    Some(UPPER_ARM_R),
    Some(HIPS),
    Some(THIGH_L),
    Some(HIPS),
    Some(THIGH_R),
];

const HIPS: usize = 0;
const SPINE: usize = 1;
const CHEST: usize = 2;
const NECK: usize = 3;
const HEAD: usize = 4;
const SHOULDER_L: usize = 5;
const UPPER_ARM_L: usize = 6;
const FOREARM_L: usize = 7;
const SHOULDER_R: usize = 8;
const UPPER_ARM_R: usize = 9;
const FOREARM_R: usize = 10;
const THIGH_L: usize = 11;
const SHIN_L: usize = 12;
const THIGH_R: usize = 13;
const SHIN_R: usize = 14;

/// The joints' rest translations relative to their parents (the rest rotations are identity
/// and the scales one).
const REST_TRANSLATIONS: [[f32; 3]; JOINT_COUNT] = [
    [0.0, 0.95, 0.0],
    [0.0, 0.12, 0.0],
    [0.0, 0.25, 0.0],
    [0.0, 0.26, 0.0],
    [0.0, 0.10, 0.0],
    [0.07, 0.20, 0.0],
    [0.16, 0.0, 0.0],
    [0.0, -0.28, 0.0],
    [-0.07, 0.20, 0.0],
    [-0.16, 0.0, 0.0],
    [0.0, -0.28, 0.0],
    [0.10, -0.04, 0.0],
    [0.0, -0.42, 0.0],
    [-0.10, -0.04, 0.0],
    [0.0, -0.42, 0.0],
];

/// The length of one walk cycle, in seconds: [`walk_pose`] repeats with this period, and the
/// glTF animation "walk" covers exactly one period.
pub const WALK_PERIOD: f32 = 1.0;

/// Keyframes per second of the glTF animation: enough that linear interpolation between
/// them is indistinguishable from [`walk_pose`] at the example's scale.
pub const WALK_KEYS_PER_SECOND: u32 = 24;

/// The name of the morph target, the glTF mesh's `extras.targetNames` entry (Bevy names the
/// morph weights by it).
pub const BREATHE_TARGET: &str = "breathe";

/// A joint's transform relative to its parent, split as glTF animates it (translation,
/// rotation and scale are separate channels).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointTransform {
    /// Offset from the parent joint, in the parent's frame.
    pub translation: Vec3,
    /// Rotation relative to the parent, a unit quaternion.
    pub rotation: Quat,
    /// Scale relative to the parent (one everywhere here, kept because glTF has it).
    pub scale: Vec3,
}

impl JointTransform {
    /// No offset, no rotation, unit scale.
    pub const IDENTITY: Self = Self {
        translation: Vec3::ZERO,
        rotation: Quat::IDENTITY,
        scale: Vec3::ONE,
    };

    /// The transform as a matrix (scale, then rotation, then translation, as glTF composes
    /// them).
    pub fn to_mat4(&self) -> Mat4 {
        Mat4::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }
}

impl Default for JointTransform {
    fn default() -> Self {
        Self::IDENTITY
    }
}

/// The rest pose (the bind pose): every joint's local transform, parents first.
pub fn rest_pose() -> Vec<JointTransform> {
    REST_TRANSLATIONS
        .iter()
        .map(|&t| JointTransform {
            translation: Vec3::from(t),
            ..JointTransform::IDENTITY
        })
        .collect()
}

/// The joints' global matrices (model space) for local transforms `locals`, composed parents
/// first in one pass: what a renderer's skinning does before it applies the inverse bind
/// matrices, here on the CPU for tests and for trees that must follow the posed mesh.
///
/// Panics if `locals` does not have [`JOINT_COUNT`] entries.
pub fn globals(locals: &[JointTransform]) -> Vec<Mat4> {
    assert_eq!(locals.len(), JOINT_COUNT, "one transform per joint");
    let mut out: Vec<Mat4> = Vec::with_capacity(JOINT_COUNT);
    for (local, parent) in locals.iter().zip(JOINT_PARENTS) {
        let m = local.to_mat4();
        out.push(match parent {
            Some(p) => out[p] * m,
            None => m,
        });
    }
    out
}

/// The walk cycle at time `t` seconds (any `t`; it repeats every [`WALK_PERIOD`]), as local
/// transforms parents first: the legs swing +-0.45 rad and the knees bend while a leg swings
/// forward, the arms swing opposite to the legs with bent elbows, the hips bob twice per
/// cycle (lowest when the legs are furthest apart), roll and twist, and the chest and head
/// counter-twist. The character walks in place: the hips never move along X or Z, so a
/// scene moves the whole character to make it travel.
///
/// Every value is a smooth periodic function of `t`, so sampled keyframes loop without a
/// jump.
pub fn walk_pose(t: f32) -> Vec<JointTransform> {
    let phase = TAU * (t / WALK_PERIOD).rem_euclid(1.0);
    let (s, c) = phase.sin_cos();
    let mut pose = rest_pose();
    let rot = |x: f32, y: f32, z: f32| Quat::from_euler(glam::EulerRot::XYZ, x, y, z);
    // Hips: bob (down 6 cm when the stride is widest), roll towards the swinging leg, twist.
    pose[HIPS].translation.y += -0.03 + 0.03 * (2.0 * phase).cos();
    pose[HIPS].rotation = rot(0.0, 0.10 * s, 0.04 * s);
    // A slight forward lean, and the chest twisting against the hips.
    pose[SPINE].rotation = rot(0.06, -0.05 * s, -0.03 * s);
    pose[CHEST].rotation = rot(0.02 + 0.02 * (2.0 * phase).cos(), -0.12 * s, 0.0);
    // The head keeps looking ahead: it undoes the twists below it.
    pose[NECK].rotation = rot(-0.04, 0.03 * s, 0.0);
    pose[HEAD].rotation = rot(-0.04, 0.04 * s, -0.01 * s);
    // Legs: the left thigh swings forward (a negative rotation about X takes the foot to +Z)
    // while `sin` is positive; a knee bends most as its thigh passes under the hips going
    // forward (`cos` highest) and least at heel strike.
    for (thigh, shin, side) in [(THIGH_L, SHIN_L, 1.0), (THIGH_R, SHIN_R, -1.0)] {
        let (ls, lc) = (side * s, side * c);
        pose[thigh].rotation = rot(-0.45 * ls, 0.0, 0.0);
        let lift = 0.5 + 0.5 * lc;
        pose[shin].rotation = rot(0.08 + 0.75 * lift * lift, 0.0, 0.0);
    }
    // Arms: each swings with the opposite leg, held a little away from the body, and the
    // elbow bends more while its arm is in front.
    for (upper, fore, side) in [
        (UPPER_ARM_L, FOREARM_L, 1.0),
        (UPPER_ARM_R, FOREARM_R, -1.0),
    ] {
        let ls = side * s;
        pose[upper].rotation = rot(0.35 * ls, 0.0, side * 0.10);
        pose[fore].rotation = rot(-0.25 - 0.25 * (0.5 - 0.5 * ls), 0.0, 0.0);
    }
    for joint in &mut pose {
        joint.rotation = joint.rotation.normalize();
    }
    pose
}

/// The weight of the [`BREATHE_TARGET`] morph target at time `t` seconds of the walk: one
/// breath per cycle, from 0 (at `t = 0`) to 1 and back, so the glTF animation's weights
/// channel loops with the rest of the walk.
pub fn breathe_weight(t: f32) -> f32 {
    let phase = TAU * (t / WALK_PERIOD).rem_euclid(1.0);
    0.5 - 0.5 * phase.cos()
}

/// How finely the character is tessellated. Every limb, the torso and the head are tubes;
/// the character has about `29 * around * rings + 12 * around` triangles, and
/// [`Detail::for_triangles`] finds the pair for a wanted count.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Detail {
    /// Vertices around each tube (at least 3).
    pub around: u32,
    /// Rings along a tube section 0.3 m long (a thigh or a forearm); shorter sections get
    /// proportionally fewer, at least one.
    pub rings: u32,
}

impl Detail {
    /// The detail whose character has the triangle count closest to `triangles`, with
    /// `rings` about `0.6 * around` so that the quads stay roughly square (e.g. about 2k, 5k
    /// and 20k triangles for the benchmarks' small, default and large characters).
    pub fn for_triangles(triangles: u32) -> Self {
        let around = ((triangles as f32 / 17.5).sqrt().round() as u32).max(4);
        (around - 1..=around + 1)
            .flat_map(|around| (1..=around * 2).map(move |rings| Self { around, rings }))
            .min_by_key(|d| d.triangle_count().abs_diff(triangles as usize))
            .unwrap()
    }

    /// The number of triangles of [`character`] at this detail.
    pub fn triangle_count(self) -> usize {
        body::triangle_count(self)
    }
}

impl Default for Detail {
    /// About 5k triangles: the size of `assets/character.glb`.
    fn default() -> Self {
        Self::for_triangles(5000)
    }
}

/// The character: a triangle mesh with, for each vertex, up to four joints and their
/// weights, the skeleton's inverse bind matrices and the morph target. Built by
/// [`character`].
#[derive(Clone, Debug, PartialEq)]
pub struct SkinnedCharacter {
    /// The tessellation it was built with.
    pub detail: Detail,
    /// Vertex positions in the rest pose (model space, which is the skeleton's space too).
    pub positions: Vec<Vec3>,
    /// Unit vertex normals in the rest pose.
    pub normals: Vec<Vec3>,
    /// Three vertex indices per triangle, counter-clockwise seen from outside.
    pub indices: Vec<u32>,
    /// Each vertex's joints (indices into [`JOINT_NAMES`]); unused slots are 0 with weight 0.
    pub joints: Vec<[u16; 4]>,
    /// Each vertex's joint weights: one to four non-zero, summing to 1 (to f32 rounding).
    pub weights: Vec<[f32; 4]>,
    /// Each joint's inverse bind matrix: the inverse of its global matrix in the
    /// [`rest_pose`], taking a rest position into the joint's frame.
    pub inverse_bind: Vec<Mat4>,
    /// The [`BREATHE_TARGET`] morph target: each vertex's displacement at weight 1 (zero
    /// outside the chest).
    pub breathe: Vec<Vec3>,
}

impl SkinnedCharacter {
    /// The number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// The skinning matrices for the joints' `globals`: `global * inverse_bind` per joint,
    /// what the vertex shader blends.
    pub fn joint_matrices(&self, globals: &[Mat4]) -> Vec<Mat4> {
        globals
            .iter()
            .zip(&self.inverse_bind)
            .map(|(g, ib)| *g * *ib)
            .collect()
    }

    /// The posed vertex positions, skinned on the CPU as a renderer does on the GPU: the
    /// morph target added with weight `breathe`, then each vertex moved by the weighted sum
    /// of its joints' skinning matrices for `globals` (from [`globals`]). Tests compare
    /// against it, and trees over an animated character are rebuilt or refitted from it.
    pub fn skin(&self, globals: &[Mat4], breathe: f32) -> Vec<Vec3> {
        let matrices = self.joint_matrices(globals);
        self.positions
            .iter()
            .zip(&self.breathe)
            .zip(self.joints.iter().zip(&self.weights))
            .map(|((&p, &d), (joints, weights))| {
                let p = p + d * breathe;
                joints
                    .iter()
                    .zip(weights)
                    .filter(|(_, w)| **w != 0.0)
                    .map(|(&j, &w)| matrices[j as usize].transform_point3(p) * w)
                    .sum()
            })
            .collect()
    }

    /// The character posed at time `t` of the walk (with its breath) as a plain [`Mesh`],
    /// the input the test kit's trees and checks take.
    ///
    /// [`Mesh`]: crate::Mesh
    pub fn walk_mesh(&self, t: f32) -> crate::Mesh {
        let positions = self.skin(&globals(&walk_pose(t)), breathe_weight(t));
        crate::Mesh {
            vertices: positions.into_iter().map(Into::into).collect(),
            indices: self
                .indices
                .chunks_exact(3)
                .map(|t| [t[0], t[1], t[2]])
                .collect(),
        }
    }
}

#[cfg(test)]
mod tests;
