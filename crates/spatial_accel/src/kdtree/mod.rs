//! An SAH kd-tree over one mesh's triangles (Wald and Havran 2006, "On building fast
//! kd-trees for ray tracing, and on doing that in O(N log N)").
//!
//! [`KdTree`] splits space, not triangles: children never overlap, a ray visits the leaves it
//! crosses front to back and stops at the first that starts past its closest hit, and a
//! triangle crossing a plane is referenced on both sides, clipped to each. It answers
//! [`TriangleQuery`](crate::query::TriangleQuery) with the watertight test, so its hits equal
//! [`BruteForceMesh`](crate::query::BruteForceMesh)'s to the bit.
//!
//! - `split.rs`: the SAH cost of a plane (with the empty-space bonus and planar triangles
//!   on the cheaper side), the order planes compete in, the classification and clipping.
//! - `build_events.rs`: the O(N log N) event sweep; `build_reference.rs`: the O(N^2) and
//!   O(N log^2 N) builds, kept to show that the three give the same tree ([`KdBuild`]).
//! - `node.rs`: the eight-byte node ([`KdNode`]); `traverse.rs`: the ray walk; `query.rs`:
//!   the queries; `validate.rs`: the invariant checker.

mod build_events;
mod build_reference;
mod builder;
mod config;
mod node;
mod query;
mod split;
mod traverse;
mod tree;
mod validate;

pub use config::{KdBuild, KdTreeConfig};
pub use node::{KdNode, KdNodeKind};
pub use tree::{KdTree, KdTreeStats};
pub use validate::KdValidationError;
