//! The mesh tree's last collapse: leaves priced as the packets a ray tests.

use super::packets::LANES;
use crate::{BuildConfig, Bvh};

/// Largest subtree, in references, whose distinct triangles are counted. A triangle is cut
/// into at most 256 pieces, but past a few dozen references a subtree over at most
/// `max_leaf_size` triangles is rare, and counting would cost a sort per node.
const COUNTED_REFERENCES: usize = 64;

/// Turns into a leaf every subtree whose references name at most `config.max_leaf_size`
/// distinct triangles and which the SAH finds cheaper as a leaf, counting each triangle once
/// and a leaf's triangles in whole packets. `triangle_of` maps a reference to its triangle
/// where the tree was built over pieces of triangles; `None` where it was built over whole
/// ones.
///
/// Why, twice over. A builder costs a leaf by its references, but a leaf is packed with each
/// triangle once (`packets.rs`), so pieces of one triangle in sibling leaves cost a ray one
/// test of that triangle per leaf where one would do; pieces of a triangle cluster next to
/// each other along the build's Morton curve, so without this more pieces would make rays
/// slower. And a builder costs a leaf per triangle, but a ray tests a leaf [`LANES`]
/// triangles at a time, so one to four triangles cost one test: priced so (tinybvh prices its
/// 4-wide leaves the same way), sibling leaves of one or two triangles merge into fuller
/// packets, for fewer packets and nodes and faster rays of every kind, shadow rays most
/// (BENCHMARKS.md, Rays on meshes). The builders' own collapse cannot see either;
/// this pass, bottom-up, keeps the cheaper of leaf and node under `traversal * area + children` against
/// `intersection * area * LANES * packets`.
pub(super) fn merge_leaves(bvh: &mut Bvh, triangle_of: Option<&[u32]>, config: &BuildConfig) {
    if !config.sah_termination || bvh.nodes.is_empty() {
        return;
    }
    let ranges = bvh.subtree_ranges();
    let mut cost = vec![0.0f32; bvh.nodes.len()];
    let mut distinct = Vec::with_capacity(COUNTED_REFERENCES);
    // Children follow their parent in the array: a reverse sweep costs both before it.
    for i in (0..bvh.nodes.len()).rev() {
        let node = bvh.nodes[i];
        let area = node.aabb().half_area();
        let [start, end] = ranges[i].map(|r| r as usize);
        let triangles = match triangle_of {
            None => Some(end - start),
            Some(triangle_of) => (end - start <= COUNTED_REFERENCES).then(|| {
                distinct.clear();
                distinct.extend(
                    bvh.primitive_indices[start..end]
                        .iter()
                        .map(|&r| triangle_of[r as usize]),
                );
                distinct.sort_unstable();
                distinct.dedup();
                distinct.len()
            }),
        };
        let as_leaf =
            |n: usize| config.sah.intersection * area * (n.div_ceil(LANES) * LANES) as f32;
        if node.is_leaf() {
            cost[i] = as_leaf(triangles.unwrap_or(end - start));
            continue;
        }
        let (left, right) = (node.first as usize, node.first as usize + 1);
        let as_node = config.sah.traversal * area + cost[left] + cost[right];
        cost[i] = match triangles {
            Some(n) if n <= config.max_leaf_size as usize && as_leaf(n) <= as_node => {
                // The children stay in the array, unreachable (see `reachable_leaves`).
                bvh.nodes[i].first = start as u32;
                bvh.nodes[i].count = (end - start) as u32;
                as_leaf(n)
            }
            _ => as_node,
        };
    }
}

/// The leaves reachable from the root, in primitive order. After [`merge_leaves`] the
/// nodes under a merged leaf are still in the array, so leaves are found by walking, not by
/// scanning it.
pub(super) fn reachable_leaves(bvh: &Bvh) -> Vec<usize> {
    let mut leaves = Vec::new();
    let mut walk = if bvh.nodes.is_empty() {
        vec![]
    } else {
        vec![0usize]
    };
    while let Some(n) = walk.pop() {
        let node = &bvh.nodes[n];
        if node.is_leaf() {
            leaves.push(n);
        } else {
            walk.extend([node.first as usize, node.first as usize + 1]);
        }
    }
    leaves.sort_unstable_by_key(|&n| bvh.nodes[n].first);
    leaves
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Aabb, SplitStrategy};
    use glam::Vec3A;

    fn leaf_ranges(bvh: &Bvh) -> Vec<[u32; 2]> {
        reachable_leaves(bvh)
            .into_iter()
            .map(|n| [bvh.nodes[n].first, bvh.nodes[n].count])
            .collect()
    }

    /// Two triangles, each cut into four pieces in a row: built with leaves of one reference,
    /// each triangle's pieces become one leaf (one test instead of four), and no further,
    /// since two triangles exceed the leaf size.
    #[test]
    fn pieces_of_one_triangle_share_a_leaf() {
        let boxes: Vec<Aabb> = (0..8)
            .map(|i| {
                let x = i as f32;
                Aabb::new(Vec3A::new(x, 0.0, 0.0), Vec3A::new(x + 1.0, 0.1, 0.1))
            })
            .collect();
        let triangle_of = [0, 0, 0, 0, 1, 1, 1, 1];
        for split in [SplitStrategy::BinnedSah { bins: 16 }, SplitStrategy::PLOC] {
            let config = BuildConfig {
                split,
                max_leaf_size: 1,
                ..BuildConfig::default()
            };
            let mut bvh = Bvh::build(&boxes, &config);
            assert_eq!(leaf_ranges(&bvh).len(), 8);
            merge_leaves(&mut bvh, Some(&triangle_of), &config);
            let leaves = leaf_ranges(&bvh);
            assert_eq!(leaves, vec![[0, 4], [4, 4]], "{split:?}");
            for [first, count] in leaves {
                let run = &bvh.primitive_indices[first as usize..(first + count) as usize];
                let t = triangle_of[run[0] as usize];
                assert!(run.iter().all(|&r| triangle_of[r as usize] == t));
            }
        }
    }

    /// Two pairs of unit cubes 4 apart: per triangle, two leaves of two cost less than one
    /// of four (46 against 52, in half areas); by packets the four share one packet, and one
    /// leaf costs less than two (52 against 66).
    #[test]
    fn leaves_are_priced_by_whole_packets() {
        let boxes: Vec<Aabb> = [0.0, 1.0, 4.0, 5.0]
            .iter()
            .map(|&x| Aabb::new(Vec3A::new(x, 0.0, 0.0), Vec3A::new(x + 1.0, 1.0, 1.0)))
            .collect();
        let single = BuildConfig {
            max_leaf_size: 1,
            ..BuildConfig::default()
        };
        let mut bvh = Bvh::build(&boxes, &single);
        assert_eq!(leaf_ranges(&bvh).len(), 4);
        merge_leaves(&mut bvh, None, &BuildConfig::default());
        assert_eq!(leaf_ranges(&bvh), vec![[0, 4]]);
    }
}
