//! A mesh's triangles in leaf order, four to a SIMD packet.

use super::leaf_merge::reachable_leaves;
use super::presplit::SplitReferences;
use crate::bvh::Bvh;
use crate::{Aabb, Triangle4};
use glam::{Vec3, Vec3A};

/// Triangles per packet: the lanes of one [`Triangle4`] test.
pub(super) const LANES: usize = 4;

/// Marks an unused packet lane.
pub(super) const NO_TRIANGLE: u32 = u32::MAX;

/// Four triangles' corners and their ids, side by side.
///
/// Why the ids sit here and not in an array of their own: a closest-hit ray reads its hit
/// triangle's id once it has finished, and from a separate array that read is a cache miss
/// at the end of nearly every ray. Here it shares the lines the leaf test has just read, which
/// makes closest-hit rays faster (BENCHMARKS.md, Rays on meshes). 160 bytes, where the corners alone are 144,
/// which also keeps a packet on three cache lines (at 144 bytes one in four straddles four).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(16))]
pub(super) struct LeafPacket {
    /// The corners of the four triangles.
    pub corners: Triangle4,
    /// The caller's triangle index of each lane, or [`NO_TRIANGLE`].
    pub triangles: [u32; 4],
}

/// The triangles of a mesh BVH, regrouped so each leaf is a run of whole [`Triangle4`]
/// packets: a ray tests a leaf four triangles per instruction, and a leaf's triangles sit
/// together in memory instead of being gathered through the index buffer.
#[derive(Clone, Debug, Default)]
pub(super) struct LeafPackets {
    /// The triangles, four per packet.
    pub packets: Vec<LeafPacket>,
    /// The vertex indices of each lane (for refits); unused lanes hold zeros.
    pub vertex_indices: Vec<[[u32; 3]; 4]>,
}

impl LeafPackets {
    /// Packs the leaves of `bvh` (built over the mesh's triangles) and rewrites the tree to
    /// name packets instead of triangles: a leaf of `n` triangles becomes `ceil(n / 4)`
    /// packets, in the tree's primitive order.
    ///
    /// With `references` the tree was built over pieces of triangles
    /// ([`super::presplit`]): a leaf's pieces are packed as their triangles, each once per
    /// leaf, and the returned boxes are each packet's part of the leaf (the union of its
    /// pieces), which the tree's boxes bound instead of the packets' whole triangles.
    pub fn pack(
        bvh: &mut Bvh,
        vertices: &[Vec3],
        indices: &[u32],
        references: Option<&SplitReferences>,
    ) -> (Self, Vec<Aabb>) {
        let leaves = reachable_leaves(bvh);
        let mut out = Self::default();
        let mut piece_boxes = Vec::new();
        let mut run: Vec<(u32, Aabb)> = Vec::new();
        for n in leaves {
            let node = &mut bvh.nodes[n];
            run.clear();
            for &r in
                &bvh.primitive_indices[node.first as usize..(node.first + node.count) as usize]
            {
                let Some(refs) = references else {
                    run.push((r, Aabb::EMPTY));
                    continue;
                };
                let (t, piece) = (refs.triangles[r as usize], refs.boxes[r as usize]);
                // Two pieces of one triangle in one leaf: test the triangle once.
                match run.iter_mut().find(|(seen, _)| *seen == t) {
                    Some((_, b)) => *b = b.union(&piece),
                    None => run.push((t, piece)),
                }
            }
            node.first = out.packets.len() as u32;
            node.count = run.len().div_ceil(LANES) as u32;
            for group in run.chunks(LANES) {
                let mut packet = Triangle4::default();
                let mut ids = [NO_TRIANGLE; 4];
                let mut lane_indices = [[0u32; 3]; 4];
                let mut pieces = Aabb::EMPTY;
                for (lane, &(t, piece)) in group.iter().enumerate() {
                    let tri = [0, 1, 2].map(|k| indices[3 * t as usize + k]);
                    packet.set(lane, tri.map(|i| Vec3A::from(vertices[i as usize])));
                    ids[lane] = t;
                    lane_indices[lane] = tri;
                    pieces = pieces.union(&piece);
                }
                out.packets.push(LeafPacket {
                    corners: packet,
                    triangles: ids,
                });
                out.vertex_indices.push(lane_indices);
                if references.is_some() {
                    piece_boxes.push(pieces);
                }
            }
        }
        bvh.primitive_indices = (0..out.packets.len() as u32).collect();
        (out, piece_boxes)
    }

    /// The corners of lane `lane` of packet `packet`.
    #[inline]
    pub fn corners(&self, packet: u32, lane: usize) -> [Vec3A; 3] {
        self.packets[packet as usize].corners.get(lane)
    }

    /// The caller's triangle index of lane `lane` of packet `packet`.
    #[inline]
    pub fn triangle(&self, packet: u32, lane: usize) -> u32 {
        self.packets[packet as usize].triangles[lane]
    }

    /// The corners of packet `packet`'s four triangles.
    #[inline]
    pub fn corners4(&self, packet: u32) -> &Triangle4 {
        &self.packets[packet as usize].corners
    }

    /// The lanes of a packet that hold a triangle.
    #[inline]
    pub fn used_lanes(&self, packet: u32) -> impl Iterator<Item = usize> + '_ {
        let ids = &self.packets[packet as usize].triangles;
        (0..LANES).filter(move |&l| ids[l] != NO_TRIANGLE)
    }

    /// The box of one lane's triangle; empty when a corner is not finite, so such a triangle
    /// (a NaN in a skinned pose, say) drops out of the tree instead of poisoning it.
    pub fn lane_bounds(&self, packet: u32, lane: usize) -> Aabb {
        triangle_bounds(&self.corners(packet, lane))
    }

    /// The box of a packet's triangles.
    #[inline]
    pub fn packet_bounds(&self, packet: u32) -> Aabb {
        self.packets[packet as usize].corners.bounds()
    }

    /// Rewrites packet `packet`'s used lanes from new vertex positions and returns its new
    /// box.
    #[inline]
    pub fn move_packet(&mut self, packet: u32, vertices: &[Vec3]) -> Aabb {
        let p = packet as usize;
        let lane_indices = &self.vertex_indices[p];
        let LeafPacket {
            corners: tri,
            triangles: ids,
        } = &mut self.packets[p];
        let mut bounds = Aabb::EMPTY;
        for lane in (0..LANES).filter(|&l| ids[l] != NO_TRIANGLE) {
            let corners = lane_indices[lane].map(|i| Vec3A::from(vertices[i as usize]));
            tri.set(lane, corners);
            // From the corners in registers: reading the packet back right after its
            // lane-by-lane stores would stall on store forwarding.
            bounds = bounds.union(&triangle_bounds(&corners));
        }
        bounds
    }

    /// Memory held, in bytes.
    pub fn memory_bytes(&self) -> usize {
        self.packets.len() * (size_of::<LeafPacket>() + size_of::<[[u32; 3]; 4]>())
    }
}

/// The box of a triangle's corners, or [`Aabb::EMPTY`] when one is not finite.
pub(super) fn triangle_bounds(corners: &[Vec3A; 3]) -> Aabb {
    if corners.iter().all(|v| v.is_finite()) {
        Aabb::from_points(*corners)
    } else {
        Aabb::EMPTY
    }
}
