//! Choosing the splitting planes: top down, each node's plane one of its triangles' planes.

use super::plane::{BspPlane, Side};
use super::split::split_triangle;
use super::tree::{BspNode, BspPiece, NONE};
use crate::Aabb;
use glam::Vec3A;

/// How a [`BspTree`](super::BspTree) chooses its planes.
///
/// At each node, `candidates` of its triangles are drawn and the plane of each is priced on
/// up to `cost_sample` of the node's triangles as `split_weight * splits + |front - back|`
/// (Ericson, "Real-Time Collision Detection", 8.3.2, with his blend of 0.8 written as a
/// weight of 4 on splits): splits multiply the triangles, imbalance deepens the tree. The
/// cheapest wins.
#[derive(Clone, Debug, PartialEq)]
pub struct BspConfig {
    /// Triangles whose planes are priced at each node (at least one is).
    pub candidates: usize,
    /// The weight of a split against one triangle of imbalance.
    pub split_weight: f32,
    /// Triangles each candidate is priced on; a node with more prices on an even stride of
    /// them, so a node costs the same to decide whatever its size.
    pub cost_sample: usize,
    /// The deepest a node may be (the root is at depth 1). A node there keeps every triangle
    /// that reaches it in its own list, in no particular order, and is counted in
    /// [`BspStats::depth_limited`](super::BspStats::depth_limited). Each node removes its own
    /// plane's triangles from its subtrees, so a tree is never deeper than its number of
    /// triangles; the limit only bounds what that allows.
    pub max_depth: u32,
    /// The seed of the draw of candidates, so a build is reproducible.
    pub seed: u64,
}

impl Default for BspConfig {
    fn default() -> Self {
        Self {
            candidates: 8,
            split_weight: 4.0,
            cost_sample: 128,
            max_depth: 4096,
            seed: 0x5eed_b5b0,
        }
    }
}

/// The tree as built: nodes (the root first, each parent before its children) and the
/// pieces, each node's own contiguous.
pub(super) struct Built {
    pub(super) nodes: Vec<BspNode>,
    pub(super) pieces: Vec<BspPiece>,
    pub(super) splits: usize,
    pub(super) depth: usize,
    pub(super) depth_limited: usize,
}

/// A node whose list of triangles is still to be partitioned.
struct Work {
    node: u32,
    pieces: Vec<BspPiece>,
    depth: u32,
}

/// Builds the tree over `pieces` (the source triangles, whole), `planes[source]` the plane
/// of each source triangle ([`BspPlane::EVERYWHERE`] for one left out of the tree). Node
/// boxes are grown by `margin`.
pub(super) fn build(
    pieces: Vec<BspPiece>,
    planes: &[BspPlane],
    tolerance: f64,
    margin: f32,
    config: &BspConfig,
) -> Built {
    let mut built = Built {
        nodes: Vec::new(),
        pieces: Vec::with_capacity(pieces.len()),
        splits: 0,
        depth: 0,
        depth_limited: 0,
    };
    if pieces.is_empty() {
        return built;
    }
    let mut rng = config.seed;
    built.nodes.push(BspNode::placeholder());
    // An explicit stack: a chain as deep as the mesh has triangles (a convex mesh gives one,
    // every plane having all the others behind it) must not overflow the call stack.
    let mut stack = vec![Work {
        node: 0,
        pieces,
        depth: 1,
    }];
    while let Some(work) = stack.pop() {
        built.depth = built.depth.max(work.depth as usize);
        let at_limit = work.depth >= config.max_depth.max(1);
        let chosen = if at_limit {
            0
        } else {
            choose_plane(&work.pieces, planes, tolerance, config, &mut rng)
        };
        let source = work.pieces[chosen].source;
        let plane = planes[source as usize];
        let first = built.pieces.len() as u32;
        let (mut front, mut back) = (Vec::new(), Vec::new());
        if at_limit {
            built.depth_limited += work.pieces.len();
            built.pieces.extend_from_slice(&work.pieces);
        } else {
            for piece in work.pieces {
                // The plane's own source is on it by construction: taking its pieces here
                // whatever their rounded corners say guarantees each node removes at least
                // one source from its subtrees, so the recursion ends.
                if piece.source == source {
                    built.pieces.push(piece);
                    continue;
                }
                let distances = piece.vertices.map(|v| plane.signed_distance(v));
                let sides = distances.map(|d| BspPlane::side_of(d, tolerance));
                let has = |s: Side| sides.contains(&s);
                match (has(Side::Front), has(Side::Back)) {
                    (false, false) => built.pieces.push(piece),
                    (true, false) => front.push(piece),
                    (false, true) => back.push(piece),
                    (true, true) => {
                        built.splits += 1;
                        let halves = split_triangle(&piece.vertices, distances, sides);
                        let with = |vertices: &[Vec3A; 3]| BspPiece {
                            vertices: *vertices,
                            source: piece.source,
                        };
                        front.extend(halves.front.as_slice().iter().map(with));
                        back.extend(halves.back.as_slice().iter().map(with));
                    }
                }
            }
        }
        let count = built.pieces.len() as u32 - first;
        let mut child = |pieces: Vec<BspPiece>, nodes: &mut Vec<BspNode>| {
            if pieces.is_empty() {
                return NONE;
            }
            let node = nodes.len() as u32;
            nodes.push(BspNode::placeholder());
            stack.push(Work {
                node,
                pieces,
                depth: work.depth + 1,
            });
            node
        };
        let front = child(front, &mut built.nodes);
        let back = child(back, &mut built.nodes);
        built.nodes[work.node as usize] = BspNode {
            plane,
            source,
            first,
            count,
            front,
            back,
            bounds: Aabb::EMPTY,
            depth_limited: at_limit,
        };
    }
    bound_nodes(&mut built, margin);
    built
}

/// Sets each node's box to hold its pieces and its children's boxes, grown by `margin`.
fn bound_nodes(built: &mut Built, margin: f32) {
    // Children come after their parents, so a reverse sweep meets them first.
    for i in (0..built.nodes.len()).rev() {
        let node = built.nodes[i];
        let mut bounds = built.pieces[node.first as usize..(node.first + node.count) as usize]
            .iter()
            .fold(Aabb::EMPTY, |b, p| b.union(&Aabb::from_points(p.vertices)));
        for child in [node.front, node.back] {
            if child != NONE {
                // Already grown: union before growing, so the margin does not compound.
                bounds = bounds.union(&built.nodes[child as usize].bounds);
            }
        }
        built.nodes[i].bounds = bounds;
    }
    for node in &mut built.nodes {
        node.bounds = node.bounds.expanded(Vec3A::splat(margin));
    }
}

/// The index in `pieces` of the piece whose source's plane prices cheapest.
fn choose_plane(
    pieces: &[BspPiece],
    planes: &[BspPlane],
    tolerance: f64,
    config: &BspConfig,
    rng: &mut u64,
) -> usize {
    let n = pieces.len();
    let k = config.candidates.clamp(1, n);
    let samples = config.cost_sample.clamp(1, n);
    let mut best = (f32::INFINITY, 0);
    for c in 0..k {
        // Every piece when there are few, else a draw.
        let candidate = if k == n {
            c
        } else {
            (splitmix64(rng) % n as u64) as usize
        };
        let source = pieces[candidate].source;
        let plane = planes[source as usize];
        let (mut front, mut back, mut splits) = (0u32, 0u32, 0u32);
        for s in 0..samples {
            let piece = &pieces[s * n / samples];
            if piece.source == source {
                continue;
            }
            let mut sides = piece.vertices.iter().map(|&v| plane.classify(v, tolerance));
            let (mut f, mut b) = (false, false);
            for side in &mut sides {
                f |= side == Side::Front;
                b |= side == Side::Back;
            }
            match (f, b) {
                (true, true) => splits += 1,
                (true, false) => front += 1,
                (false, true) => back += 1,
                (false, false) => {}
            }
        }
        let cost = splits as f32 * config.split_weight + front.abs_diff(back) as f32;
        if cost < best.0 {
            best = (cost, candidate);
        }
    }
    best.1
}

/// SplitMix64 (Steele, Lea and Flood 2014): a seeded stream for the draw of candidates.
fn splitmix64(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}
