//! A box around a skinned mesh's posed vertices from its joints alone, without skinning them.

use super::skinning::{SkinnedVertices, SkinningError, SkinningInput, check_length};
use crate::Aabb;
use glam::{Mat3A, Mat4, Vec3, Vec3A};

/// What a skinned mesh's vertices need to be bounded in any pose from the joint matrices
/// alone: per joint, the box of the vertices it moves; the reach of each morph target; and
/// how large the vertices' weights are. Computed once per mesh asset (a pass over its
/// vertices); [`SkinBounds::bound`] then costs a few operations per joint and per target,
/// where skinning costs a matrix blend per vertex: a broad phase can skip the meshes a ray
/// misses without posing them.
///
/// # Why the bound holds
///
/// Take one axis, and a vertex `v` whose slots `s` (up to four) weight joint `k_s` by `w_s`
/// (zero-weight slots add nothing and are left out). Its morphed position `p'` is its bind
/// position `p` moved by at most `Σ_t |W_t| * D_t` on each axis (`W_t` the pose's target
/// weights, `D_t` the largest displacement of target `t` on that axis), so `p'` lies in
/// `B_k` grown by that reach, for every joint `k` of its slots (`B_k` being the box of the
/// bind positions of the vertices with a non-zero weight on `k`). The posed position is
/// `Σ_s w_s * A_s(p')` where `A_s` is the affine map of the first three rows of `J[k_s]`
/// (the shader's blended matrix is linear in the joints' matrices, and the fourth row is
/// dropped). An affine map takes a box into the hull of its eight corners' images, so each
/// `a_s = A_s(p')` lies in `[lo, hi]`, the box of all joints' transformed corners.
/// Split the slots by the sign of their weight: with `P = Σ_{w_s > 0} w_s`,
/// `Σ_{w_s > 0} w_s a_s = P * (a convex combination of the a_s)` lies in `P * [lo, hi]`; with
/// `N = Σ_{w_s < 0} |w_s|`, the other slots' sum lies in `-N * [lo, hi]`. Over all vertices
/// `P` and `N` range over `[P_min, P_max]` and `[N_min, N_max]`, so the posed position lies
/// in `[P_min, P_max] * [lo, hi] - [N_min, N_max] * [lo, hi]` (interval arithmetic), for any
/// finite weights. For glTF weights (in `[0, 1]`, summing to one) `N = 0` and `P = 1`: the
/// bound is the box of the transformed joint boxes, which is as tight as it can be from
/// boxes alone; weights summing to less than one pull the vertices towards the origin, and
/// the bound grows towards it with them.
///
/// The argument is exact arithmetic; the skinning and the bound are both computed in `f32`.
/// Every rounding of either is at most a few units in the last place of the terms it adds,
/// each no larger than `|J| * (|p'|, 1)` (the absolute matrix times the absolute position),
/// times the summed absolute weights. The bound is grown by a multiple of that magnitude
/// large enough for every rounding on the way (the morph sum's grows with the target count),
/// so that an `f32` posed vertex lies inside too.
#[derive(Clone, Debug)]
pub struct SkinBounds {
    /// Per joint that moves some vertex, in joint order: the joint, the box of the bind
    /// positions of the vertices that give it a non-zero weight, and the first of those
    /// vertices. Only those joints: a piece of a mesh (see `SkinSegments`) names a few joints
    /// of many, and its bound reads only these entries.
    joints: Vec<(u16, Aabb, usize)>,
    /// Per morph target, its largest displacement on each axis, in absolute value.
    morph_reach: Vec<Vec3A>,
    vertex_count: usize,
    /// The least and the largest sum of a vertex's positive weights.
    positive: [f32; 2],
    /// The least and the largest sum of a vertex's negative weights, in absolute value.
    negative: [f32; 2],
    /// Whether every weight in use and the position it moves are finite.
    finite: bool,
}

impl SkinBounds {
    /// The bounds of a skinned mesh with `target_count` morph targets, whose displacements
    /// are laid out target-major as in [`MorphTargets`](super::MorphTargets) (empty for a
    /// mesh without targets).
    ///
    /// A joint index past the skin is caught by [`SkinBounds::bound`], which knows the
    /// joint count.
    pub fn new(
        vertices: &SkinnedVertices<'_>,
        morph_displacements: &[Vec3],
        target_count: usize,
    ) -> Result<Self, SkinningError> {
        vertices.check_lengths()?;
        let n = vertices.vertex_count();
        check_length(
            SkinningInput::MorphDisplacements,
            target_count.saturating_mul(n),
            morph_displacements.len(),
        )?;
        let mut by_joint: Vec<(Aabb, usize)> = Vec::new();
        let (mut positive, mut negative) = ([f32::INFINITY, 0.0], [f32::INFINITY, 0.0]);
        let mut finite = true;
        for (vertex, ((p, indices), weights)) in vertices
            .positions
            .iter()
            .zip(vertices.joint_indices)
            .zip(vertices.joint_weights)
            .enumerate()
        {
            let (mut pos, mut neg) = (0.0f32, 0.0f32);
            for (&joint, &w) in indices.iter().zip(weights) {
                if w == 0.0 {
                    continue;
                }
                let joint = usize::from(joint);
                if joint >= by_joint.len() {
                    by_joint.resize(joint + 1, (Aabb::EMPTY, usize::MAX));
                }
                let (bind, first) = &mut by_joint[joint];
                *bind = bind.grow(*p);
                *first = (*first).min(vertex);
                if w > 0.0 {
                    pos += w;
                } else {
                    neg -= w;
                }
                // Skinning such a vertex fails; min and max would pass a NaN over silently
                // and bound a pose that does not exist.
                finite &= w.is_finite() && p.is_finite();
            }
            positive = [positive[0].min(pos), positive[1].max(pos)];
            negative = [negative[0].min(neg), negative[1].max(neg)];
        }
        // `by_joint` is indexed by `u16` joint numbers, so each index fits one.
        let joints = by_joint
            .into_iter()
            .enumerate()
            .filter(|(_, (bind, _))| !bind.is_empty())
            .map(|(joint, (bind, first))| (joint as u16, bind, first))
            .collect();
        let morph_reach = morph_displacements
            .chunks_exact(n.max(1))
            .map(|target| {
                target.iter().fold(Vec3A::ZERO, |reach, d| {
                    // A NaN displacement reaches everywhere: `max` would drop it.
                    let d = Vec3A::from(*d).abs();
                    reach.max(Vec3A::select(d.is_nan_mask(), Vec3A::INFINITY, d))
                })
            })
            .collect();
        Ok(Self {
            joints,
            morph_reach,
            vertex_count: n,
            positive,
            negative,
            finite,
        })
    }

    /// The number of morph targets.
    pub fn target_count(&self) -> usize {
        self.morph_reach.len()
    }

    /// A box around every posed vertex of the pose that `joint_matrices` (see
    /// [`joint_matrices`](super::joint_matrices)) and `morph_weights` (one per target; empty
    /// for a mesh without targets) give, as [`skin_positions`](super::skin_positions) would
    /// pose them, for any finite weights (see the type's documentation for the proof).
    ///
    /// Empty for a mesh without vertices. Errors: a joint with a non-zero weight past
    /// `joint_matrices`, a wrong number of morph weights, or a non-finite box (a non-finite
    /// matrix of a joint that moves vertices, or a non-finite morph weight or reach).
    pub fn bound(
        &self,
        joint_matrices: &[Mat4],
        morph_weights: &[f32],
    ) -> Result<Aabb, SkinningError> {
        check_length(
            SkinningInput::MorphWeights,
            self.morph_reach.len(),
            morph_weights.len(),
        )?;
        if self.vertex_count == 0 {
            return Ok(Aabb::EMPTY);
        }
        // Zero-weight targets are skipped as skinning skips them: their displacements may
        // be non-finite.
        let reach = morph_weights
            .iter()
            .zip(&self.morph_reach)
            .filter(|(w, _)| **w != 0.0)
            .fold(Vec3A::ZERO, |reach, (w, d)| reach + w.abs() * *d);
        let (mut lo, mut hi) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
        let mut magnitude = Vec3A::ZERO;
        for &(joint, bind, vertex) in &self.joints {
            let m =
                joint_matrices
                    .get(usize::from(joint))
                    .ok_or(SkinningError::JointOutOfRange {
                        vertex,
                        joint,
                        joint_count: joint_matrices.len(),
                    })?;
            if !m.is_finite() {
                // `min` and `max` would drop a NaN corner and bound a pose that fails.
                return Err(SkinningError::NonFiniteBound);
            }
            let bind = bind.expanded(reach);
            // The box of the box's image, from its centre and half extents (Arvo 1990): a
            // quarter of the work of transforming its eight corners, and this runs for every
            // joint of every skinned entity a ray's first pass reads. Its rounding differs
            // from the corners' by a few ulps of `magnitude`, inside the pad below.
            let linear = Mat3A::from_mat4(*m);
            let center = linear * bind.center() + Vec3A::from_vec4(m.w_axis);
            let half = abs_matrix(&linear) * bind.half_extents();
            (lo, hi) = (lo.min(center - half), hi.max(center + half));
            let size = bind.min.abs().max(bind.max.abs());
            magnitude = magnitude.max(Vec3A::from_vec4(m.abs() * size.extend(1.0)));
        }
        if lo.cmpgt(hi).any() {
            // No vertex has a non-zero weight: every one is posed at the origin.
            return Ok(Aabb::from_point(Vec3A::ZERO));
        }
        let (plo, phi) = scale_interval(self.positive, lo, hi);
        let (nlo, nhi) = scale_interval(self.negative, lo, hi);
        let (lo, hi) = (plo - nhi, phi - nlo);
        // Rounding (see the type's documentation): the morph sum's error grows with the
        // target count, the blend's and the bound's own with a fixed number of operations;
        // twice their first-order sum covers the higher orders, and an absolute term the
        // underflow of subnormal results.
        let operations = (self.morph_reach.len() + 16) as f32;
        let weight = self.positive[1] + self.negative[1];
        let pad = 2.0 * operations * f32::EPSILON * weight * magnitude
            + Vec3A::splat(16.0 * f32::MIN_POSITIVE);
        let bound = Aabb::new(lo - pad, hi + pad);
        if bound.is_finite() && self.finite {
            Ok(bound)
        } else {
            Err(SkinningError::NonFiniteBound)
        }
    }
}

/// The matrix of the absolute values of `m`'s entries.
fn abs_matrix(m: &Mat3A) -> Mat3A {
    Mat3A::from_cols(m.x_axis.abs(), m.y_axis.abs(), m.z_axis.abs())
}

/// `[s0, s1] * [lo, hi]` per axis in interval arithmetic: the least and largest of the four
/// products.
fn scale_interval([s0, s1]: [f32; 2], lo: Vec3A, hi: Vec3A) -> (Vec3A, Vec3A) {
    let (a, b, c, d) = (lo * s0, lo * s1, hi * s0, hi * s1);
    (a.min(b).min(c).min(d), a.max(b).max(c).max(d))
}
