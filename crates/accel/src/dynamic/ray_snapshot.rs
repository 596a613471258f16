//! The 8-wide copy of a still dynamic tree that rays walk instead of the binary tree, made in
//! place or on another thread, and dropped at the tree's next change.
//!
//! A binary tree is deep: on the picking bench a ray through the dynamic tree of 10,000
//! entities visits 52 binary nodes, against about 10 wide ones through the static tree.
//! Copying the tree into wide nodes after every change would cost more than the rays save
//! (1.8 ms at 10,000 leaves, 20-45 ms at 100,000, on the benchmark VM), so the copy is made
//! once the tree holds still, and kept until it changes.

use super::DynamicBvh;
use super::flatten::flatten;
use crate::bvh::wide::Bvh8;
use std::thread::JoinHandle;

/// A copy being made on another thread, of the tree as it was at `generation`.
#[derive(Debug)]
struct Job {
    generation: u64,
    handle: JoinHandle<Bvh8>,
}

/// The ray copy of a dynamic tree, and the count of changes that tells whether a copy made
/// on another thread still matches the tree.
#[derive(Debug, Default)]
pub(super) struct RaySnapshot {
    wide: Option<Bvh8>,
    /// Bumped at every change of the tree (every mutable access, in fact).
    generation: u64,
    job: Option<Job>,
}

impl Clone for RaySnapshot {
    /// The copy is cloned; a copy still being made is not (the clone makes its own).
    fn clone(&self) -> Self {
        Self {
            wide: self.wide.clone(),
            generation: self.generation,
            job: None,
        }
    }
}

impl RaySnapshot {
    /// The copy, when one matches the tree.
    #[inline]
    pub fn wide(&self) -> Option<&Bvh8> {
        self.wide.as_ref()
    }

    /// Whether a copy is being made on another thread.
    pub fn is_pending(&self) -> bool {
        self.job.is_some()
    }

    /// The tree is about to change: the copy no longer matches, nor will one being made.
    #[inline]
    pub fn invalidate(&mut self) {
        self.wide = None;
        self.generation = self.generation.wrapping_add(1);
    }

    /// Whether `tree` can be copied: not empty, and refit (its inner boxes bound its leaves).
    fn can_copy(tree: &DynamicBvh) -> bool {
        !tree.is_empty() && !tree.needs_refit()
    }

    /// Copies `tree` now, unless a copy is held. Returns whether one is held.
    pub fn make(&mut self, tree: &DynamicBvh) -> bool {
        if self.wide.is_none() && Self::can_copy(tree) {
            self.wide = Some(Bvh8::from_bvh(&tree.to_flat_bvh()));
        }
        self.wide.is_some()
    }

    /// Starts copying `tree` on another thread, unless a copy is held or being made. The
    /// thread works on a copy of the arena and the tight boxes (two `memcpy`s), so the tree
    /// stays free to change;
    /// a change before [`Self::poll`] installs the result makes it stale, and it is dropped.
    /// Returns whether a copy is held or being made.
    pub fn start(&mut self, tree: &DynamicBvh) -> bool {
        if self.wide.is_some() || self.job.is_some() {
            return true;
        }
        if !Self::can_copy(tree) {
            return false;
        }
        let (arena, tight) = (tree.arena.nodes.clone(), tree.tight.clone());
        let (root, leaves) = (tree.root, tree.len());
        let spawned = std::thread::Builder::new()
            .name("accel-dynamic-ray-snapshot".into())
            .spawn(move || Bvh8::from_bvh(&flatten(&arena, &tight, root, leaves)));
        match spawned {
            Ok(handle) => {
                self.job = Some(Job {
                    generation: self.generation,
                    handle,
                });
                true
            }
            // No thread to be had: rays keep the binary tree.
            Err(_) => false,
        }
    }

    /// Installs a copy finished on another thread if the tree has not changed since it was
    /// started, and drops it otherwise. Does not wait. Returns whether a copy is held.
    pub fn poll(&mut self) -> bool {
        if self.job.as_ref().is_some_and(|job| job.handle.is_finished())
            && let Some(job) = self.job.take()
            // A thread that panicked leaves the binary tree in use.
            && let Ok(wide) = job.handle.join()
            && job.generation == self.generation
        {
            self.wide = Some(wide);
        }
        self.wide.is_some()
    }
}
