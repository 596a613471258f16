//! The 16-wide tree that rays walk instead of the binary dynamic tree, built in place or on
//! another thread, refit along the paths of leaves that move, and dropped at the next
//! insertion or removal.
//!
//! A binary tree is deep: a ray waits on each level's node in turn, and a binary tree has
//! four times the levels of a 16-wide one over the same leaves. Building a wide tree after
//! every change would cost more than the rays save, so it is built once the tree's set of
//! leaves holds still, and refit while they move.
//!
//! It is a fresh build over the leaves' *tight* boxes, not a copy of the dynamic tree's
//! shape. Why: the dynamic tree is shaped for motion (fat boxes, insertions, rotations),
//! while the snapshot only refits tight boxes in place and is rebuilt when it has aged. Rays
//! through a copy of the dynamic tree's shape, even refit to the tight boxes, visit more
//! wide nodes and more candidates, and run clearly slower, than through a PLOC build over
//! the same boxes, which visits as many as the static tree over the same entities
//! (BENCHMARKS.md, Picking).
//!
//! 16-wide, as the static tree's ray copy, since the walk's 16-wide node test runs 8 lanes at
//! a time (`bvh/wide/ray.rs`): rays through the snapshot are faster than through an 8-wide
//! one, and its refits cost no more while entities move (BENCHMARKS.md, Picking).

use super::DynamicBvh;
use crate::bvh::wide::{Bvh16, RefitPaths};
use crate::{Aabb, BuildConfig, Bvh};
use std::thread::JoinHandle;

/// No leaf at this arena index.
const NOT_A_LEAF: u32 = u32::MAX;

/// A snapshot being built on another thread, of the tree's leaves as they were at
/// `generation`, and the leaves that moved since it started (applied when it is installed).
#[derive(Debug)]
struct Job {
    generation: u64,
    handle: JoinHandle<Held>,
    /// Arena indices of leaves updated since the job started.
    moved: Vec<u32>,
}

/// A snapshot and what refits it after motion.
#[derive(Clone, Debug)]
struct Held {
    wide: Bvh16,
    /// The dynamic tree's arena index of the leaf at each position of the leaf order.
    leaf_at: Vec<u32>,
    /// Each arena index's position in the leaf order ([`NOT_A_LEAF`] for other nodes).
    position_of: Vec<u32>,
    paths: RefitPaths,
    /// Refits that found motion since the snapshot was built.
    moving_refits: u32,
}

impl Held {
    fn build(leaves: &LeafBoxes, config: &BuildConfig) -> Self {
        let mut wide = Bvh16::from_bvh(&Bvh::build(&leaves.boxes, config));
        let leaf_at: Vec<u32> = wide
            .primitive_indices
            .iter()
            .map(|&k| leaves.arena[k as usize])
            .collect();
        for p in &mut wide.primitive_indices {
            *p = leaves.ids[*p as usize];
        }
        // Single-entity leaves, most of this tree's: see `inline_single_leaves`.
        wide.inline_single_leaves();
        let end = leaves.arena.iter().max().map_or(0, |&a| a as usize + 1);
        let mut position_of = vec![NOT_A_LEAF; end];
        for (position, &leaf) in leaf_at.iter().enumerate() {
            position_of[leaf as usize] = position as u32;
        }
        Self {
            paths: RefitPaths::of(&wide),
            wide,
            leaf_at,
            position_of,
            moving_refits: 0,
        }
    }

    /// Refits the boxes above the `moved` leaves (arena indices) to the tree's tight boxes.
    fn refit(&mut self, tree: &DynamicBvh, moved: &[u32]) {
        let Self {
            wide,
            leaf_at,
            position_of,
            paths,
            ..
        } = self;
        let bounds_at = |position: usize| tree.tight[leaf_at[position] as usize];
        // Past a quarter of the leaves, paths overlap so much that one sweep over every node
        // is cheaper than climbing them.
        if moved.len() > leaf_at.len() / 4 {
            wide.refit_at(bounds_at);
        } else {
            let positions = moved.iter().map(|&leaf| position_of[leaf as usize]);
            wide.refit_moved(paths, positions, bounds_at);
        }
        self.moving_refits = self.moving_refits.saturating_add(1);
    }
}

/// The ray snapshot of a dynamic tree, and the count of insertions and removals that tells
/// whether a snapshot built on another thread still holds the tree's leaves.
///
/// Motion does not drop it: leaves that move are listed ([`Self::note_moved`]) and the
/// snapshot is refit along their paths ([`Self::refit`]); rays do not use it in between.
#[derive(Debug, Default)]
pub(super) struct RaySnapshot {
    held: Option<Held>,
    /// Arena indices of leaves updated since the held snapshot's last refit.
    moved: Vec<u32>,
    /// Bumped at every change of the tree's set of leaves (every mutable access, in fact,
    /// except updates and maintenance through the pair's own methods).
    generation: u64,
    job: Option<Job>,
}

impl Clone for RaySnapshot {
    /// The snapshot is cloned; one still being built is not (the clone builds its own).
    fn clone(&self) -> Self {
        Self {
            held: self.held.clone(),
            moved: self.moved.clone(),
            generation: self.generation,
            job: None,
        }
    }
}

/// Every live leaf's arena index, id and tight box, in arena order: what a snapshot is built
/// from.
struct LeafBoxes {
    arena: Vec<u32>,
    ids: Vec<u32>,
    boxes: Vec<Aabb>,
}

impl LeafBoxes {
    fn of(tree: &DynamicBvh) -> Self {
        let n = tree.len();
        let mut leaves = Self {
            arena: Vec::with_capacity(n),
            ids: Vec::with_capacity(n),
            boxes: Vec::with_capacity(n),
        };
        for (handle, id, bounds) in tree.leaves() {
            leaves.arena.push(handle.index());
            leaves.ids.push(id);
            leaves.boxes.push(bounds);
        }
        leaves
    }
}

impl RaySnapshot {
    /// The snapshot, when one is held and refit to every update.
    #[inline]
    pub fn wide(&self) -> Option<&Bvh16> {
        self.held
            .as_ref()
            .filter(|_| self.moved.is_empty())
            .map(|h| &h.wide)
    }

    /// Whether a snapshot is held with updates not yet refit.
    pub fn needs_refit(&self) -> bool {
        self.held.is_some() && !self.moved.is_empty()
    }

    /// Whether a snapshot is being built on another thread.
    pub fn is_pending(&self) -> bool {
        self.job.is_some()
    }

    /// Whether a snapshot built on another thread is done and waits for [`Self::poll`].
    pub fn is_finished(&self) -> bool {
        self.job
            .as_ref()
            .is_some_and(|job| job.handle.is_finished())
    }

    /// Refits with motion since the held snapshot was built, if one is held.
    pub fn moving_refits(&self) -> Option<u32> {
        self.held.as_ref().map(|h| h.moving_refits)
    }

    /// The tree's set of leaves is about to change: the snapshot no longer matches, nor will
    /// one being built.
    #[inline]
    pub fn invalidate(&mut self) {
        self.held = None;
        self.moved.clear();
        self.generation = self.generation.wrapping_add(1);
    }

    /// Leaf `leaf` (an arena index) was given a new tight box.
    #[inline]
    pub fn note_moved(&mut self, leaf: u32, leaf_count: usize) {
        if self.held.is_some() {
            self.moved.push(leaf);
        }
        if let Some(job) = &mut self.job
            && job.moved.len() <= leaf_count
        {
            // Past one entry per leaf the install refits everything anyway (see `Held::refit`).
            job.moved.push(leaf);
        }
    }

    /// Refits the held snapshot to the leaves updated since its last refit.
    pub fn refit(&mut self, tree: &DynamicBvh) {
        if let Some(held) = &mut self.held
            && !self.moved.is_empty()
        {
            held.refit(tree, &self.moved);
        }
        self.moved.clear();
    }

    /// Builds the snapshot of `tree` now with `config`, unless one is held and `replace` is
    /// false. Returns whether one is held.
    pub fn make(&mut self, tree: &DynamicBvh, config: &BuildConfig, replace: bool) -> bool {
        if (replace || self.held.is_none()) && !tree.is_empty() {
            self.held = Some(Held::build(&LeafBoxes::of(tree), config));
            self.moved.clear();
        }
        self.held.is_some()
    }

    /// Starts building the snapshot of `tree` on another thread, unless one is being built,
    /// or one is held and `replace` is false (a held one serves rays until the new one is
    /// installed). The thread works on a copy of the leaves' arena indices, ids and tight
    /// boxes (one pass over the arena here), so the tree stays free to change: leaves updated
    /// before [`Self::poll`] installs the result are refit then, and an insertion or a
    /// removal makes it stale (it is dropped). Returns whether a snapshot is held or being
    /// built.
    pub fn start(&mut self, tree: &DynamicBvh, config: &BuildConfig, replace: bool) -> bool {
        if self.job.is_some() || (self.held.is_some() && !replace) {
            return true;
        }
        if tree.is_empty() {
            return self.held.is_some();
        }
        let leaves = LeafBoxes::of(tree);
        let config = *config;
        let spawned = std::thread::Builder::new()
            .name("accel-dynamic-ray-snapshot".into())
            .spawn(move || Held::build(&leaves, &config));
        match spawned {
            Ok(handle) => {
                self.job = Some(Job {
                    generation: self.generation,
                    handle,
                    moved: Vec::new(),
                });
                true
            }
            // No thread to be had: rays keep what they have.
            Err(_) => self.held.is_some(),
        }
    }

    /// Installs a snapshot finished on another thread if the tree's leaves are the ones it
    /// was started with, refit to the leaves updated since, and drops it otherwise. Does not
    /// wait. Returns whether a snapshot is held.
    pub fn poll(&mut self, tree: &DynamicBvh) -> bool {
        if self.is_finished()
            && let Some(job) = self.job.take()
            // A thread that panicked leaves the binary tree in use.
            && let Ok(mut held) = job.handle.join()
            && job.generation == self.generation
        {
            if !job.moved.is_empty() {
                held.refit(tree, &job.moved);
                held.moving_refits = 0;
            }
            self.held = Some(held);
            self.moved.clear();
        }
        self.held.is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3A;

    /// The snapshot holds every live leaf's id exactly once, over its tight box
    /// (valid against the id-indexed tight boxes, root their union: a tree over the fat boxes
    /// fails that), also after leaves moved within and out of their fat boxes and some left.
    #[test]
    fn snapshot_is_built_over_the_tight_boxes_by_id() {
        let mut next = crate::test_floats(0x51f1_5eed_0bad_cafe);
        let random_box = |next: &mut dyn FnMut() -> f32| {
            let c = Vec3A::new(next(), next(), next()) * 100.0;
            Aabb::new(c, c + Vec3A::new(next(), next(), next()) + 0.5)
        };
        let mut tree = DynamicBvh::new();
        // Ids are not arena indices: every third id, so a mix-up of the two shows.
        let mut boxes = vec![Aabb::EMPTY; 3 * 600];
        let mut handles = Vec::new();
        for k in 0..600usize {
            let b = random_box(&mut next);
            handles.push(Some(tree.insert(3 * k as u32, b).unwrap()));
            boxes[3 * k] = b;
        }
        let config = BuildConfig::with_split(crate::SplitStrategy::PLOC_FASTEST);
        for round in 0..3 {
            tree.maintain();
            let held = Held::build(&LeafBoxes::of(&tree), &config);
            held.wide.validate(&boxes).unwrap();
            let union = boxes.iter().fold(Aabb::EMPTY, |acc, b| acc.union(b));
            assert_eq!(held.wide.bounds(), union, "round {round}");
            // Move a third (small steps stay inside the fat boxes, every tenth jumps away),
            // and take out every 50th.
            for (k, slot) in handles
                .iter_mut()
                .enumerate()
                .filter(|(k, _)| k % 3 == round)
            {
                let Some(h) = *slot else { continue };
                if k % 50 == 0 {
                    tree.remove(h).unwrap();
                    boxes[3 * k] = Aabb::EMPTY;
                    *slot = None;
                    continue;
                }
                let b = if k % 10 == 0 {
                    random_box(&mut next)
                } else {
                    let step = Vec3A::splat(0.01);
                    Aabb::new(boxes[3 * k].min + step, boxes[3 * k].max + step)
                };
                tree.update(h, b).unwrap();
                boxes[3 * k] = b;
            }
        }
    }
}
