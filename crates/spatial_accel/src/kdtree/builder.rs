//! The state every build writes the tree through: the node array in depth-first order, the
//! leaves' triangle lists, and the counts of what splitting did.

use super::node::{KdNode, MAX_PACKED};
use super::split::{Part, Side, Split, SplitSearch, clip_to_children};
use super::{KdBuild, KdTreeConfig, build_events, build_reference};
use crate::Aabb;
use glam::Vec3A;

/// What one build made, before the tree takes it over.
pub(super) struct Built {
    pub nodes: Vec<KdNode>,
    pub references: Vec<u32>,
    /// Triangles a split sent to both sides.
    pub straddled: usize,
    /// Of those, sides where clipping found nothing of the triangle (one reference saved).
    pub clipped_away: usize,
}

/// The builds' shared state and the steps they all take the same way.
pub(super) struct BuildContext<'a> {
    /// Every triangle's corners, by the caller's index.
    pub corners: &'a [[Vec3A; 3]],
    pub config: &'a KdTreeConfig,
    /// Nodes at this depth become leaves.
    pub depth_limit: u32,
    out: Built,
}

/// Builds the tree over `parts` (the finite triangles, each bounded by its own box) inside
/// `root`, with the algorithm `config.build` names.
pub(super) fn build(
    corners: &[[Vec3A; 3]],
    parts: Vec<Part>,
    root: &Aabb,
    config: &KdTreeConfig,
) -> Built {
    let mut ctx = BuildContext {
        corners,
        config,
        depth_limit: config.depth_limit(parts.len()),
        out: Built {
            nodes: Vec::new(),
            references: Vec::new(),
            straddled: 0,
            clipped_away: 0,
        },
    };
    match config.build {
        KdBuild::Naive => build_reference::naive(&mut ctx, root, parts),
        KdBuild::SortEachLevel => build_reference::sort_each_level(&mut ctx, root, parts),
        KdBuild::EventSweep => build_events::event_sweep(&mut ctx, root, parts),
    }
    ctx.out
}

impl BuildContext<'_> {
    /// The split for a node of `n` parts at `depth`, if it should have one: `None` at the
    /// depth limit, for an empty node, or where `feed` (which gives the search every
    /// candidate plane) finds none cheaper than a leaf.
    pub fn choose_split(
        &self,
        node: &Aabb,
        depth: u32,
        n: usize,
        feed: impl FnOnce(&mut SplitSearch<'_>),
    ) -> Option<Split> {
        if depth >= self.depth_limit || n == 0 {
            return None;
        }
        let mut search = SplitSearch::new(node, n, self.config);
        feed(&mut search);
        search.best()
    }

    /// Appends a leaf holding `parts`' triangles, in increasing index order (so that the
    /// builds' leaves compare equal however they gathered them).
    pub fn leaf(&mut self, parts: &[Part]) {
        let first = self.out.references.len();
        self.out.references.extend(parts.iter().map(|p| p.triangle));
        self.out.references[first..].sort_unstable();
        assert!(
            parts.len() <= MAX_PACKED as usize && first <= u32::MAX as usize,
            "kd-tree leaf too large for the compact node"
        );
        self.out
            .nodes
            .push(KdNode::leaf(first as u32, parts.len() as u32));
    }

    /// Reserves the interior node whose subtree below is built next; [`Self::close`] fills it
    /// in once the child above's index is known.
    pub fn open(&mut self) -> usize {
        self.out.nodes.push(KdNode::leaf(0, 0));
        self.out.nodes.len() - 1
    }

    /// Fills in the interior node reserved at `at`: its child above starts here.
    pub fn close(&mut self, at: usize, split: &Split) {
        let above = self.out.nodes.len();
        assert!(
            above <= MAX_PACKED as usize,
            "kd-tree too large for the compact node"
        );
        self.out.nodes[at] = KdNode::interior(split.axis, split.position, above as u32);
    }

    /// Sorts `parts` between the two children of `node` at `split`: each part goes below,
    /// above, or (clipped to each side) both; `class(triangle, side)` hears each decision.
    /// Returns each child's parts, with the clipped ones after the others, and where those
    /// start.
    pub fn partition(
        &mut self,
        parts: &[Part],
        node: &Aabb,
        split: &Split,
        mut class: impl FnMut(u32, Side),
    ) -> [(Vec<Part>, usize); 2] {
        let (mut below, mut above) = (Vec::new(), Vec::new());
        let mut crossing = Vec::new();
        for part in parts {
            let side = split.classify(&part.bounds);
            class(part.triangle, side);
            match side {
                Side::Below => below.push(*part),
                Side::Above => above.push(*part),
                Side::Both => crossing.push(*part),
            }
        }
        let (below_start, above_start) = (below.len(), above.len());
        self.out.straddled += crossing.len();
        for part in &crossing {
            let corners = &self.corners[part.triangle as usize];
            let [b, a] = clip_to_children(corners, part, node, split);
            self.out.clipped_away += usize::from(b.is_none()) + usize::from(a.is_none());
            below.extend(b);
            above.extend(a);
        }
        [(below, below_start), (above, above_start)]
    }
}
