//! The 8-wide tree that rays walk instead of a still dynamic tree, built in place or on
//! another thread, and dropped at the tree's next change.
//!
//! A binary tree is deep: on the picking bench a ray through the dynamic tree of 10,000
//! entities visits 52 binary nodes, against about 10 wide ones through the static tree.
//! Building a wide tree after every change would cost more than the rays save, so it is built
//! once the tree holds still, and kept until it changes.
//!
//! It is a fresh build over the leaves' *tight* boxes, not a copy of the dynamic tree's
//! shape. Why: the dynamic tree is shaped for motion (fat boxes, insertions, rotations), and
//! the snapshot never sees motion. On the picking bench at 100,000 entities, rays through a
//! copy of the dynamic tree's shape (even refit to the tight boxes) visited 18.1 wide nodes
//! and 3.67 candidates each, and ran 1.15-1.8x slower than through a PLOC build over the same
//! boxes, which visited 13.4 and 3.33, as many as the static tree over the same entities.

use super::DynamicBvh;
use crate::bvh::wide::Bvh8;
use crate::{Aabb, BuildConfig, Bvh};
use std::thread::JoinHandle;

/// A snapshot being built on another thread, of the tree as it was at `generation`.
#[derive(Debug)]
struct Job {
    generation: u64,
    handle: JoinHandle<Bvh8>,
}

/// The ray snapshot of a dynamic tree, and the count of changes that tells whether a snapshot
/// built on another thread still matches the tree.
#[derive(Debug, Default)]
pub(super) struct RaySnapshot {
    wide: Option<Bvh8>,
    /// Bumped at every change of the tree (every mutable access, in fact).
    generation: u64,
    job: Option<Job>,
}

impl Clone for RaySnapshot {
    /// The snapshot is cloned; one still being built is not (the clone builds its own).
    fn clone(&self) -> Self {
        Self {
            wide: self.wide.clone(),
            generation: self.generation,
            job: None,
        }
    }
}

/// A live leaf's id and tight box, in arena order: what a snapshot is built from.
struct LeafBoxes {
    ids: Vec<u32>,
    boxes: Vec<Aabb>,
}

impl LeafBoxes {
    fn of(tree: &DynamicBvh) -> Self {
        let (ids, boxes) = tree.leaves().map(|(_, id, b)| (id, b)).unzip();
        Self { ids, boxes }
    }

    /// The binary tree over the boxes, its primitive indices turned into the leaves' ids.
    fn build(&self, config: &BuildConfig) -> Bvh {
        let mut bvh = Bvh::build(&self.boxes, config);
        for p in &mut bvh.primitive_indices {
            *p = self.ids[*p as usize];
        }
        bvh
    }
}

impl RaySnapshot {
    /// The snapshot, when one matches the tree.
    #[inline]
    pub fn wide(&self) -> Option<&Bvh8> {
        self.wide.as_ref()
    }

    /// Whether a snapshot is being built on another thread.
    pub fn is_pending(&self) -> bool {
        self.job.is_some()
    }

    /// The tree is about to change: the snapshot no longer matches, nor will one being built.
    #[inline]
    pub fn invalidate(&mut self) {
        self.wide = None;
        self.generation = self.generation.wrapping_add(1);
    }

    /// Builds the snapshot of `tree` now with `config`, unless one is held. Returns whether
    /// one is held.
    pub fn make(&mut self, tree: &DynamicBvh, config: &BuildConfig) -> bool {
        if self.wide.is_none() && !tree.is_empty() {
            self.wide = Some(Bvh8::from_bvh(&LeafBoxes::of(tree).build(config)));
        }
        self.wide.is_some()
    }

    /// Starts building the snapshot of `tree` on another thread, unless one is held or being
    /// built. The thread works on a copy of the leaves' ids and tight boxes (one pass over the
    /// arena here), so the tree stays free to change; a change before [`Self::poll`] installs
    /// the result makes it stale, and it is dropped. Returns whether a snapshot is held or
    /// being built.
    pub fn start(&mut self, tree: &DynamicBvh, config: &BuildConfig) -> bool {
        if self.wide.is_some() || self.job.is_some() {
            return true;
        }
        if tree.is_empty() {
            return false;
        }
        let leaves = LeafBoxes::of(tree);
        let config = *config;
        let spawned = std::thread::Builder::new()
            .name("accel-dynamic-ray-snapshot".into())
            .spawn(move || Bvh8::from_bvh(&leaves.build(&config)));
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

    /// Installs a snapshot finished on another thread if the tree has not changed since it
    /// was started, and drops it otherwise. Does not wait. Returns whether a snapshot is held.
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

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3A;

    /// The snapshot's binary tree holds every live leaf's id exactly once, over its tight box
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
            let bvh = LeafBoxes::of(&tree).build(&config);
            bvh.validate(&boxes).unwrap();
            let union = boxes.iter().fold(Aabb::EMPTY, |acc, b| acc.union(b));
            assert_eq!(bvh.bounds(), union, "round {round}");
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
