//! A skinned mesh cut into segments by joint, and each segment into pieces, for rays that
//! meet each pose once.
//!
//! An animated character changes pose every frame, and a pointer casts one ray a frame: a
//! posed tree ([`PosedMeshBvh`](super::PosedMeshBvh)) is then skinned whole and refit for a
//! single ray, which costs more than testing the bind pose's every triangle. Here each
//! triangle belongs to the segment of the joint that weighs most on its first corner (a
//! forearm, a shin), and each segment is cut, by halving its triangles along the longest
//! axis of their bind-pose centres, into pieces of at most [`PIECE_TRIANGLES`]. Every box
//! comes from its joints' matrices alone ([`SkinBounds`]). A ray takes the boxes of the
//! segments it meets, then of their pieces, and skins and tests only the pieces whose box it
//! meets, nearest first, stopping once the next box lies beyond the nearest hit. A ray that
//! reaches a character's arm skins the part of the arm around it, not the character.

use super::hit::MeshHit;
use super::skin_bounds::SkinBounds;
use super::skinning::{MorphTargets, SkinnedVertices, SkinningError, check_length, skin_positions};
use crate::geometry::{Backfaces, Ray, Triangle};
use glam::{Mat4, Vec3, Vec3A};
use std::ops::Range;

/// The most triangles a piece holds. Why pieces at all: a joint's segment of a 5k-triangle
/// character holds hundreds of triangles, and a ray that reaches its box skinned and tested
/// them all; a piece's box costs a few joints' box transforms, so a ray pays for the boxes of
/// the segments it reaches and for the few pieces inside them it meets (BENCHMARKS.md,
/// Skinned picking).
const PIECE_TRIANGLES: usize = 32;

/// Some triangles of one segment, with their own copy of the vertices they use.
#[derive(Clone, Debug)]
struct Piece {
    positions: Vec<Vec3>,
    joint_indices: Vec<[u16; 4]>,
    joint_weights: Vec<[f32; 4]>,
    /// Morph displacements of the piece's vertices, target-major.
    morph: Vec<Vec3>,
    /// Each triangle: its index in the mesh, and its corners among the piece's vertices.
    triangles: Vec<(u32, [u32; 3])>,
    bounds: SkinBounds,
}

/// One joint's triangles: the box of all of them, and the pieces they were cut into.
#[derive(Clone, Debug)]
struct Segment {
    bounds: SkinBounds,
    pieces: Range<usize>,
}

/// A skinned mesh's triangles by segment, for [`SkinSegments::cast_ray`].
///
/// ```
/// use glam::{Mat4, Vec3, Vec3A};
/// use spatial_accel::mesh::{SkinSegments, SkinnedVertices};
/// use spatial_accel::{Backfaces, Ray};
///
/// // A square of two triangles, each corner on joint 0 or joint 1.
/// let positions = [Vec3::new(0., 0., 0.), Vec3::new(1., 0., 0.), Vec3::new(1., 1., 0.), Vec3::new(0., 1., 0.)];
/// let joints = [[0u16; 4], [0; 4], [1; 4], [1; 4]];
/// let weights = [[1.0, 0.0, 0.0, 0.0]; 4];
/// let vertices = SkinnedVertices { positions: &positions, joint_indices: &joints, joint_weights: &weights };
/// let segments = SkinSegments::new(&vertices, &[], 0, &[0, 1, 2, 0, 2, 3]).unwrap();
/// // Joint 1 lifts its corners by 1 along z.
/// let pose = [Mat4::IDENTITY, Mat4::from_translation(Vec3::Z)];
/// let ray = Ray::new(Vec3A::new(0.2, 0.9, 5.0), Vec3A::NEG_Z);
/// let hit = segments.cast_ray(&ray, Backfaces::Cull, &vertices, &pose, &[], &mut Vec::new()).unwrap().unwrap();
/// assert_eq!(hit.triangle, 1);
/// ```
#[derive(Clone, Debug)]
pub struct SkinSegments {
    segments: Vec<Segment>,
    pieces: Vec<Piece>,
    vertex_count: usize,
    target_count: usize,
}

impl SkinSegments {
    /// Cuts a skinned mesh (its attributes, its morph targets' displacements laid out as in
    /// [`MorphTargets`], and its triangle list) into segments. Errors: attributes of unequal
    /// lengths, or a triangle that names a vertex past the mesh's (or is cut short).
    pub fn new(
        vertices: &SkinnedVertices<'_>,
        morph_displacements: &[Vec3],
        target_count: usize,
        indices: &[u32],
    ) -> Result<Self, SkinningError> {
        vertices.check_lengths()?;
        let n = vertices.vertex_count();
        check_length(
            super::skinning::SkinningInput::MorphDisplacements,
            n * target_count,
            morph_displacements.len(),
        )?;
        if let Some(triangle) = indices
            .chunks(3)
            .position(|t| t.len() < 3 || t.iter().any(|&i| i as usize >= n))
        {
            return Err(SkinningError::BadTriangle { triangle });
        }
        // The joint of most weight on each triangle's first corner names its segment.
        let dominant = |v: usize| {
            let (w, j) = (vertices.joint_weights[v], vertices.joint_indices[v]);
            (0..4)
                .max_by(|&a, &b| w[a].abs().total_cmp(&w[b].abs()))
                .map_or(0, |k| j[k])
        };
        let mut by_joint: std::collections::BTreeMap<u16, Vec<u32>> = Default::default();
        for t in 0..(indices.len() / 3) as u32 {
            by_joint
                .entry(dominant(indices[3 * t as usize] as usize))
                .or_default()
                .push(t);
        }
        let mut segments = Vec::with_capacity(by_joint.len());
        let mut pieces = Vec::new();
        let mut cutter = Cutter {
            vertices,
            morph_displacements,
            target_count,
            indices,
            local: vec![u32::MAX; n],
        };
        for mut triangles in by_joint.into_values() {
            let bounds = cutter.piece_of(&triangles)?.bounds;
            let first = pieces.len();
            // Three times the triangle's centre: only the order along an axis matters.
            let centre = |t: u32| {
                let i = 3 * t as usize;
                indices[i..i + 3]
                    .iter()
                    .map(|&v| Vec3A::from(vertices.positions[v as usize]))
                    .sum::<Vec3A>()
            };
            for range in cut_in_pieces(&mut triangles, &centre) {
                pieces.push(cutter.piece_of(&triangles[range])?);
            }
            segments.push(Segment {
                bounds,
                pieces: first..pieces.len(),
            });
        }
        Ok(Self {
            segments,
            pieces,
            vertex_count: n,
            target_count,
        })
    }

    /// The number of segments (one per joint that weighs most on some triangle).
    pub fn segment_count(&self) -> usize {
        self.segments.len()
    }

    /// The number of pieces the segments were cut into.
    pub fn piece_count(&self) -> usize {
        self.pieces.len()
    }

    /// The nearest hit of `ray` on the mesh posed by `joint_matrices` (see
    /// [`joint_matrices`](super::joint_matrices)) and `morph_weights` (one per target),
    /// exactly as [`skin_positions`] would pose it, triangle numbers as in the mesh.
    /// `vertices` must be the attributes the segments were cut from (only their count is
    /// checked); `scratch` holds a piece's posed vertices between calls. Errors: those of
    /// [`skin_positions`] and [`SkinBounds::bound`] for the segments and pieces the ray
    /// reaches.
    pub fn cast_ray(
        &self,
        ray: &Ray,
        backfaces: Backfaces,
        vertices: &SkinnedVertices<'_>,
        joint_matrices: &[Mat4],
        morph_weights: &[f32],
        scratch: &mut Vec<Vec3>,
    ) -> Result<Option<MeshHit>, SkinningError> {
        check_length(
            super::skinning::SkinningInput::PosedPositions,
            self.vertex_count,
            vertices.vertex_count(),
        )?;
        check_length(
            super::skinning::SkinningInput::MorphWeights,
            self.target_count,
            morph_weights.len(),
        )?;
        // Pieces by entry into their posed box, nearest first; only the pieces of segments
        // whose box the ray meets.
        let mut reached: Vec<(f32, usize)> = Vec::new();
        for segment in &self.segments {
            let bound = segment.bounds.bound(joint_matrices, morph_weights)?;
            if ray.intersect_aabb(&bound).is_none() {
                continue;
            }
            for i in segment.pieces.clone() {
                let bound = self.pieces[i].bounds.bound(joint_matrices, morph_weights)?;
                if let Some(entry) = ray.intersect_aabb(&bound) {
                    reached.push((entry, i));
                }
            }
        }
        reached.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut ray = *ray;
        let mut best: Option<MeshHit> = None;
        for (entry, i) in reached {
            if best.is_some_and(|b| entry > b.t) {
                break;
            }
            let piece = &self.pieces[i];
            let morph = (self.target_count > 0).then_some(MorphTargets {
                weights: morph_weights,
                displacements: &piece.morph,
            });
            let piece_vertices = SkinnedVertices {
                positions: &piece.positions,
                joint_indices: &piece.joint_indices,
                joint_weights: &piece.joint_weights,
            };
            skin_positions(&piece_vertices, joint_matrices, morph, scratch)?;
            for &(triangle, [a, b, c]) in &piece.triangles {
                let [a, b, c] = [a, b, c].map(|v| scratch[v as usize]);
                let Some(hit) = Triangle::new(a, b, c).intersect(&ray, backfaces) else {
                    continue;
                };
                // Nearest wins; on a tie the lower triangle number, whichever piece holds
                // it, so the answer does not depend on how the mesh was cut.
                if best.is_some_and(|b| hit.t > b.t || (hit.t == b.t && triangle > b.triangle)) {
                    continue;
                }
                let normal =
                    (Vec3A::from(b) - Vec3A::from(a)).cross(Vec3A::from(c) - Vec3A::from(a));
                best = Some(MeshHit {
                    t: hit.t,
                    triangle,
                    barycentrics: hit.barycentrics(),
                    geometric_normal: normal.normalize_or_zero(),
                    front_face: hit.front_face,
                });
                ray.t_max = hit.t;
            }
        }
        Ok(best)
    }
}

/// What cutting a mesh into pieces reads, and a vertex map reused from piece to piece.
struct Cutter<'a> {
    vertices: &'a SkinnedVertices<'a>,
    morph_displacements: &'a [Vec3],
    target_count: usize,
    indices: &'a [u32],
    /// Each mesh vertex's index in the piece being made, `u32::MAX` outside it.
    local: Vec<u32>,
}

impl Cutter<'_> {
    /// The piece of `triangles` (numbers in the mesh), with the box of its vertices.
    fn piece_of(&mut self, triangles: &[u32]) -> Result<Piece, SkinningError> {
        let (vertices, n) = (self.vertices, self.vertices.vertex_count());
        let mut used: Vec<u32> = Vec::new();
        let mut corners = Vec::with_capacity(triangles.len());
        for &t in triangles {
            let tri = &self.indices[3 * t as usize..3 * t as usize + 3];
            corners.push((
                t,
                [0, 1, 2].map(|k| {
                    let v = tri[k] as usize;
                    if self.local[v] == u32::MAX {
                        self.local[v] = used.len() as u32;
                        used.push(v as u32);
                    }
                    self.local[v]
                }),
            ));
        }
        for &v in &used {
            self.local[v as usize] = u32::MAX;
        }
        let pick = |v: &u32| *v as usize;
        let positions: Vec<Vec3> = used.iter().map(|v| vertices.positions[pick(v)]).collect();
        let joint_indices: Vec<[u16; 4]> = used
            .iter()
            .map(|v| vertices.joint_indices[pick(v)])
            .collect();
        let joint_weights: Vec<[f32; 4]> = used
            .iter()
            .map(|v| vertices.joint_weights[pick(v)])
            .collect();
        let displacements = self.morph_displacements;
        let morph: Vec<Vec3> = (0..self.target_count)
            .flat_map(|t| used.iter().map(move |v| displacements[t * n + pick(v)]))
            .collect();
        let piece_vertices = SkinnedVertices {
            positions: &positions,
            joint_indices: &joint_indices,
            joint_weights: &joint_weights,
        };
        let bounds = SkinBounds::new(&piece_vertices, &morph, self.target_count)?;
        Ok(Piece {
            positions,
            joint_indices,
            joint_weights,
            morph,
            triangles: corners,
            bounds,
        })
    }
}

/// Orders `triangles` so that consecutive runs of at most [`PIECE_TRIANGLES`] lie close
/// together, and returns the runs: each part is halved at the median of its triangles'
/// `centre`s along their widest axis, until it is small enough. The order depends only on
/// the input (ties go by triangle number), so a mesh is always cut the same way.
fn cut_in_pieces(triangles: &mut [u32], centre: &impl Fn(u32) -> Vec3A) -> Vec<Range<usize>> {
    let mut pieces = Vec::new();
    let mut parts: Vec<Range<usize>> = Vec::new();
    parts.push(0..triangles.len());
    while let Some(part) = parts.pop() {
        if part.len() <= PIECE_TRIANGLES {
            if !part.is_empty() {
                pieces.push(part);
            }
            continue;
        }
        let slice = &mut triangles[part.clone()];
        let (lo, hi) = slice
            .iter()
            .fold((Vec3A::INFINITY, Vec3A::NEG_INFINITY), |(lo, hi), &t| {
                (lo.min(centre(t)), hi.max(centre(t)))
            });
        let extent = hi - lo;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let mid = slice.len() / 2;
        slice.select_nth_unstable_by(mid, |&a, &b| {
            centre(a)[axis].total_cmp(&centre(b)[axis]).then(a.cmp(&b))
        });
        parts.push(part.start + mid..part.end);
        parts.push(part.start..part.start + mid);
    }
    pieces.sort_by_key(|r| r.start);
    pieces
}
