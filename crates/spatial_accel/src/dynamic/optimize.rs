//! The incremental optimiser: reinsertion of the worst internal nodes, within a budget.
//!
//! Refit keeps boxes correct but not good: a leaf that crossed the world still hangs under
//! its old parent, whose box now spans both places. Bittner et al. 2013 ("Fast insertion-based
//! optimization of bounding volume hierarchies") repair such trees by repeatedly taking out
//! the internal nodes with the worst inefficiency and reinserting their two children where the
//! SAH wants them. Done to convergence that is a full optimisation; here it runs a bounded
//! number of steps per frame on the nodes the frame's motion touched plus a rotating window
//! of the rest of the tree, so the cost is capped and every node is eventually looked at.

use super::DynamicBvh;
use super::node::NULL;
use core::time::Duration;
use std::time::Instant;

/// What one [`DynamicBvh::optimize`] call did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct OptimizeReport {
    /// Internal nodes scored.
    pub examined: usize,
    /// Internal nodes taken out and their children reinserted.
    pub reinserted: usize,
    /// Wall-clock time spent.
    pub elapsed: Duration,
}

/// Reused buffers and the round-robin position of the optimiser.
#[derive(Debug, Default)]
pub(super) struct OptimizerState {
    cursor: usize,
    candidates: Vec<(f64, u32)>,
    /// Edits (insertions, removals, refits) since the optimiser last ran.
    changes: u64,
    /// The refit buffer holds nodes the optimiser has not looked at yet.
    fresh_refit: bool,
}

impl OptimizerState {
    pub(super) fn note_change(&mut self) {
        self.changes += 1;
    }

    pub(super) fn note_refit(&mut self) {
        self.changes += 1;
        self.fresh_refit = true;
    }
}

impl DynamicBvh {
    /// Reinserts up to `max_reinsertions` of the internal nodes with the worst SAH
    /// inefficiency, stopping early when `budget` is spent. Returns at once when the tree has
    /// not changed since the last call.
    ///
    /// The inefficiency is Bittner's combined measure, the product of `area(n)`,
    /// `area(n) / min(child areas)` and `area(n) / mean(child areas)`. Large nodes whose children are much smaller, or
    /// unbalanced, score high: those are the nodes a moved leaf stretched.
    pub fn optimize(&mut self, budget: Duration, max_reinsertions: usize) -> OptimizeReport {
        let mut report = OptimizeReport::default();
        if self.optimizer.changes == 0
            || self.root == NULL
            || max_reinsertions == 0
            || budget.is_zero()
        {
            return report;
        }
        debug_assert!(self.dirty.is_empty(), "optimize() needs a refit first");
        let start = Instant::now();
        self.optimizer.changes = 0;
        let mut candidates = core::mem::take(&mut self.optimizer.candidates);
        candidates.clear();
        // Scoring touches three nodes at random places in the arena: a few cache misses
        // each, so the candidate pool is kept to a small multiple of what can be reinserted.
        let window = max_reinsertions.saturating_mul(4).max(64);

        // The nodes this frame's motion touched, thinned to the window size.
        if self.optimizer.fresh_refit {
            self.optimizer.fresh_refit = false;
            let touched = self.last_refit_nodes();
            let stride = touched.len().div_ceil(window).max(1);
            for &i in touched.iter().step_by(stride) {
                if let Some(s) = self.inefficiency(i) {
                    candidates.push((s, i));
                }
            }
        }
        // A window of the arena, so untouched regions are improved too, a slice per frame.
        let len = self.arena.nodes.len();
        let span = window.min(len);
        for k in 0..span {
            let i = ((self.optimizer.cursor + k) % len) as u32;
            if let Some(s) = self.inefficiency(i) {
                candidates.push((s, i));
            }
        }
        self.optimizer.cursor = (self.optimizer.cursor + span) % len.max(1);
        report.examined = candidates.len();

        let k = max_reinsertions.min(candidates.len());
        if k > 0 && k < candidates.len() {
            candidates.select_nth_unstable_by(k - 1, |a, b| b.0.total_cmp(&a.0));
        }
        candidates.truncate(k);
        candidates.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));

        for (n, &(_, node)) in candidates.iter().enumerate() {
            if n % 8 == 7 && start.elapsed() >= budget {
                break;
            }
            // An earlier reinsertion may have freed or moved this node; what matters is
            // only that it is still an internal node with a parent.
            let nd = &self.arena.nodes[node as usize];
            if !nd.is_internal() || nd.parent == NULL {
                continue;
            }
            self.reinsert_children(node);
            report.reinserted += 1;
        }
        self.optimizer.candidates = candidates;
        report.elapsed = start.elapsed();
        report
    }

    /// Bittner's combined inefficiency of an internal, non-root node.
    fn inefficiency(&self, i: u32) -> Option<f64> {
        let n = &self.arena.nodes[i as usize];
        if !n.is_internal() || n.parent == NULL {
            return None;
        }
        let [a, b] = n.children;
        let area = f64::from(n.aabb.half_area());
        let area_a = f64::from(self.arena.nodes[a as usize].aabb.half_area());
        let area_b = f64::from(self.arena.nodes[b as usize].aabb.half_area());
        // The epsilon keeps point-like children from dividing by zero; such nodes score as
        // very inefficient only if they are themselves large, which is the right answer.
        let eps = 1e-12;
        let m_min = area / (area_a.min(area_b) + eps);
        let m_sum = area / ((area_a + area_b) * 0.5 + eps);
        Some(area * m_min * m_sum)
    }

    /// Takes internal node `node` out of the tree and reinserts its two children as
    /// subtrees, each where the SAH branch and bound puts it.
    fn reinsert_children(&mut self, node: u32) {
        let [a, b] = self.arena.nodes[node as usize].children;
        self.detach(node);
        self.free_node(node);
        self.arena.nodes[a as usize].parent = NULL;
        self.arena.nodes[b as usize].parent = NULL;
        // `detach` and `free_node` returned two slots to the free list; the two attachments
        // take them back, so the arena does not grow.
        self.attach(a);
        self.attach(b);
    }
}
