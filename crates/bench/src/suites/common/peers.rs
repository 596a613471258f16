//! The peer crates seen through our types: their trees as [`BoundingTree`]s, so one SAH cost
//! function ([`spatial_accel::bvh::stats::tree_stats`]) and one cost model rate every tree, and their
//! primitive types built from ours.

use nalgebra::Point3;
use spatial_accel::query::BoundingTree;
use spatial_accel::{Aabb, Triangle};

/// An obvhs box from ours.
pub fn to_obvhs_aabb(b: &Aabb) -> obvhs::aabb::Aabb {
    obvhs::aabb::Aabb::new(b.min, b.max)
}

/// An obvhs triangle from ours.
pub fn to_obvhs_tri(t: &Triangle) -> obvhs::triangle::Triangle {
    let [v0, v1, v2] = t.vertices;
    obvhs::triangle::Triangle { v0, v1, v2 }
}

/// An obvhs BVH2 as a [`BoundingTree`]: node 0 is the root, children at `first_index` and
/// `first_index + 1`, leaves index `primitive_indices`.
pub struct ObvhsBvh2<'a>(pub &'a obvhs::bvh2::Bvh2);

impl BoundingTree for ObvhsBvh2<'_> {
    type Volume = Aabb;
    type Children<'a>
        = [u32; 2]
    where
        Self: 'a;

    fn root(&self) -> Option<u32> {
        (!self.0.nodes.is_empty()).then_some(0)
    }
    fn node_bounds(&self, node: u32) -> Aabb {
        let a = self.0.nodes[node as usize].aabb();
        Aabb::new(a.min, a.max)
    }
    fn node_children(&self, node: u32) -> Option<[u32; 2]> {
        let n = &self.0.nodes[node as usize];
        (n.prim_count == 0).then_some([n.first_index, n.first_index + 1])
    }
    fn node_primitives(&self, node: u32) -> &[u32] {
        let n = &self.0.nodes[node as usize];
        if n.prim_count == 0 {
            return &[];
        }
        let first = n.first_index as usize;
        &self.0.primitive_indices[first..first + n.prim_count as usize]
    }
}

/// Memory of an obvhs BVH2: nodes plus primitive indices (the optional parent and
/// primitive-to-node maps, empty after a build, are left out).
pub fn obvhs_bvh2_bytes(b: &obvhs::bvh2::Bvh2) -> usize {
    super::bytes_of(&b.nodes) + super::bytes_of(&b.primitive_indices)
}

/// Memory of an obvhs CWBVH: nodes plus primitive indices.
pub fn obvhs_cwbvh_bytes(b: &obvhs::cwbvh::CwBvh) -> usize {
    super::bytes_of(&b.nodes) + super::bytes_of(&b.primitive_indices)
}

/// A primitive for the `bvh` crate: its box, its id (the crate hands back shapes, not ids) and
/// the node index the builder writes back.
#[derive(Clone, Copy, Debug)]
pub struct BvhShape {
    pub aabb: bvh::aabb::Aabb<f32, 3>,
    pub id: u32,
    pub node: usize,
}

impl BvhShape {
    pub fn new(id: usize, b: &Aabb) -> Self {
        Self {
            id: id as u32,
            aabb: bvh::aabb::Aabb::with_bounds(
                Point3::new(b.min.x, b.min.y, b.min.z),
                Point3::new(b.max.x, b.max.y, b.max.z),
            ),
            node: 0,
        }
    }
}

impl bvh::aabb::Bounded<f32, 3> for BvhShape {
    fn aabb(&self) -> bvh::aabb::Aabb<f32, 3> {
        self.aabb
    }
}

impl bvh::bounding_hierarchy::BHShape<f32, 3> for BvhShape {
    fn set_bh_node_index(&mut self, i: usize) {
        self.node = i;
    }
    fn bh_node_index(&self) -> usize {
        self.node
    }
}

fn from_bvh_aabb(a: &bvh::aabb::Aabb<f32, 3>) -> Aabb {
    Aabb::new(
        glam::Vec3A::new(a.min.x, a.min.y, a.min.z),
        glam::Vec3A::new(a.max.x, a.max.y, a.max.z),
    )
}

/// A `bvh` crate tree as a [`BoundingTree`]. That crate keeps each child's box in its parent
/// and one shape per leaf, so the node boxes and leaf ids are gathered once here.
pub struct BvhCrateTree {
    children: Vec<Option<[u32; 2]>>,
    bounds: Vec<Aabb>,
    leaf_ids: Vec<u32>,
}

impl BvhCrateTree {
    /// A lone-leaf tree (one primitive) gets an empty root box: the benchmarks never build one.
    pub fn new(tree: &bvh::bvh::Bvh<f32, 3>) -> Self {
        use bvh::bvh::BvhNode;
        let n = tree.nodes.len();
        let mut s = Self {
            children: vec![None; n],
            bounds: vec![Aabb::EMPTY; n],
            leaf_ids: vec![0; n],
        };
        for (i, node) in tree.nodes.iter().enumerate() {
            match *node {
                BvhNode::Node {
                    child_l_index,
                    ref child_l_aabb,
                    child_r_index,
                    ref child_r_aabb,
                    ..
                } => {
                    s.children[i] = Some([child_l_index as u32, child_r_index as u32]);
                    s.bounds[child_l_index] = from_bvh_aabb(child_l_aabb);
                    s.bounds[child_r_index] = from_bvh_aabb(child_r_aabb);
                }
                BvhNode::Leaf { shape_index, .. } => s.leaf_ids[i] = shape_index as u32,
            }
        }
        if let Some([a, b]) = s.children.first().copied().flatten() {
            s.bounds[0] = s.bounds[a as usize].union(&s.bounds[b as usize]);
        }
        s
    }
}

impl BoundingTree for BvhCrateTree {
    type Volume = Aabb;
    type Children<'a>
        = [u32; 2]
    where
        Self: 'a;

    fn root(&self) -> Option<u32> {
        (!self.children.is_empty()).then_some(0)
    }
    fn node_bounds(&self, node: u32) -> Aabb {
        self.bounds[node as usize]
    }
    fn node_children(&self, node: u32) -> Option<[u32; 2]> {
        self.children[node as usize]
    }
    fn node_primitives(&self, node: u32) -> &[u32] {
        if self.children[node as usize].is_some() {
            &[]
        } else {
            core::slice::from_ref(&self.leaf_ids[node as usize])
        }
    }
}

/// Memory of a `bvh` crate tree (its node enum; shapes are the caller's).
pub fn bvh_crate_bytes(tree: &bvh::bvh::Bvh<f32, 3>) -> usize {
    super::bytes_of(&tree.nodes)
}
