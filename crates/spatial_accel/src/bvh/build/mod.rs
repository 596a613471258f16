//! The builders of the static BVH, one file per strategy, all writing the same node array.
//!
//! - `top_down`: the top-down driver (recursion, leaves, stopping rules) and the dispatch to
//!   every strategy; `parallel`: the same driver on rayon's pool (cargo feature `rayon`).
//! - The top-down splits: `object` (midpoint, median), `binned` (binned SAH) with its AVX2
//!   passes in `binned_avx2`, `sweep` (full-sweep SAH), and for small nodes `exhaustive`
//!   (every partition) and `sorted` (every plane, AVX2); `partition` moves the primitives
//!   around the plane found.
//! - `lbvh`: the linear BVH, a radix tree over `morton`'s sorted codes.
//! - `ploc`, `ploc_search`, `ploc_tree` and `reinsert`: the bottom-up PLOC builder, its
//!   neighbour search, its layout into the node array, and the reinsertion that refines it.

mod binned;
#[cfg(target_arch = "x86_64")]
mod binned_avx2;
mod exhaustive;
mod lbvh;
pub(crate) mod morton;
mod object;
#[cfg(feature = "rayon")]
mod parallel;
mod partition;
mod ploc;
mod ploc_search;
mod ploc_tree;
mod reinsert;
#[cfg(target_arch = "x86_64")]
mod sorted;
mod sweep;
mod top_down;

pub use binned::MAX_BINS;
#[cfg(feature = "rayon")]
pub(super) use parallel::build_nodes_parallel;
pub use ploc::MAX_SEARCH_RADIUS;
pub(super) use top_down::build_nodes;
