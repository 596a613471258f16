//! The dynamic tree's invariant checker: the static BVH's checks plus links, heights, the free
//! list and the bookkeeping the quality monitor relies on.

use super::DynamicBvh;
use super::node::{FLAG_PLACED, FLAG_QUEUED, NULL};
use crate::Aabb;
use crate::bvh::validate::{ValidationError, validate_tree};
use crate::query::BoundingTree;
use std::fmt;

/// A broken invariant of a [`DynamicBvh`].
#[derive(Clone, Debug, PartialEq)]
pub enum DynamicValidationError {
    /// A check shared with the static BVH failed (boxes, reachability, duplicates). Primitive
    /// numbers in it are leaf ordinals in arena order, not caller ids.
    Tree(ValidationError),
    /// Updates are waiting for a refit, so ancestors' boxes are not current yet.
    PendingUpdates,
    /// A child's parent link does not name its parent (or the root's is not null).
    ParentLink(u32),
    /// A node's stored height is not 1 + the larger of its children's.
    Height(u32),
    /// A free slot is reachable from the root, or the free list is inconsistent.
    FreeList(u32),
    /// The number of live leaves differs from the count kept.
    LeafCount {
        /// Leaves found in the arena.
        found: usize,
        /// Leaves the tree believes it has.
        expected: usize,
    },
    /// An arena slot is neither free nor reachable from the root.
    Unreachable(u32),
    /// A traversal flag was left set.
    StaleFlag(u32),
    /// The whole-tree refit's compiled shape is marked current but names other links than
    /// the tree's (an edit did not invalidate it); the node is the first that differs.
    StaleRefitSchedule(u32),
    /// The incrementally kept area sums drifted from the tree's real areas.
    AreaSums {
        /// Kept sums (internal, leaf).
        kept: (f64, f64),
        /// Recomputed sums (internal, leaf).
        actual: (f64, f64),
    },
}

impl fmt::Display for DynamicValidationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "dynamic BVH invariant broken: {self:?}")
    }
}

impl std::error::Error for DynamicValidationError {}

/// The tree seen with leaf ordinals instead of caller ids as primitives, so the shared
/// validator's "every primitive exactly once" check works whatever ids the caller chose
/// (sparse, huge or repeated).
struct DenseView<'a> {
    tree: &'a DynamicBvh,
    ordinal: Vec<u32>,
}

impl BoundingTree for DenseView<'_> {
    type Volume = Aabb;
    type Children<'a>
        = [u32; 2]
    where
        Self: 'a;

    fn root(&self) -> Option<u32> {
        (self.tree.root != NULL).then_some(self.tree.root)
    }
    fn node_bounds(&self, node: u32) -> Aabb {
        self.tree.arena.nodes[node as usize].aabb
    }
    fn node_children(&self, node: u32) -> Option<[u32; 2]> {
        self.tree.node_children(node)
    }
    fn node_primitives(&self, node: u32) -> &[u32] {
        if self.tree.arena.nodes[node as usize].is_leaf() {
            core::slice::from_ref(&self.ordinal[node as usize])
        } else {
            &[]
        }
    }
}

impl DynamicBvh {
    /// Checks every invariant: each node bounds its children, each fat leaf box contains the
    /// leaf's tight box, each live leaf is reachable exactly once, parent links and heights
    /// are exact, free slots are unreachable, and the area sums are current. O(n).
    pub fn validate(&self) -> Result<(), DynamicValidationError> {
        if !self.dirty.is_empty() {
            return Err(DynamicValidationError::PendingUpdates);
        }
        let nodes = &self.arena.nodes;
        let mut ordinal = vec![NULL; nodes.len()];
        let mut tight = Vec::with_capacity(self.leaf_count);
        for (i, n) in nodes.iter().enumerate() {
            if n.is_leaf() {
                ordinal[i] = tight.len() as u32;
                tight.push(self.tight[i]);
            }
        }
        if tight.len() != self.leaf_count {
            return Err(DynamicValidationError::LeafCount {
                found: tight.len(),
                expected: self.leaf_count,
            });
        }
        let view = DenseView {
            tree: self,
            ordinal,
        };
        validate_tree(&view, nodes.len(), tight.len(), |p| {
            tight.get(p as usize).copied()
        })
        .map_err(DynamicValidationError::Tree)?;

        // Links, heights and flags, walking from the root.
        let mut reached = 0usize;
        if self.root != NULL {
            if nodes[self.root as usize].parent != NULL {
                return Err(DynamicValidationError::ParentLink(self.root));
            }
            let mut stack = vec![self.root];
            while let Some(i) = stack.pop() {
                reached += 1;
                let n = &nodes[i as usize];
                if n.is_free() {
                    return Err(DynamicValidationError::FreeList(i));
                }
                // No update is pending here (checked above), so no leaf may still be marked
                // dirty, and no mark may name an epoch that has not begun.
                if n.flags & (FLAG_QUEUED | FLAG_PLACED) != 0
                    || n.dirty_mark >> 1 >= self.refit_epoch
                {
                    return Err(DynamicValidationError::StaleFlag(i));
                }
                if n.is_internal() {
                    let [a, b] = n.children;
                    for c in [a, b] {
                        if nodes[c as usize].parent != i {
                            return Err(DynamicValidationError::ParentLink(c));
                        }
                    }
                    if n.height != 1 + nodes[a as usize].height.max(nodes[b as usize].height) {
                        return Err(DynamicValidationError::Height(i));
                    }
                    stack.push(a);
                    stack.push(b);
                }
            }
        }
        // Every slot is either reachable or on the free list, and the free list holds only
        // free slots.
        let mut free_seen = 0usize;
        for i in self.arena.free_list() {
            if !nodes[i as usize].is_free() || free_seen > nodes.len() {
                return Err(DynamicValidationError::FreeList(i));
            }
            free_seen += 1;
        }
        if free_seen != self.arena.free_count() {
            return Err(DynamicValidationError::FreeList(NULL));
        }
        if reached + free_seen != nodes.len() {
            let first = nodes
                .iter()
                .enumerate()
                .find(|(_, n)| !n.is_free())
                .map_or(NULL, |(i, _)| i as u32);
            return Err(DynamicValidationError::Unreachable(first));
        }
        debug_assert_eq!(self.arena.live(), reached);

        self.validate_refit_schedule()?;

        let (mut internal, mut leaf) = (0.0f64, 0.0f64);
        for n in nodes {
            if n.is_leaf() {
                leaf += n.aabb.half_area_f64();
            } else if n.is_internal() {
                internal += n.aabb.half_area_f64();
            }
        }
        let close = |kept: f64, actual: f64| (kept - actual).abs() <= 1e-6 * actual.abs().max(1.0);
        if !close(self.internal_area, internal) || !close(self.leaf_area, leaf) {
            return Err(DynamicValidationError::AreaSums {
                kept: (self.internal_area, self.leaf_area),
                actual: (internal, leaf),
            });
        }
        Ok(())
    }

    /// A schedule marked current must list exactly the tree's internal nodes, each with its
    /// two children, breadth-first from the root: a replay of a stale one would write boxes
    /// into nodes that are no longer where it thinks.
    fn validate_refit_schedule(&self) -> Result<(), DynamicValidationError> {
        if !self.schedule.is_valid() {
            return Ok(());
        }
        let nodes = &self.arena.nodes;
        let mut entries = self.schedule.entries();
        let mut internal_nodes = Vec::new();
        if self.root != NULL && nodes[self.root as usize].is_internal() {
            internal_nodes.push(self.root);
        }
        let mut k = 0;
        while k < internal_nodes.len() {
            let i = internal_nodes[k];
            k += 1;
            let Some((listed, children)) = entries.next() else {
                return Err(DynamicValidationError::StaleRefitSchedule(i));
            };
            if listed != i {
                return Err(DynamicValidationError::StaleRefitSchedule(i));
            }
            for (c, recorded) in nodes[i as usize].children.into_iter().zip(children) {
                let expected = if nodes[c as usize].is_internal() {
                    internal_nodes.push(c);
                    Ok(internal_nodes.len() as u32 - 1)
                } else {
                    Err(c)
                };
                if recorded != expected {
                    return Err(DynamicValidationError::StaleRefitSchedule(i));
                }
            }
        }
        match entries.next() {
            Some((extra, _)) => Err(DynamicValidationError::StaleRefitSchedule(extra)),
            None => Ok(()),
        }
    }
}
