//! The tree: nodes, the triangles cut to fit them, and what the build counted.

use super::BspConfig;
use super::build::build;
use super::plane::{BspPlane, double_area, is_degenerate, tolerance_for_scale};
use crate::mesh::MeshError;
use crate::query::mesh_triangles;
use crate::{Aabb, Triangle};
use glam::{Vec3, Vec3A};

/// No child.
pub(super) const NONE: u32 = u32::MAX;

/// One triangle of the tree: a source triangle of the mesh, or a piece cut from one, with
/// the source's winding.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BspPiece {
    /// The corners, in the source's winding order.
    pub vertices: [Vec3A; 3],
    /// The index of the source triangle in the mesh's index buffer.
    pub source: u32,
}

impl BspPiece {
    /// The area, in `f64`.
    pub fn area(&self) -> f64 {
        double_area(&self.vertices) / 2.0
    }
}

/// A node: a plane, the pieces lying in it, and the subtrees on either side.
#[derive(Clone, Copy, Debug)]
pub(super) struct BspNode {
    pub(super) plane: BspPlane,
    /// The source triangle whose plane it is.
    pub(super) source: u32,
    /// The node's own pieces: `pieces[first..first + count]`.
    pub(super) first: u32,
    pub(super) count: u32,
    /// The subtree in front of the plane, or [`NONE`].
    pub(super) front: u32,
    /// The subtree behind it, or [`NONE`].
    pub(super) back: u32,
    /// A box around every piece of the subtree, grown by the tree's margin.
    pub(super) bounds: Aabb,
    /// Whether the depth limit stopped the build here (the list then holds every piece that
    /// reached the node, coplanar or not).
    pub(super) depth_limited: bool,
}

impl BspNode {
    /// A node whose plane and pieces are still to be chosen.
    pub(super) fn placeholder() -> Self {
        Self {
            plane: BspPlane::EVERYWHERE,
            source: 0,
            first: 0,
            count: 0,
            front: NONE,
            back: NONE,
            bounds: Aabb::EMPTY,
            depth_limited: false,
        }
    }

    /// The range of the node's own pieces.
    pub(super) fn range(&self) -> core::ops::Range<usize> {
        self.first as usize..(self.first + self.count) as usize
    }
}

/// The shape of a built tree.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BspStats {
    /// Source triangles in the tree.
    pub sources: usize,
    /// Finite triangles left out as degenerate (thinner than the tolerance): not in the
    /// tree's orders, still hit by rays and found by box queries.
    pub degenerate: usize,
    /// Triangles left out for a non-finite corner (never hit, as brute force does).
    pub non_finite: usize,
    /// Pieces in the tree (source triangles whole or cut).
    pub pieces: usize,
    /// Times a plane cut a triangle.
    pub splits: usize,
    /// Nodes.
    pub nodes: usize,
    /// Nodes on the longest path from the root (the root alone is depth 1).
    pub depth: usize,
    /// The most pieces one source triangle was cut into.
    pub max_pieces_per_source: usize,
    /// Pieces in nodes the depth limit stopped, which the orders give in no particular order.
    pub depth_limited: usize,
}

impl BspStats {
    /// Pieces per source triangle on average (1 when nothing was cut).
    pub fn pieces_per_source(&self) -> f64 {
        self.pieces as f64 / self.sources.max(1) as f64
    }
}

/// A polygon-aligned BSP tree over the triangles of one mesh (Fuchs, Kedem and Naylor 1980).
///
/// Each node's plane is the plane of one of its triangles; the triangles lying in it (either
/// facing) are the node's own, and the rest go to the side they are on, cut in two where
/// they straddle it ([`BspConfig`] says how planes are chosen). From any eye point the tree
/// then gives every piece in an order a painter can draw in
/// ([`BspTree::back_to_front`]), and it answers ray and box queries
/// ([`TriangleQuery`](crate::query::TriangleQuery)) with the source triangles' indices,
/// exactly as [`BruteForceMesh`](crate::query::BruteForceMesh) does.
///
/// **Robustness.** A point is on a plane within one tolerance
/// ([`RELATIVE_TOLERANCE`](super::RELATIVE_TOLERANCE) of the largest coordinate),
/// classified from its own coordinates alone, so triangles sharing a vertex agree on its
/// side; a crossing point is computed once per edge from its end points in one order, so
/// triangles sharing the edge share the point. Triangles thinner than the tolerance and
/// triangles with a non-finite corner are left out of the tree and counted.
///
/// ```
/// use spatial_accel::bsp::BspTree;
/// use glam::{Vec3, Vec3A};
/// // Two unit triangles, one at z = 0 and one at z = -1, both facing +z.
/// let vertices = [
///     Vec3::ZERO, Vec3::X, Vec3::Y,
///     Vec3::NEG_Z, Vec3::new(1.0, 0.0, -1.0), Vec3::new(0.0, 1.0, -1.0),
/// ];
/// let tree = BspTree::new(&vertices, &[0, 1, 2, 3, 4, 5]).unwrap();
/// let mut order = Vec::new();
/// tree.back_to_front(Vec3A::new(0.2, 0.2, 5.0), &mut order);
/// let sources: Vec<u32> = order.iter().map(|&p| tree.pieces()[p as usize].source).collect();
/// assert_eq!(sources, [1, 0]);
/// ```
#[derive(Clone, Debug, Default)]
pub struct BspTree {
    pub(super) nodes: Vec<BspNode>,
    pub(super) pieces: Vec<BspPiece>,
    /// Triangle `i` of the index buffer, `None` when a corner is not finite.
    pub(super) sources: Vec<Option<Triangle>>,
    /// The finite triangles left out of the tree as degenerate, which every query tests
    /// directly (rounding can still make one hit, and brute force tests it).
    pub(super) loose: Vec<u32>,
    pub(super) bounds: Aabb,
    pub(super) tolerance: f64,
    pub(super) stats: BspStats,
}

impl BspTree {
    /// The tree over an indexed triangle list (triangle `i` uses `indices[3i..3i + 3]`), with
    /// the default [`BspConfig`].
    pub fn new(vertices: &[Vec3], indices: &[u32]) -> Result<Self, MeshError> {
        Self::with_config(vertices, indices, &BspConfig::default())
    }

    /// The tree over an indexed triangle list, its planes chosen as `config` says.
    pub fn with_config(
        vertices: &[Vec3],
        indices: &[u32],
        config: &BspConfig,
    ) -> Result<Self, MeshError> {
        let sources = mesh_triangles(vertices, indices)?;
        let finite = || sources.iter().flatten();
        let bounds = finite().fold(Aabb::EMPTY, |b, t| b.union(&t.aabb()));
        let scale = finite()
            .flat_map(|t| t.vertices)
            .map(|v| v.abs().max_element())
            .fold(0.0f32, f32::max);
        let tolerance = tolerance_for_scale(f64::from(scale));
        let mut stats = BspStats::default();
        let (mut planes, mut pieces, mut loose) = (Vec::new(), Vec::new(), Vec::new());
        for (i, source) in sources.iter().enumerate() {
            let plane = match source {
                None => {
                    stats.non_finite += 1;
                    None
                }
                Some(t) if is_degenerate(&t.vertices, tolerance) => {
                    stats.degenerate += 1;
                    loose.push(i as u32);
                    None
                }
                Some(t) => BspPlane::from_triangle(&t.vertices),
            };
            if let (Some(t), Some(_)) = (source, plane) {
                pieces.push(BspPiece {
                    vertices: t.vertices,
                    source: i as u32,
                });
            }
            planes.push(plane.unwrap_or(BspPlane::EVERYWHERE));
        }
        stats.sources = pieces.len();
        // The node boxes' margin: far above the rounding of a split point (a piece may miss
        // its source's edge by that much), so a ray that hits the source near a cut still
        // finds a box holding a piece there.
        let margin = tolerance as f32;
        let built = build(pieces, &planes, tolerance, margin, config);
        stats.pieces = built.pieces.len();
        stats.splits = built.splits;
        stats.nodes = built.nodes.len();
        stats.depth = built.depth;
        stats.depth_limited = built.depth_limited;
        let mut per_source = vec![0usize; sources.len()];
        for p in &built.pieces {
            per_source[p.source as usize] += 1;
        }
        stats.max_pieces_per_source = per_source.into_iter().max().unwrap_or(0);
        Ok(Self {
            nodes: built.nodes,
            pieces: built.pieces,
            sources,
            loose,
            bounds,
            tolerance,
            stats,
        })
    }

    /// Every piece of the tree; the orders list indices into it.
    pub fn pieces(&self) -> &[BspPiece] {
        &self.pieces
    }

    /// Source triangle `i` as given, or `None` when a corner is not finite or `i` is out of
    /// range.
    pub fn source_triangle(&self, i: u32) -> Option<Triangle> {
        self.sources.get(i as usize).copied().flatten()
    }

    /// The classification tolerance of this tree, in the mesh's units (see
    /// [`RELATIVE_TOLERANCE`](super::RELATIVE_TOLERANCE)).
    pub fn tolerance(&self) -> f64 {
        self.tolerance
    }

    /// What the build counted: splits, nodes, depth, pieces per source, triangles left out.
    pub fn stats(&self) -> BspStats {
        self.stats
    }

    /// The indices of the finite triangles left out of the tree as degenerate.
    pub fn degenerate_triangles(&self) -> &[u32] {
        &self.loose
    }
}
