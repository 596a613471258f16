//! Every textbook build choice, as one configuration.

/// How a node's primitives are divided between its two children.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SplitStrategy {
    /// Split at the middle of the centroid bounds on their longest axis (spatial median).
    /// Fastest to build; poor on clustered scenes.
    Midpoint,
    /// Split at the median centroid on the longest axis (object median): a balanced tree of
    /// depth log2(n), whatever the distribution.
    Median,
    /// Binned surface area heuristic (Wald 2007, "On fast construction of SAH-based bounding
    /// volume hierarchies"): centroids fall into `bins` buckets per axis and the best of the
    /// `bins - 1` planes on all three axes is taken; a node of up to four primitives tries
    /// every division of them instead, which is cheaper there and exact. The default:
    /// near-sweep quality at a fraction of the cost.
    BinnedSah {
        /// Buckets per axis; 8 to 32 is the usual range.
        bins: u32,
    },
    /// Full-sweep SAH: every split between sorted centroids on all three axes. The quality
    /// reference; O(n log^2 n) to build.
    SweepSah,
    /// Not a split: LBVH, the linear BVH (Lauterbach et al. 2009; Karras 2012's binary radix
    /// tree). Primitives are sorted along a Morton curve and each node splits its run where
    /// the highest differing bit of their codes changes: a sort and two linear passes, the
    /// fastest build here, for a tree of a higher SAH cost than a binned SAH one (BENCHMARKS.md,
    /// Static BVH builds). `max_leaf_size` and `max_depth` apply;
    /// `sah_termination` does not (no split is costed).
    Lbvh,
    /// Not a split: PLOC, Parallel Locally-Ordered Clustering (Meister & Bittner 2018), a
    /// bottom-up agglomerative builder run on one thread. Primitives are sorted along a Morton
    /// curve; then, repeatedly, each cluster finds the neighbour within `search_radius` places
    /// on the curve whose union with it has the smallest area, and pairs that choose each other
    /// merge. The fastest builder here ([`SplitStrategy::PLOC_FASTEST`]); with reinsertion
    /// ([`SplitStrategy::PLOC`]) the trees with the lowest SAH cost.
    ///
    /// The stopping rules apply to the finished tree: a subtree becomes a leaf when it fits in
    /// `max_leaf_size` and, with `sah_termination`, its primitives cost no more than the
    /// subtree (the optimal collapse under [`BuildConfig::sah`]). A bottom-up tree has no depth
    /// bound of its own; a subtree that would reach below `max_depth` is rebuilt top-down
    /// (binned SAH) from where it starts.
    Ploc {
        /// Neighbours looked at on each side, 1 to [`crate::bvh::MAX_SEARCH_RADIUS`]
        /// (clamped). The paper uses 16 on a GPU; radius 1 builds fastest, larger radii find
        /// better pairs at a cost linear in the radius.
        search_radius: u32,
        /// Reinsertion after clustering (Bittner et al. 2013, as parallelised by Meister &
        /// Bittner 2018): the nodes with the largest boxes, this many per thousand nodes, are
        /// moved to where they cost least. 0 skips it; 10 to 20 buys most of its gain. It pays
        /// where primitive sizes vary (large triangles among small ones, as in the
        /// million-triangle benchmark scene: BENCHMARKS.md, Static BVH builds) and finds nothing
        /// to move among boxes of similar size.
        reinsert_per_mille: u32,
    },
}

impl SplitStrategy {
    /// PLOC tuned for build speed: radius 1, no reinsertion.
    pub const PLOC_FASTEST: Self = Self::Ploc {
        search_radius: 1,
        reinsert_per_mille: 0,
    };

    /// PLOC tuned for tree quality: radius 1 and reinsertion of 1.2% of the nodes. On the
    /// million-triangle benchmark scene its SAH cost is below obvhs' `medium_build` preset's
    /// (BENCHMARKS.md, Static BVH builds); reinserting more nodes lowers it a little further,
    /// for a longer build.
    pub const PLOC: Self = Self::Ploc {
        search_radius: 1,
        reinsert_per_mille: 12,
    };
}

/// The SAH cost model: the expected cost of a ray through a node is
/// `traversal + sum(area(child) / area(node) * primitives(child) * intersection)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SahCosts {
    /// Cost of visiting an interior node (one box test per child).
    pub traversal: f32,
    /// Cost of testing one primitive.
    pub intersection: f32,
}

impl Default for SahCosts {
    /// A node visit costs twice a primitive test. With equal costs the SAH splits down to
    /// single-primitive leaves: twice the nodes and a slower build for trees that trace no
    /// faster once collapsed to wide nodes, whose one visit tests up to eight boxes.
    fn default() -> Self {
        Self {
            traversal: 2.0,
            intersection: 1.0,
        }
    }
}

/// Build configuration: split strategy and stopping rules.
///
/// Stopping rules, from the textbook: one primitive (`max_leaf_size = 1`), fewer than n
/// (`max_leaf_size = n`), a depth limit (`max_depth`), and SAH cost termination
/// (`sah_termination`: a node of at most `max_leaf_size` primitives becomes a leaf when testing
/// its primitives costs no more than the best split). Empty nodes are never made. Nodes that
/// cannot be split by position (all centroids equal) are split by count, so degenerate input
/// never recurses forever.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BuildConfig {
    /// How to split.
    pub split: SplitStrategy,
    /// Nodes with more primitives are always split (unless `max_depth` is reached).
    pub max_leaf_size: u32,
    /// Nodes at this depth become leaves, whatever their size (the root has depth 0).
    pub max_depth: u32,
    /// Stop splitting when the SAH says a leaf is cheaper (SAH strategies only).
    pub sah_termination: bool,
    /// The SAH cost model, used by the SAH strategies and by cost reports.
    pub sah: SahCosts,
}

impl Default for BuildConfig {
    /// Binned SAH with 16 bins, leaves of up to 8 primitives chosen by cost.
    fn default() -> Self {
        Self {
            split: SplitStrategy::BinnedSah { bins: 16 },
            max_leaf_size: 8,
            max_depth: 64,
            sah_termination: true,
            sah: SahCosts::default(),
        }
    }
}

impl BuildConfig {
    /// The default configuration with another split strategy.
    pub fn with_split(split: SplitStrategy) -> Self {
        Self {
            split,
            ..Self::default()
        }
    }
}
