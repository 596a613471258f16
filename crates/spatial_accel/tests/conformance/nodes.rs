//! The nodes each structure shows a debug overlay ([`DynamicIndex::visit_nodes`] and
//! [`visit_tree_nodes`]): every entry lies in a node that keeps it, depth ranges filter and
//! order, a break stops the walk, and the counts agree with what the structures report.

use accel_testkit::{Rng, random_box};
use core::cell::Cell;
use core::ops::{ControlFlow, RangeInclusive};
use spatial_accel::query::{
    AnyIndex, BoundingTree, DynamicIndex, IndexKind, NodeView, visit_tree_nodes,
};
use spatial_accel::{Aabb, BuildConfig, Bvh};
use std::time::Duration;

/// Every depth.
const ALL: RangeInclusive<u32> = 0..=u32::MAX;

/// A few hundred small boxes and a few large ones (oversize in the grid, kept near the root
/// of the loose trees), with a fixed seed.
fn scene(seed: u64) -> Vec<Aabb> {
    let mut rng = Rng::new(seed);
    let mut boxes: Vec<Aabb> = (0..300)
        .map(|_| random_box(&mut rng, 100.0, 0.1..3.0))
        .collect();
    boxes.extend((0..12).map(|_| random_box(&mut rng, 100.0, 20.0..80.0)));
    boxes
}

fn index_of(kind: IndexKind, boxes: &[Aabb]) -> AnyIndex {
    let mut index = AnyIndex::new(kind);
    for (i, b) in boxes.iter().enumerate() {
        index.insert(i as u32, *b).unwrap();
    }
    index.maintain(Duration::ZERO);
    index
}

/// The nodes `index` visits over `depths`, checking it finished.
fn nodes_of(index: &impl DynamicIndex, depths: RangeInclusive<u32>) -> Vec<NodeView> {
    let mut out = Vec::new();
    let flow = index.visit_nodes(depths, &mut |node| {
        out.push(node);
        ControlFlow::Continue(())
    });
    assert_eq!(flow, ControlFlow::Continue(()));
    out
}

#[test]
fn every_entry_lies_in_a_node_that_keeps_it() {
    for kind in IndexKind::ALL {
        let boxes = scene(0x0de5);
        let index = index_of(kind, &boxes);
        let nodes = nodes_of(&index, ALL);
        let stats = index.index_stats();
        assert!(!nodes.is_empty(), "{kind:?}: no node");
        for n in &nodes {
            assert!(
                n.bounds.is_valid() && n.bounds.is_finite(),
                "{kind:?}: unbounded node {n:?}"
            );
        }
        assert!(
            nodes.windows(2).all(|w| w[0].depth <= w[1].depth),
            "{kind:?}: deeper nodes before shallower ones"
        );
        let keeping: Vec<&NodeView> = nodes.iter().filter(|n| n.entries > 0).collect();
        let total: u64 = nodes.iter().map(|n| u64::from(n.entries)).sum();
        if let AnyIndex::Grid(grid) = &index {
            // Cells at depth 0, the oversize list's entries at depth 1; an entry over several
            // cells is counted in each and lies in their union, which its corners sample.
            let cells = nodes.iter().filter(|n| n.depth == 0).count();
            let oversize: Vec<&NodeView> = nodes.iter().filter(|n| n.depth == 1).collect();
            assert_eq!(cells, stats.nodes, "{kind:?}: cells");
            assert_eq!(cells + oversize.len(), nodes.len(), "{kind:?}: depths");
            assert_eq!(oversize.len(), grid.oversize_count(), "{kind:?}: oversize");
            assert!(!oversize.is_empty(), "the scene's large boxes are oversize");
            assert!(oversize.iter().all(|n| n.leaf && n.entries == 1));
            assert!(total >= boxes.len() as u64);
            for (i, b) in boxes.iter().enumerate() {
                let listed = oversize.iter().any(|n| n.bounds == *b);
                let in_cells = b.corners().into_iter().chain([b.center()]).all(|p| {
                    keeping
                        .iter()
                        .any(|n| n.depth == 0 && n.bounds.contains_point(p))
                });
                assert!(listed || in_cells, "{kind:?}: entry {i} in no node");
            }
        } else {
            // Trees (and the list as one leaf): every entry kept at exactly one node.
            assert_eq!(nodes.len(), stats.nodes, "{kind:?}: node count");
            assert_eq!(total, boxes.len() as u64, "{kind:?}: entries counted");
            let deepest = nodes.iter().map(|n| n.depth).max().unwrap();
            assert_eq!(deepest as usize, stats.depth, "{kind:?}: depth");
            assert!(
                nodes.iter().all(|n| n.leaf || n.depth < deepest),
                "{kind:?}: an interior node at the deepest depth"
            );
            for (i, b) in boxes.iter().enumerate() {
                assert!(
                    keeping.iter().any(|n| n.bounds.contains_aabb(b)),
                    "{kind:?}: entry {i} {b:?} in no node keeping entries"
                );
            }
        }
        if matches!(
            kind,
            IndexKind::DynamicBvh | IndexKind::Octree | IndexKind::Quadtree
        ) {
            assert!(stats.depth >= 3, "{kind:?}: the scene makes a real tree");
        }
    }
}

#[test]
fn depth_ranges_filter_the_full_walk() {
    for kind in IndexKind::ALL {
        let index = index_of(kind, &scene(0xf117));
        let all = nodes_of(&index, ALL);
        let deepest = all.iter().map(|n| n.depth).max().unwrap();
        let ranges = [
            0..=0,
            0..=1,
            1..=1,
            1..=3,
            2..=2,
            3..=5,
            deepest..=deepest,
            deepest..=u32::MAX,
            deepest + 1..=u32::MAX,
            u32::MAX..=u32::MAX,
            RangeInclusive::new(4, 2),
        ];
        for depths in ranges {
            let filtered: Vec<NodeView> = all
                .iter()
                .filter(|n| depths.contains(&n.depth))
                .copied()
                .collect();
            let visited = nodes_of(&index, depths.clone());
            assert!(
                visited.iter().all(|n| depths.contains(&n.depth)),
                "{kind:?}: a node outside {depths:?}"
            );
            assert_eq!(visited, filtered, "{kind:?}, {depths:?}");
        }
        // A range ending at 0 is the roots: one for a tree or the list, the cells for the
        // grid.
        let roots = nodes_of(&index, 0..=0);
        let expected = match kind {
            IndexKind::Grid => index.index_stats().nodes,
            _ => 1,
        };
        assert_eq!(roots.len(), expected, "{kind:?}: roots");
        assert!(roots.iter().all(|n| n.depth == 0));
    }
}

#[test]
fn a_break_stops_the_walk() {
    for kind in IndexKind::ALL {
        let index = index_of(kind, &scene(0xb4ea));
        let total = nodes_of(&index, ALL).len();
        for budget in [1, 2, 7, total].into_iter().filter(|&b| b <= total) {
            let mut seen = 0;
            let flow = index.visit_nodes(ALL, &mut |_| {
                seen += 1;
                if seen == budget {
                    ControlFlow::Break(())
                } else {
                    ControlFlow::Continue(())
                }
            });
            assert_eq!(
                (flow, seen),
                (ControlFlow::Break(()), budget),
                "{kind:?}: budget {budget}"
            );
        }
    }
}

#[test]
fn an_empty_index_has_no_node() {
    for kind in IndexKind::ALL {
        let mut index = index_of(kind, &scene(3));
        index.clear();
        index.maintain(Duration::ZERO);
        assert_eq!(nodes_of(&index, ALL), [], "{kind:?}");
        assert_eq!(nodes_of(&AnyIndex::new(kind), ALL), [], "{kind:?}");
    }
}

#[test]
fn the_loose_trees_show_their_loose_cells_by_level() {
    for kind in [IndexKind::Octree, IndexKind::Quadtree] {
        let index = index_of(kind, &scene(0x1005e));
        let nodes = nodes_of(&index, ALL);
        // Every octant of one depth has a cell of one size, halved at each level; the
        // quadtree's cells are squares in x and y.
        let side = |n: &NodeView| n.bounds.extent().x;
        let root = side(&nodes[0]);
        for n in &nodes {
            let expected = root / 2f32.powi(n.depth as i32);
            assert!(
                (side(n) - expected).abs() <= expected * 1e-4,
                "{kind:?}: {n:?} is not a cell of depth {}",
                n.depth
            );
            let e = n.bounds.extent();
            assert!((e.y - e.x).abs() <= e.x * 1e-4, "{kind:?}: {n:?}");
            if kind == IndexKind::Octree {
                assert!((e.z - e.x).abs() <= e.x * 1e-4, "{kind:?}: {n:?}");
            }
        }
    }
}

/// A tree that counts the nodes whose children are read.
struct Counting<'a> {
    tree: &'a Bvh,
    expanded: Cell<usize>,
}

impl BoundingTree for Counting<'_> {
    type Volume = Aabb;
    type Children<'b>
        = [u32; 2]
    where
        Self: 'b;

    fn root(&self) -> Option<u32> {
        self.tree.root()
    }

    fn node_bounds(&self, node: u32) -> Aabb {
        self.tree.node_bounds(node)
    }

    fn node_children(&self, node: u32) -> Option<[u32; 2]> {
        self.expanded.set(self.expanded.get() + 1);
        self.tree.node_children(node)
    }

    fn node_primitives(&self, node: u32) -> &[u32] {
        self.tree.node_primitives(node)
    }
}

#[test]
fn the_static_bvh_shows_every_node_and_reads_no_deeper_than_asked() {
    let boxes = scene(0x57a7);
    for config in [
        BuildConfig::default(),
        BuildConfig {
            max_leaf_size: 1,
            ..BuildConfig::default()
        },
    ] {
        let bvh = Bvh::build(&boxes, &config);
        let mut nodes = Vec::new();
        let flow = visit_tree_nodes(&bvh, ALL, |n| {
            nodes.push(n);
            ControlFlow::Continue(())
        });
        assert_eq!(flow, ControlFlow::Continue(()));
        assert_eq!(nodes.len(), bvh.nodes().len());
        assert_eq!(
            nodes.iter().filter(|n| n.leaf).count(),
            bvh.nodes().iter().filter(|n| n.is_leaf()).count()
        );
        let total: u32 = nodes.iter().map(|n| n.entries).sum();
        assert_eq!(total as usize, boxes.len());
        assert!(nodes.iter().all(|n| n.leaf == (n.entries > 0)));
        assert!(nodes.windows(2).all(|w| w[0].depth <= w[1].depth));
        assert_eq!(nodes[0].bounds, bvh.node_bounds(0));
        for b in &boxes {
            assert!(nodes.iter().any(|n| n.leaf && n.bounds.contains_aabb(b)));
        }

        // Down to depth d, at most the 2^(d+1) - 1 nodes above it have their children read.
        for last in 0..4u32 {
            let counting = Counting {
                tree: &bvh,
                expanded: Cell::new(0),
            };
            let mut seen = 0;
            let _ = visit_tree_nodes(&counting, last..=last, |n| {
                assert_eq!(n.depth, last);
                seen += 1;
                ControlFlow::Continue(())
            });
            assert!(counting.expanded.get() < 1 << (last + 1), "depth {last}");
            assert_eq!(seen, nodes.iter().filter(|n| n.depth == last).count());
        }

        // A break stops it.
        let mut seen = 0;
        let flow = visit_tree_nodes(&bvh, 1..=u32::MAX, |_| {
            seen += 1;
            if seen == 3 {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        });
        assert_eq!((flow, seen), (ControlFlow::Break(()), 3));
    }
}

#[test]
fn nodes_can_be_shown_between_edits_and_maintain() {
    for kind in IndexKind::ALL {
        let boxes = scene(0xed17);
        let mut index = AnyIndex::new(kind);
        let handles: Vec<_> = boxes
            .iter()
            .enumerate()
            .map(|(i, b)| index.insert(i as u32, *b).unwrap())
            .collect();
        index.maintain(Duration::ZERO);
        let far = Aabb::new(glam::Vec3A::splat(500.0), glam::Vec3A::splat(501.0));
        for &h in handles.iter().step_by(5) {
            index.update(h, far).unwrap();
        }
        // The structure as it stands, without the checks queries make.
        let before = nodes_of(&index, ALL);
        assert!(!before.is_empty(), "{kind:?}");
        index.maintain(Duration::ZERO);
        let after = nodes_of(&index, ALL);
        let moved = after
            .iter()
            .filter(|n| n.entries > 0 && n.bounds.contains_point(far.center()));
        assert!(moved.count() > 0, "{kind:?}: the moved entries' node");
    }
}
