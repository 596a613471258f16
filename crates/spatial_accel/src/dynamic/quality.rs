//! The quality monitor and rebuilds: knowing when incremental repair is no longer enough.
//!
//! The SAH cost of the tree is `(ct * sum internal areas + ci * sum leaf areas) / root area`.
//! Every box write goes through `set_aabb`, which keeps both sums current, so the cost is O(1)
//! to read. What a fresh build *would* cost is estimated from a sample: a binned-SAH build over
//! about a thousand leaves drawn at random from the arena costs, per sampled leaf, a fixed
//! fraction of what a build over all `n` costs per leaf, and that fraction is measured at each
//! rebuild (when a fresh build's cost is known). The sample is rebuilt every few frames that changed the
//! tree, so the estimate follows the scene as it spreads, clusters, or as leaves grow fat.
//!
//! Why not scale the last build's internal-to-leaf area ratio by the current leaf area, which
//! is O(1): leaf areas and internal areas do not grow together. Where moving leaves are
//! fattened along their motion, such a scaled estimate comes out far too high, so the tree
//! looks much better than a fresh build and the monitor never fires. A sampled build
//! over-reads such inflation a little instead, which errs towards an early rebuild.
//!
//! The tree is also rebuilt when its leaf count doubled or halved since the last rebuild,
//! which keeps the measured fraction calibrated, and
//! [`DynamicBvh::measure_fresh_build_cost`] gives the exact figure when a test or benchmark
//! wants it.

use super::DynamicBvh;
use super::node::{FLAG_PLACED, NULL};
use crate::bvh::stats::tree_stats;
use crate::{Aabb, BuildConfig, Bvh, SplitStrategy};
use std::thread::JoinHandle;

/// The tree's SAH cost against an estimate of a fresh binned-SAH build's.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct QualityEstimate {
    /// SAH cost of the tree as it is (see [`crate::bvh::stats::TreeStats::sah_cost`]).
    pub sah_cost: f32,
    /// Estimated SAH cost of a fresh binned-SAH build over the same fat boxes, or `None`
    /// before the first rebuild calibrated the estimate.
    pub fresh_estimate: Option<f32>,
    /// `sah_cost / fresh_estimate` (1.0 before calibration).
    pub ratio: f32,
}

/// What one [`DynamicBvh::maintain`] call did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MaintainReport {
    /// Internal nodes the refit recomputed.
    pub refit_nodes: usize,
    /// The optimiser's work.
    pub optimize: super::OptimizeReport,
    /// The quality after the call.
    pub quality: QualityEstimate,
    /// A rebuild was done (synchronously) or a finished background one swapped in.
    pub rebuilt: bool,
    /// A background rebuild was started.
    pub rebuild_started: bool,
}

/// About how many leaves the estimate's sample build takes.
const SAMPLE_LEAVES: usize = 1024;

/// Maintain calls between two sample builds (only calls after which the tree had changed
/// count): a build over the sample is too dear for every call, so it is spread out.
const SAMPLE_PERIOD: u32 = 16;

#[derive(Clone, Copy, Debug)]
struct Calibration {
    /// Fresh build cost over (sample cost per sampled leaf times leaf count), measured when
    /// the tree was a fresh build.
    scale: f64,
    /// Leaves at that build.
    leaves: usize,
}

#[derive(Debug)]
struct Job {
    /// The build and its SAH cost (measured on the build thread, over the snapshot's boxes).
    handle: JoinHandle<(Bvh, f32)>,
    /// The leaves the background build was given: (arena index, generation), in input order.
    snapshot: Vec<(u32, u32)>,
}

/// Calibration and the background rebuild in flight.
#[derive(Debug, Default)]
pub(super) struct QualityState {
    calibration: Option<Calibration>,
    /// The last sampled estimate of a fresh build's SAH cost.
    fresh_estimate: Option<f32>,
    /// Edits (insertions, removals, moves, reinsertions) since the tree was created; the
    /// sample is rebuilt only if this moved.
    edits: u64,
    edits_at_sample: u64,
    calls_since_sample: u32,
    job: Option<Job>,
    rebuilds: u64,
}

impl QualityState {
    pub(super) fn clone_without_job(&self) -> Self {
        Self {
            calibration: self.calibration,
            fresh_estimate: self.fresh_estimate,
            edits: self.edits,
            edits_at_sample: self.edits_at_sample,
            calls_since_sample: self.calls_since_sample,
            job: None,
            rebuilds: self.rebuilds,
        }
    }

    /// Notes that the tree changed (cheap: called on every edit).
    #[inline]
    pub(super) fn note_edit(&mut self) {
        self.edits = self.edits.wrapping_add(1);
    }
}

/// The build a rebuild runs: binned SAH to single-primitive leaves, the shape the dynamic tree
/// keeps (so the new tree can be adopted node for node).
pub(super) fn rebuild_config() -> BuildConfig {
    BuildConfig {
        split: SplitStrategy::BinnedSah { bins: 16 },
        max_leaf_size: 1,
        max_depth: u32::MAX,
        sah_termination: false,
        ..BuildConfig::default()
    }
}

impl DynamicBvh {
    /// The SAH cost of the tree and the ratio to the estimated cost of a fresh build; O(1).
    /// The estimate is the one [`maintain`](Self::maintain) last sampled.
    pub fn quality(&self) -> QualityEstimate {
        let sah_cost = self.sah_cost_from_sums(self.internal_area, self.leaf_area);
        let fresh_estimate = self.quality.fresh_estimate;
        let ratio = match fresh_estimate {
            Some(f) if f > 0.0 => sah_cost / f,
            _ => 1.0,
        };
        QualityEstimate {
            sah_cost,
            fresh_estimate,
            ratio,
        }
    }

    /// SAH cost per leaf of a binned-SAH build over a random sample of the leaves' fat boxes
    /// (all of them in a small tree), or `None` for an empty tree.
    fn sample_cost_per_leaf(&self) -> Option<f64> {
        let nodes = &self.arena.nodes;
        // A small tree is measured whole: drawing with replacement from it would repeat
        // leaves, and repeats change the cost per leaf.
        if self.leaf_count <= 2 * SAMPLE_LEAVES {
            let boxes: Vec<Aabb> = nodes
                .iter()
                .filter(|n| n.is_leaf())
                .map(|n| n.aabb)
                .collect();
            return self.cost_per_leaf_of(&boxes);
        }
        // Slots are drawn at pseudo-random (fixed-seed, so every sample is drawn alike) until
        // the sample holds about `SAMPLE_LEAVES` leaves. Not a stride through the arena: an
        // insertion allocates a leaf and its parent together, so leaves and internal nodes
        // alternate there and an even stride can land on internal nodes only. And always about
        // the same number of leaves, whatever the population: a sample of another size would
        // have another cost per leaf (deeper trees cost more per leaf), and the estimate would
        // drift with the population instead of with the tree.
        let wanted = SAMPLE_LEAVES;
        let mut boxes: Vec<Aabb> = Vec::with_capacity(wanted);
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        for _ in 0..8 * wanted {
            if boxes.len() == wanted {
                break;
            }
            // splitmix64
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            let n = &nodes[(z % nodes.len() as u64) as usize];
            if n.is_leaf() {
                boxes.push(n.aabb);
            }
        }
        self.cost_per_leaf_of(&boxes)
    }

    /// SAH cost per leaf of a binned-SAH build over `boxes` (`None` if there are none).
    fn cost_per_leaf_of(&self, boxes: &[Aabb]) -> Option<f64> {
        if boxes.is_empty() {
            return None;
        }
        let bvh = Bvh::build(boxes, &rebuild_config());
        let cost = tree_stats(&bvh, &self.config.sah).sah_cost;
        Some(f64::from(cost) / boxes.len() as f64)
    }

    /// Re-measures the sample and refreshes the fresh-build estimate.
    fn resample_estimate(&mut self) {
        self.quality.edits_at_sample = self.quality.edits;
        self.quality.calls_since_sample = 0;
        self.quality.fresh_estimate = match (self.quality.calibration, self.sample_cost_per_leaf())
        {
            (Some(c), Some(per_leaf)) => Some((c.scale * per_leaf * self.leaf_count as f64) as f32),
            _ => None,
        };
    }

    fn sah_cost_from_sums(&self, internal: f64, leaf: f64) -> f32 {
        if self.root == NULL {
            return 0.0;
        }
        let costs = self.config.sah;
        let root_area = self.arena.nodes[self.root as usize].aabb.half_area_f64();
        if root_area > 0.0 {
            ((internal * f64::from(costs.traversal) + leaf * f64::from(costs.intersection))
                / root_area) as f32
        } else {
            // Everything at one point: weight each node 1, as `tree_stats` does.
            let n = self.leaf_count as f32;
            (n - 1.0) * costs.traversal + n * costs.intersection
        }
    }

    /// The exact SAH cost of a fresh binned-SAH build over the current fat boxes (O(n log n):
    /// for tests, benchmarks and calibration, not for every frame).
    pub fn measure_fresh_build_cost(&self) -> f32 {
        let boxes: Vec<Aabb> = self
            .arena
            .nodes
            .iter()
            .filter(|n| n.is_leaf())
            .map(|n| n.aabb)
            .collect();
        let bvh = Bvh::build(&boxes, &rebuild_config());
        tree_stats(&bvh, &self.config.sah).sah_cost
    }

    /// Number of rebuilds installed so far.
    pub fn rebuild_count(&self) -> u64 {
        self.quality.rebuilds
    }

    /// True while a background rebuild runs.
    pub fn rebuild_in_flight(&self) -> bool {
        self.quality.job.is_some()
    }

    /// True when a background rebuild is done and waits for [`maintain`](Self::maintain) (or
    /// [`finish_background_rebuild`](Self::finish_background_rebuild)) to install it. An
    /// engine that maintains the tree only in frames with edits must also do so then, or a
    /// world that holds still after a large spawn keeps its tree of insertions for good.
    pub fn rebuild_finished(&self) -> bool {
        self.quality
            .job
            .as_ref()
            .is_some_and(|j| j.handle.is_finished())
    }

    /// The once-per-frame call: refit what moved, install a finished background rebuild,
    /// optimise within the configured budget, and rebuild when the quality estimate passed
    /// [`DynamicBvhConfig::rebuild_threshold`](super::DynamicBvhConfig::rebuild_threshold) or
    /// the leaf count doubled or halved since the last rebuild. A frame in which nothing
    /// changed costs a few comparisons.
    pub fn maintain(&mut self) -> MaintainReport {
        let mut report = MaintainReport {
            refit_nodes: self.refit(),
            ..MaintainReport::default()
        };
        if self.rebuild_finished() {
            report.rebuilt = self.finish_background_rebuild();
        }
        // A fixed count would rework a small tree whole every frame: at a thousand leaves,
        // 512 reinsertions a frame cost more than the rest of the plugin's frame and more
        // than the motion they repair (quality decays with the leaves moved, a share of the
        // tree). So the count follows the tree's size.
        let (budget, max) = (
            self.config.optimize_budget,
            self.config
                .optimize_max_reinsertions
                .min((self.leaf_count / 32).max(16)),
        );
        report.optimize = self.optimize(budget, max);
        if self.quality.calibration.is_some() && self.quality.edits != self.quality.edits_at_sample
        {
            self.quality.calls_since_sample += 1;
            if self.quality.calls_since_sample >= SAMPLE_PERIOD {
                self.resample_estimate();
            }
        }
        report.quality = self.quality();
        if self.quality.job.is_none() && self.wants_rebuild(&report.quality) {
            if self.config.background_rebuild {
                self.start_background_rebuild();
                report.rebuild_started = true;
            } else {
                self.rebuild();
                report.rebuilt = true;
                report.quality = self.quality();
            }
        }
        report
    }

    fn wants_rebuild(&self, q: &QualityEstimate) -> bool {
        let n = self.leaf_count;
        if n < self.config.min_leaves_for_rebuild {
            return false;
        }
        match self.quality.calibration {
            None => true,
            Some(c) => {
                n > 2 * c.leaves || 2 * n < c.leaves || q.ratio > self.config.rebuild_threshold
            }
        }
    }

    /// Rebuilds the whole tree with binned SAH now, keeping every handle valid.
    pub fn rebuild(&mut self) {
        self.refit();
        let (snapshot, boxes) = self.snapshot();
        let bvh = Bvh::build(&boxes, &rebuild_config());
        self.install(&bvh, &snapshot, None);
    }

    /// Starts a rebuild on another thread over a snapshot of the fat boxes; a later
    /// [`maintain`](Self::maintain) (or [`finish_background_rebuild`](Self::finish_background_rebuild))
    /// swaps it in, with the insertions, removals and moves made meanwhile applied. Does
    /// nothing if one is already running.
    pub fn start_background_rebuild(&mut self) {
        if self.quality.job.is_some() {
            return;
        }
        self.refit();
        let (snapshot, boxes) = self.snapshot();
        let costs = self.config.sah;
        let spawned = std::thread::Builder::new()
            .name("accel-dynamic-bvh-rebuild".into())
            .spawn(move || {
                let bvh = Bvh::build(&boxes, &rebuild_config());
                let cost = tree_stats(&bvh, &costs).sah_cost;
                (bvh, cost)
            });
        match spawned {
            Ok(handle) => self.quality.job = Some(Job { handle, snapshot }),
            // No thread to be had: the rebuild still has to happen.
            Err(_) => self.rebuild(),
        }
    }

    /// Waits for the background rebuild, if any, and swaps it in. Returns whether one was
    /// installed (a build thread that panicked installs nothing and leaves the tree as is).
    pub fn finish_background_rebuild(&mut self) -> bool {
        let Some(job) = self.quality.job.take() else {
            return false;
        };
        match job.handle.join() {
            Ok((bvh, cost)) => {
                self.refit();
                self.install(&bvh, &job.snapshot, Some(cost));
                true
            }
            Err(_) => false,
        }
    }

    /// Drops a background rebuild without installing it.
    pub(super) fn finish_background_rebuild_discard(&mut self) {
        if let Some(job) = self.quality.job.take() {
            // The result is stale by definition here; joining only reclaims the thread.
            let _ = job.handle.join();
        }
    }

    fn snapshot(&self) -> (Vec<(u32, u32)>, Vec<Aabb>) {
        let mut snapshot = Vec::with_capacity(self.leaf_count);
        let mut boxes = Vec::with_capacity(self.leaf_count);
        for (i, n) in self.arena.nodes.iter().enumerate() {
            if n.is_leaf() {
                snapshot.push((i as u32, n.generation));
                boxes.push(n.aabb);
            }
        }
        (snapshot, boxes)
    }

    /// Replaces every internal node by those of `bvh`, built over the leaves of `snapshot`.
    ///
    /// The tree may have changed since the snapshot: leaves removed since (their generation
    /// moved on) are dropped and their parents collapsed, leaves that moved get boxes from
    /// their current fat bounds (boxes are recomputed bottom-up here, not copied from the
    /// build), and leaves inserted since are inserted afterwards by the usual SAH insertion.
    ///
    /// `build_cost` is the build's SAH cost when it was measured elsewhere (a background
    /// build, whose boxes may have moved since); otherwise the installed tree's is used.
    fn install(&mut self, bvh: &Bvh, snapshot: &[(u32, u32)], build_cost: Option<f32>) {
        debug_assert!(self.dirty.is_empty());
        self.schedule.invalidate();
        let len = self.arena.nodes.len();
        // Freed straight to the arena, outside the area sums: taking every internal node's
        // area out one by one would drive the sum below its cancellation threshold again and
        // again near the end, each time an O(n) recount.
        for i in 0..len as u32 {
            if self.arena.nodes[i as usize].is_internal() {
                self.arena.free(i);
            }
        }
        self.internal_area = 0.0;
        self.area_peaks.0 = 0.0;
        self.root = NULL;
        let nodes = bvh.nodes();
        let prims = bvh.primitive_indices();
        let mut map = vec![NULL; nodes.len()];
        let (mut placed, mut placed_area) = (0usize, 0.0f64);
        // Children follow their parent in the flat array, so a reverse sweep is bottom-up.
        for i in (0..nodes.len()).rev() {
            let n = nodes[i];
            map[i] = if n.is_leaf() {
                let mut m = NULL;
                for &p in &prims[n.first as usize..(n.first + n.count) as usize] {
                    let (leaf, generation) = snapshot[p as usize];
                    let ln = &mut self.arena.nodes[leaf as usize];
                    if ln.is_leaf() && ln.generation == generation {
                        ln.flags |= FLAG_PLACED;
                        placed += 1;
                        placed_area += ln.aabb.half_area_f64();
                        m = self.join(m, leaf);
                    }
                }
                m
            } else {
                self.join(map[n.first as usize], map[n.first as usize + 1])
            };
        }
        if let Some(&r) = map.first()
            && r != NULL
        {
            self.root = r;
            self.arena.nodes[r as usize].parent = NULL;
        }
        // What a fresh build costs calibrates the sample's cost. After a synchronous rebuild
        // the tree now *is* that build, over the current boxes: its cost is O(1) from the
        // internal-area sum the joins kept and the placed leaves' areas. A background build
        // was made over boxes that may have moved since (moved leaves stretch the installed
        // structure), so its own cost, measured on its thread, is used instead.
        let (fresh, built_leaves) = match build_cost {
            Some(cost) => (f64::from(cost), bvh.primitive_indices().len()),
            None => (
                f64::from(self.sah_cost_from_sums(self.internal_area, placed_area)),
                placed,
            ),
        };
        let mut leaf_area = 0.0f64;
        for i in 0..len as u32 {
            let n = &mut self.arena.nodes[i as usize];
            if n.is_leaf() {
                leaf_area += n.aabb.half_area_f64();
                if n.flags & FLAG_PLACED != 0 {
                    n.flags &= !FLAG_PLACED;
                } else {
                    n.parent = NULL;
                    self.attach(i);
                }
            }
        }
        // Both sums afresh without a recount pass: the internal one was zeroed above and
        // counted by the joins and attachments, the leaves' in this loop.
        self.leaf_area = leaf_area;
        self.area_peaks = (self.internal_area, leaf_area);
        self.quality.calibration = self.sample_cost_per_leaf().map(|per_leaf| Calibration {
            scale: if per_leaf > 0.0 && built_leaves > 0 {
                fresh / (per_leaf * built_leaves as f64)
            } else {
                1.0
            },
            leaves: self.leaf_count,
        });
        self.quality.fresh_estimate = self
            .quality
            .calibration
            .map(|_| (fresh * self.leaf_count as f64 / built_leaves.max(1) as f64) as f32);
        self.quality.edits_at_sample = self.quality.edits;
        self.quality.calls_since_sample = 0;
        self.quality.rebuilds += 1;
        // The refit buffer names internal nodes that were just freed: the optimiser must not
        // take them for candidates.
        self.refit_sorted.clear();
    }

    /// A parent for two subtrees (either may be missing).
    fn join(&mut self, a: u32, b: u32) -> u32 {
        if a == NULL {
            return b;
        }
        if b == NULL {
            return a;
        }
        let p = self.alloc_internal();
        let (na, nb) = (&self.arena.nodes[a as usize], &self.arena.nodes[b as usize]);
        let (bx, h) = (na.aabb.union(&nb.aabb), 1 + na.height.max(nb.height));
        let pn = &mut self.arena.nodes[p as usize];
        pn.children = [a, b];
        pn.height = h;
        self.set_aabb(p, bx);
        self.arena.nodes[a as usize].parent = p;
        self.arena.nodes[b as usize].parent = p;
        p
    }

    /// Recomputes both area sums from scratch (clears floating-point drift).
    pub(super) fn recompute_area_sums(&mut self) {
        let (mut internal, mut leaf) = (0.0f64, 0.0f64);
        for n in &self.arena.nodes {
            if n.is_leaf() {
                leaf += n.aabb.half_area_f64();
            } else if n.is_internal() {
                internal += n.aabb.half_area_f64();
            }
        }
        self.internal_area = internal;
        self.leaf_area = leaf;
        self.area_peaks = (internal, leaf);
    }
}
