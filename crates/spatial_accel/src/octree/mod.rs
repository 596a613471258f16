//! Loose octrees and quadtrees over moving boxes (Ulrich, Game Programming Gems 1).
//!
//! - [`LooseOctree`]: the main entry point; an object sits at the deepest octant whose loose
//!   cell holds it, so edits cost O(depth) and a move inside the loose cell one box write.
//! - [`Quadtree`]: the same code over x and y, for 2D worlds.
//! - [`OctreeConfig`]: looseness, depth and the world cube the root starts as.
//!
//! Both answer [`SpatialQuery`](crate::SpatialQuery) through the shared walks and
//! [`DynamicIndex`](crate::query::DynamicIndex) by [`OctreeHandle`].

mod as_index;
mod cells;
pub mod config;
mod edit;
mod handle;
mod refit;
mod tree;
mod tree_view;
mod validate;

pub use config::{OctreeConfig, OctreeConfigError};
pub use handle::{AnyLooseTree, OctreeHandle};
pub use tree::{LooseOctree, LooseTree, Quadtree};
pub use validate::OctreeValidationError;
