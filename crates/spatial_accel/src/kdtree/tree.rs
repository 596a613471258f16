//! The tree: its nodes, its leaves' triangles in leaf order, and how it is built from a mesh.

use super::KdTreeConfig;
use super::builder::build;
use super::node::{KdNode, KdNodeKind};
use super::split::Part;
use crate::Aabb;
use crate::mesh::MeshError;
use glam::{Vec3, Vec3A};

/// An SAH kd-tree over the triangles of one indexed mesh (Wald and Havran 2006, "On building
/// fast kd-trees for ray tracing, and on doing that in O(N log N)"), answering the exact
/// (watertight) queries of [`TriangleQuery`](crate::query::TriangleQuery).
///
/// Every node splits space at one axis-aligned plane, so children never overlap and a ray
/// walks the leaves it crosses front to back, stopping at the first leaf that starts beyond
/// its closest hit. A triangle that crosses a plane sits in both children, each time bounded
/// by its part clipped to that child ("perfect splits"), so leaves hold what is really in
/// them. Splits are priced by the surface area heuristic with a bonus for cutting off empty
/// space, and a node stays a leaf when no split is cheaper ([`KdTreeConfig`]). Triangles
/// with a non-finite corner are left out (they cannot be hit).
///
/// The three build algorithms of the paper ([`super::KdBuild`]) give the same tree.
///
/// ```
/// use spatial_accel::kdtree::KdTree;
/// use spatial_accel::query::TriangleQuery;
/// use spatial_accel::{Backfaces, Ray};
/// use glam::{Vec3, Vec3A};
/// // A unit quad in the z = 0 plane, facing +z.
/// let vertices = [Vec3::new(0., 0., 0.), Vec3::new(1., 0., 0.), Vec3::new(1., 1., 0.), Vec3::new(0., 1., 0.)];
/// let tree = KdTree::new(&vertices, &[0, 1, 2, 0, 2, 3]).unwrap();
/// let ray = Ray::new(Vec3A::new(0.25, 0.75, 5.0), Vec3A::NEG_Z);
/// let hit = tree.cast_ray(&ray, Backfaces::Cull).unwrap();
/// assert_eq!((hit.t, hit.triangle, hit.front_face), (5.0, 1, true));
/// ```
#[derive(Clone, Debug)]
pub struct KdTree {
    pub(super) nodes: Vec<KdNode>,
    /// Each leaf's triangle indices, leaf after leaf, increasing within a leaf.
    pub(super) references: Vec<u32>,
    /// The corners of `references[i]`'s triangle at `i`: a leaf's triangles are read in one
    /// stream instead of gathered through the index buffer.
    pub(super) corners: Vec<[Vec3A; 3]>,
    pub(super) bounds: Aabb,
    triangle_count: usize,
    stats: KdTreeStats,
}

/// What a build made, for benchmarks and overlays.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct KdTreeStats {
    /// Nodes, interior and leaf.
    pub nodes: usize,
    /// Leaves.
    pub leaves: usize,
    /// Leaves with no triangle (the empty space the splits cut off).
    pub empty_leaves: usize,
    /// Triangle references in the leaves: the finite triangles, plus one more each time a
    /// split sent a triangle to both sides and clipping found some of it on each.
    pub references: usize,
    /// Times a split sent a triangle to both sides.
    pub straddled: usize,
    /// Of those, sides on which clipping found nothing of the triangle, so no reference was
    /// made there.
    pub clipped_away: usize,
    /// Depth of the deepest leaf (the root is depth 0).
    pub depth: u32,
}

impl KdTree {
    /// Builds with [`KdTreeConfig::default`] (the event sweep).
    pub fn new(vertices: &[Vec3], indices: &[u32]) -> Result<Self, MeshError> {
        Self::with_config(vertices, indices, &KdTreeConfig::default())
    }

    /// Builds with a chosen configuration. Fails on an index list that is not a list of
    /// triangles or names a vertex that does not exist.
    pub fn with_config(
        vertices: &[Vec3],
        indices: &[u32],
        config: &KdTreeConfig,
    ) -> Result<Self, MeshError> {
        if !indices.len().is_multiple_of(3) {
            return Err(MeshError::NotATriangleList {
                index_count: indices.len(),
            });
        }
        if let Some(&index) = indices.iter().find(|&&i| i as usize >= vertices.len()) {
            return Err(MeshError::IndexOutOfRange {
                index,
                vertex_count: vertices.len(),
            });
        }
        let corners: Vec<[Vec3A; 3]> = indices
            .chunks_exact(3)
            .map(|t| [0, 1, 2].map(|k| Vec3A::from(vertices[t[k] as usize])))
            .collect();
        let parts: Vec<Part> = corners
            .iter()
            .enumerate()
            .filter(|(_, c)| c.iter().all(|v| v.is_finite()))
            .map(|(t, c)| Part::new(t as u32, Aabb::from_points(*c)))
            .collect();
        let bounds = parts.iter().fold(Aabb::EMPTY, |b, p| b.union(&p.bounds));
        let built = build(&corners, parts, &bounds, config);
        let leaf_corners = built
            .references
            .iter()
            .map(|&t| corners[t as usize])
            .collect();
        let mut tree = Self {
            nodes: built.nodes,
            references: built.references,
            corners: leaf_corners,
            bounds,
            triangle_count: corners.len(),
            stats: KdTreeStats {
                straddled: built.straddled,
                clipped_away: built.clipped_away,
                ..KdTreeStats::default()
            },
        };
        tree.count_nodes();
        Ok(tree)
    }

    /// Fills in the node counts and depth of the stats.
    fn count_nodes(&mut self) {
        let s = &mut self.stats;
        s.nodes = self.nodes.len();
        s.references = self.references.len();
        let mut stack = vec![(0usize, 0u32)];
        while let Some((n, depth)) = stack.pop() {
            match self.nodes[n].kind() {
                KdNodeKind::Interior { above, .. } => {
                    stack.push((n + 1, depth + 1));
                    stack.push((above as usize, depth + 1));
                }
                KdNodeKind::Leaf { count, .. } => {
                    s.leaves += 1;
                    s.empty_leaves += usize::from(count == 0);
                    s.depth = s.depth.max(depth);
                }
            }
        }
    }

    /// The box around every finite triangle: the root's region.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Number of triangles in the mesh it was built over (non-finite ones included).
    pub fn triangle_count(&self) -> usize {
        self.triangle_count
    }

    /// The nodes, depth first from the root at 0 (see [`KdNode`]).
    pub fn nodes(&self) -> &[KdNode] {
        &self.nodes
    }

    /// The leaves' triangle indices: a leaf `{ first, count }` holds
    /// `leaf_references()[first..first + count]`, in increasing order.
    pub fn leaf_references(&self) -> &[u32] {
        &self.references
    }

    /// What the build made: node, leaf and reference counts, straddling, depth.
    pub fn stats(&self) -> KdTreeStats {
        self.stats
    }

    /// Memory held, in bytes: the nodes, the references and their leaf-ordered corners.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.capacity() * size_of::<KdNode>()
            + self.references.capacity() * size_of::<u32>()
            + self.corners.capacity() * size_of::<[Vec3A; 3]>()
    }
}
