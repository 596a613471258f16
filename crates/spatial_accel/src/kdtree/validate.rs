//! The invariant checker: the layout is a tree, regions nest, and every point of every
//! triangle lies in a leaf that holds it.

use super::KdTree;
use super::node::KdNodeKind;
use crate::Aabb;
use glam::{Vec3, Vec3A};
use std::fmt;

/// A broken kd-tree invariant.
#[derive(Clone, Debug, PartialEq)]
pub enum KdValidationError {
    /// The tree was checked against a mesh with another number of triangles.
    TriangleCountChanged {
        /// Triangles the tree was built over.
        expected: usize,
        /// Triangles given.
        got: usize,
    },
    /// An interior node's child above is not after its child below, or past the end.
    BadChild(u32),
    /// A node is reached twice, or never.
    NodeReachedTwice(u32),
    /// Nodes the walk from the root never reaches.
    UnreachedNodes(usize),
    /// A split plane outside its node's region (children would not nest in it).
    SplitOutsideNode(u32),
    /// A leaf's run of references is not where depth-first order puts it, or past the end.
    MisplacedLeaf(u32),
    /// A leaf's triangles are not in increasing order, or one appears twice.
    UnsortedLeaf(u32),
    /// A leaf names a triangle that does not exist or has a non-finite corner.
    UnknownTriangle {
        /// The leaf.
        leaf: u32,
        /// The triangle index.
        triangle: u32,
    },
    /// A leaf's copy of a triangle's corners differs from the mesh's.
    StaleCorners {
        /// The leaf.
        leaf: u32,
        /// The triangle index.
        triangle: u32,
    },
    /// A leaf holds a triangle whose box does not reach the leaf's region.
    TriangleOutsideLeaf {
        /// The leaf.
        leaf: u32,
        /// The triangle index.
        triangle: u32,
    },
    /// A point of a triangle lies in no leaf that holds the triangle: a ray through it could
    /// miss the triangle.
    UncoveredPoint {
        /// The triangle index.
        triangle: u32,
        /// The point.
        point: Vec3A,
    },
}

impl fmt::Display for KdValidationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "kd-tree invariant broken: {self:?}")
    }
}

impl std::error::Error for KdValidationError {}

/// Barycentric weights of the points each triangle is checked at: its corners, edge
/// midpoints, centroid and a few points near its edges and corners (where planes cut it).
const SAMPLES: [[f32; 3]; 13] = [
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
    [0.5, 0.5, 0.0],
    [0.0, 0.5, 0.5],
    [0.5, 0.0, 0.5],
    [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0],
    [0.9, 0.05, 0.05],
    [0.05, 0.9, 0.05],
    [0.05, 0.05, 0.9],
    [0.7, 0.3, 0.0],
    [0.0, 0.2, 0.8],
    [0.45, 0.1, 0.45],
];

impl KdTree {
    /// Checks the tree against the mesh it was built over: the nodes form one depth-first
    /// tree, every split lies inside its node's region (so regions nest and tile the root),
    /// leaves hold existing finite triangles in increasing order with their current corners,
    /// each reaching the leaf's region, and every point of every finite triangle (checked at
    /// its corners, edge midpoints, centroid and six more points) lies in a leaf that holds
    /// it. A point strictly on one side of a
    /// plane must be held on that side; one exactly in a plane, on either.
    pub fn validate(&self, vertices: &[Vec3], indices: &[u32]) -> Result<(), KdValidationError> {
        let triangles = indices.len() / 3;
        if triangles != self.triangle_count() {
            return Err(KdValidationError::TriangleCountChanged {
                expected: self.triangle_count(),
                got: triangles,
            });
        }
        let corners = |t: u32| -> Option<[Vec3A; 3]> {
            let c = [0, 1, 2].map(|k| {
                let i = *indices.get(3 * t as usize + k)? as usize;
                vertices.get(i).map(|&v| Vec3A::from(v))
            });
            let c = [c[0]?, c[1]?, c[2]?];
            c.iter().all(|v| v.is_finite()).then_some(c)
        };
        self.check_structure(&corners)?;
        for t in 0..triangles as u32 {
            let Some(c) = corners(t) else { continue };
            let bounds = Aabb::from_points(c);
            for w in SAMPLES {
                // Clamped into the triangle's box: rounding may put a computed point just
                // outside it, and such a point is not on the triangle.
                let point = (c[0] * w[0] + c[1] * w[1] + c[2] * w[2]).clamp(bounds.min, bounds.max);
                if !self.bounds.contains_point(point) || !self.covers(0, point, t) {
                    return Err(KdValidationError::UncoveredPoint { triangle: t, point });
                }
            }
        }
        Ok(())
    }

    /// The layout, the regions and the leaves' contents.
    fn check_structure(
        &self,
        corners: &dyn Fn(u32) -> Option<[Vec3A; 3]>,
    ) -> Result<(), KdValidationError> {
        let mut reached = vec![false; self.nodes.len()];
        let mut next_reference = 0usize;
        // Below pushed last, so leaves come out in depth-first order.
        let mut stack = vec![(0u32, self.bounds)];
        while let Some((node, region)) = stack.pop() {
            let seen = reached
                .get_mut(node as usize)
                .ok_or(KdValidationError::BadChild(node))?;
            if std::mem::replace(seen, true) {
                return Err(KdValidationError::NodeReachedTwice(node));
            }
            match self.nodes[node as usize].kind() {
                KdNodeKind::Interior {
                    axis,
                    position,
                    above,
                } => {
                    if above <= node + 1 || above as usize >= self.nodes.len() {
                        return Err(KdValidationError::BadChild(node));
                    }
                    if !(region.min[axis] <= position && position <= region.max[axis]) {
                        return Err(KdValidationError::SplitOutsideNode(node));
                    }
                    let (mut below_region, mut above_region) = (region, region);
                    below_region.max[axis] = position;
                    above_region.min[axis] = position;
                    stack.push((above, above_region));
                    stack.push((node + 1, below_region));
                }
                KdNodeKind::Leaf { first, count } => {
                    let run = first as usize..first as usize + count as usize;
                    if first as usize != next_reference || run.end > self.references.len() {
                        return Err(KdValidationError::MisplacedLeaf(node));
                    }
                    next_reference = run.end;
                    let refs = &self.references[run.clone()];
                    if refs.windows(2).any(|w| w[0] >= w[1]) {
                        return Err(KdValidationError::UnsortedLeaf(node));
                    }
                    for (r, &triangle) in run.zip(refs) {
                        let Some(c) = corners(triangle) else {
                            return Err(KdValidationError::UnknownTriangle {
                                leaf: node,
                                triangle,
                            });
                        };
                        if self.corners[r] != c {
                            return Err(KdValidationError::StaleCorners {
                                leaf: node,
                                triangle,
                            });
                        }
                        if !Aabb::from_points(c).intersects_aabb(&region) {
                            return Err(KdValidationError::TriangleOutsideLeaf {
                                leaf: node,
                                triangle,
                            });
                        }
                    }
                }
            }
        }
        let unreached = reached.iter().filter(|&&r| !r).count();
        if unreached > 0 {
            return Err(KdValidationError::UnreachedNodes(unreached));
        }
        if next_reference != self.references.len() {
            return Err(KdValidationError::MisplacedLeaf(0));
        }
        Ok(())
    }

    /// True when `point` lies in a leaf under `node` that holds `triangle`: the side of each
    /// plane the point is on, or either side when it is in the plane.
    fn covers(&self, node: u32, point: Vec3A, triangle: u32) -> bool {
        match self.nodes[node as usize].kind() {
            KdNodeKind::Interior {
                axis,
                position,
                above,
            } => {
                let x = point[axis];
                (x <= position && self.covers(node + 1, point, triangle))
                    || (x >= position && self.covers(above, point, triangle))
            }
            KdNodeKind::Leaf { first, count } => self.references
                [first as usize..(first + count) as usize]
                .binary_search(&triangle)
                .is_ok(),
        }
    }
}
