//! CPU skinning and morph targets: a mesh posed as Bevy's vertex shader poses it.
//!
//! Bevy draws a skinned mesh at positions its vertex shader computes (`bevy_pbr`'s
//! `skinning.wgsl` and `mesh.wgsl`); a ray cast against the stored (bind-pose) positions
//! answers for a shape nobody sees. The functions here compute those positions on the CPU,
//! step by step as the shader does, so that a query over them answers for what is drawn.

use core::fmt;
use glam::{Mat4, Vec3};

/// Which input of a skinning call has the wrong length (see [`SkinningError::LengthMismatch`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SkinningInput {
    /// The joint indices, one `[u16; 4]` per vertex.
    JointIndices,
    /// The joint weights, one `[f32; 4]` per vertex.
    JointWeights,
    /// The morph targets' displacements: one per vertex per target.
    MorphDisplacements,
    /// The morph weights given for a pose: one per target.
    MorphWeights,
    /// The positions a pose left (see [`PosedMeshBvh::pose`](super::PosedMeshBvh::pose)):
    /// one per vertex of the mesh.
    PosedPositions,
}

/// Why a mesh could not be posed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SkinningError {
    /// An input does not have the length the vertex count (or the target count) asks for.
    LengthMismatch {
        /// The input at fault.
        input: SkinningInput,
        /// The length it should have.
        expected: usize,
        /// The length it has.
        got: usize,
    },
    /// A vertex gives a non-zero weight to a joint the skin does not have.
    JointOutOfRange {
        /// The vertex.
        vertex: usize,
        /// The joint index it names.
        joint: u16,
        /// The number of joint matrices given.
        joint_count: usize,
    },
    /// A posed position is not finite (a non-finite joint matrix, weight, morph weight,
    /// displacement or position was used).
    NonFinite {
        /// The first vertex whose position is not finite.
        vertex: usize,
    },
    /// A bound of the posed mesh is not finite (see
    /// [`SkinBounds::bound`](super::SkinBounds::bound)).
    NonFiniteBound,
    /// A triangle names a vertex the mesh does not have, or the index count is not a
    /// multiple of three (see [`SkinSegments::new`](super::SkinSegments::new)).
    BadTriangle {
        /// The first such triangle (the index count over three for a trailing remainder).
        triangle: usize,
    },
}

impl fmt::Display for SkinningError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::LengthMismatch {
                input,
                expected,
                got,
            } => write!(f, "{input:?}: {got} values where {expected} were expected"),
            Self::JointOutOfRange {
                vertex,
                joint,
                joint_count,
            } => write!(
                f,
                "vertex {vertex} weights joint {joint}, but the skin has {joint_count} joints"
            ),
            Self::NonFinite { vertex } => {
                write!(f, "vertex {vertex} is posed at a non-finite position")
            }
            Self::NonFiniteBound => write!(f, "the bound of the posed mesh is not finite"),
            Self::BadTriangle { triangle } => {
                write!(
                    f,
                    "triangle {triangle} names vertices the mesh does not have"
                )
            }
        }
    }
}

impl std::error::Error for SkinningError {}

/// A skinned mesh's vertex attributes as the mesh asset stores them (Bevy's
/// `ATTRIBUTE_POSITION`, `ATTRIBUTE_JOINT_INDEX` and `ATTRIBUTE_JOINT_WEIGHT`): one entry per
/// vertex in each.
#[derive(Clone, Copy, Debug)]
pub struct SkinnedVertices<'a> {
    /// The positions, in the bind pose (before morph targets).
    pub positions: &'a [Vec3],
    /// Four joint indices per vertex, into the skin's joints.
    pub joint_indices: &'a [[u16; 4]],
    /// Four weights per vertex, used as stored: they need not sum to one (the shader does
    /// not normalise them either).
    pub joint_weights: &'a [[f32; 4]],
}

impl SkinnedVertices<'_> {
    /// The number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Checks that every attribute has one entry per vertex.
    pub fn check_lengths(&self) -> Result<(), SkinningError> {
        let n = self.positions.len();
        check_length(SkinningInput::JointIndices, n, self.joint_indices.len())?;
        check_length(SkinningInput::JointWeights, n, self.joint_weights.len())
    }
}

/// A mesh's morph targets (position displacements) and the weights of one pose.
#[derive(Clone, Copy, Debug)]
pub struct MorphTargets<'a> {
    /// Each target's weight, in target order.
    pub weights: &'a [f32],
    /// The displacements, target-major: target `t`'s displacement of vertex `v` at
    /// `t * vertex_count + v`.
    pub displacements: &'a [Vec3],
}

pub(super) fn check_length(
    input: SkinningInput,
    expected: usize,
    got: usize,
) -> Result<(), SkinningError> {
    if expected == got {
        Ok(())
    } else {
        Err(SkinningError::LengthMismatch {
            input,
            expected,
            got,
        })
    }
}

/// Each joint's skinning matrix, `joint_globals[k] * inverse_bindposes[k]`, into `out`
/// (cleared first; one matrix per joint of `joint_globals`), as Bevy's skin extraction
/// computes them.
///
/// `joint_globals[k]` is joint `k`'s global transform as a matrix (`GlobalTransform::affine`,
/// converted). Where a joint has no inverse bindpose (`inverse_bindposes` is shorter) its
/// matrix is [`Mat4::IDENTITY`], as in Bevy; Bevy does the same for a joint whose entity has
/// no transform, which a caller mirrors by writing `Mat4::IDENTITY` into that slot of `out`.
pub fn joint_matrices(joint_globals: &[Mat4], inverse_bindposes: &[Mat4], out: &mut Vec<Mat4>) {
    out.clear();
    out.extend(joint_globals.iter().enumerate().map(|(k, global)| {
        inverse_bindposes
            .get(k)
            .map_or(Mat4::IDENTITY, |b| *global * *b)
    }));
}

/// The positions with the morph targets applied, into `out` (cleared first), as Bevy's
/// `morph_vertex`: `p + Σ weight[t] * displacement[t][v]`, targets added in order, in the
/// mesh's own space.
///
/// A target of weight zero is skipped, as the shader skips it: its displacements are never
/// read, so non-finite ones there do no harm.
pub fn morph_positions(
    positions: &[Vec3],
    morph: MorphTargets<'_>,
    out: &mut Vec<Vec3>,
) -> Result<(), SkinningError> {
    morph_into(positions, morph, out)?;
    first_non_finite(out)
}

/// [`morph_positions`] without the finiteness check (skinning checks its own output).
fn morph_into(
    positions: &[Vec3],
    morph: MorphTargets<'_>,
    out: &mut Vec<Vec3>,
) -> Result<(), SkinningError> {
    let n = positions.len();
    // Saturating: a product that wraps could match a short slice and index out of it.
    let expected = morph.weights.len().saturating_mul(n);
    check_length(
        SkinningInput::MorphDisplacements,
        expected,
        morph.displacements.len(),
    )?;
    out.clear();
    out.extend_from_slice(positions);
    // Target-major, one target over all vertices at a time: each pass streams one slice
    // (a vertex-major loop would stride through every target's slice per vertex).
    for (&weight, target) in morph
        .weights
        .iter()
        .zip(morph.displacements.chunks_exact(n.max(1)))
    {
        if weight == 0.0 {
            continue;
        }
        for (p, d) in out.iter_mut().zip(target) {
            *p += weight * *d;
        }
    }
    Ok(())
}

/// The posed (world-space) positions of a skinned mesh, into `out` (cleared first; no
/// allocation when it has the capacity), as Bevy's vertex shader computes them.
///
/// Step by step as the shader: the morph targets first, if any (see [`morph_positions`]);
/// then per vertex the matrix `M = w.x * J[i.x] + w.y * J[i.y] + w.z * J[i.z] + w.w * J[i.w]`
/// (each matrix scaled, then summed in that order), and the position `(M * (p, 1)).xyz`, the
/// fourth component dropped. `joint_matrices` are the skin's (see [`joint_matrices`]); the
/// result is in world space, as Bevy ignores a skinned mesh entity's own transform.
///
/// An index past the joints with weight zero adds nothing (glTF files hold such padding);
/// with any other weight it is an error. Every error leaves `out` with unspecified contents.
pub fn skin_positions(
    vertices: &SkinnedVertices<'_>,
    joint_matrices: &[Mat4],
    morph: Option<MorphTargets<'_>>,
    out: &mut Vec<Vec3>,
) -> Result<(), SkinningError> {
    vertices.check_lengths()?;
    match morph {
        Some(morph) => morph_into(vertices.positions, morph, out)?,
        None => {
            out.clear();
            out.extend_from_slice(vertices.positions);
        }
    }
    let joint_count = joint_matrices.len();
    // One flag over all vertices instead of an early exit per vertex: the loop stays
    // branch-free on finiteness; the failing vertex is looked for only on failure.
    let mut finite = true;
    for (vertex, ((p, indices), weights)) in out
        .iter_mut()
        .zip(vertices.joint_indices)
        .zip(vertices.joint_weights)
        .enumerate()
    {
        let joint = |slot: usize| match joint_matrices.get(usize::from(indices[slot])) {
            Some(m) => Ok(*m),
            // The shader reads whatever its bounds policy gives there and scales it by
            // zero: nothing, for a finite matrix.
            None if weights[slot] == 0.0 => Ok(Mat4::ZERO),
            None => Err(SkinningError::JointOutOfRange {
                vertex,
                joint: indices[slot],
                joint_count,
            }),
        };
        let m = joint(0)? * weights[0]
            + joint(1)? * weights[1]
            + joint(2)? * weights[2]
            + joint(3)? * weights[3];
        *p = (m * p.extend(1.0)).truncate();
        finite &= p.is_finite();
    }
    if finite {
        Ok(())
    } else {
        first_non_finite(out)
    }
}

/// `Err(NonFinite)` naming the first non-finite position, if there is one.
fn first_non_finite(positions: &[Vec3]) -> Result<(), SkinningError> {
    match positions.iter().position(|p| !p.is_finite()) {
        Some(vertex) => Err(SkinningError::NonFinite { vertex }),
        None => Ok(()),
    }
}
