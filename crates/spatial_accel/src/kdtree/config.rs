//! The kd-tree's cost model, depth limit and choice of build algorithm.

/// Which of the three builds makes the tree. All three evaluate the same candidate planes in
/// the same order with the same arithmetic, so they give the same tree, to the bit; they
/// differ only in how fast they find each plane's triangle counts (Wald and Havran 2006,
/// sections 4.1 to 4.3).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum KdBuild {
    /// O(N^2): every candidate plane counts the node's triangles on each side by looping
    /// over all of them. The reference the fast builds are tested against; small meshes only.
    Naive,
    /// O(N log^2 N): each node sorts its triangles' events afresh and sweeps them.
    SortEachLevel,
    /// O(N log N): the events are sorted once at the root; each node sweeps its sorted lists
    /// and hands each child its share in linear time, sorting only the few new events of the
    /// triangles clipped at the split.
    #[default]
    EventSweep,
}

/// How a [`super::KdTree`] is built: the SAH cost constants, the empty-space bonus, the depth
/// limit and the build algorithm.
///
/// A node is split where `traversal_cost + intersection_cost * (area_left / area * n_left +
/// area_right / area * n_right)`, scaled by `empty_bonus` when one side holds no triangle, is
/// lowest, and only while that is below `intersection_cost * n`, the cost of making it a leaf
/// (cost-based termination).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KdTreeConfig {
    /// Cost of one traversal step, relative to `intersection_cost`. Default 15, the paper's.
    pub traversal_cost: f32,
    /// Cost of one ray/triangle test. Default 20, the paper's.
    pub intersection_cost: f32,
    /// Factor on the cost of a split that leaves one side empty: below 1, it cuts empty space
    /// off early, so rays skip it in one step. Default 0.8, the paper's `lambda`.
    pub empty_bonus: f32,
    /// Deepest level a node may be made at (the root is depth 0). `None`: the paper's
    /// `8 + 1.3 log2 N` for `N` triangles. Clamped to [`KdTreeConfig::DEPTH_CAP`] either way.
    pub max_depth: Option<u32>,
    /// Which build algorithm to run (they all give the same tree).
    pub build: KdBuild,
}

impl Default for KdTreeConfig {
    fn default() -> Self {
        Self {
            traversal_cost: 15.0,
            intersection_cost: 20.0,
            empty_bonus: 0.8,
            max_depth: None,
            build: KdBuild::EventSweep,
        }
    }
}

impl KdTreeConfig {
    /// The deepest any tree is built. The build recurses once per level and a ray keeps one
    /// stack entry per level; past this depth a tree over any mesh that fits in memory has
    /// long stopped paying for itself.
    pub const DEPTH_CAP: u32 = 64;

    /// The default configuration with another build algorithm.
    pub fn with_build(build: KdBuild) -> Self {
        Self {
            build,
            ..Self::default()
        }
    }

    /// The depth limit for a mesh of `triangles` finite triangles: `max_depth`, or
    /// `8 + 1.3 log2 N` rounded, clamped to [`KdTreeConfig::DEPTH_CAP`].
    pub fn depth_limit(&self, triangles: usize) -> u32 {
        let depth = self.max_depth.unwrap_or_else(|| {
            let n = triangles.max(1) as f64;
            (8.0 + 1.3 * n.log2()).round() as u32
        });
        depth.min(Self::DEPTH_CAP)
    }
}
