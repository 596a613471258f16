//! The polygon-aligned BSP tree over one mesh's triangles: painter's orders from any eye
//! point, and exact ray and box queries.
//!
//! - [`BspTree`]: the tree, its pieces ([`BspPiece`], each with its source triangle) and
//!   stats ([`BspStats`]); [`BspTree::back_to_front`] and [`BspTree::front_to_back`] list the
//!   pieces for painting; [`TriangleQuery`](crate::query::TriangleQuery) answers rays and
//!   boxes with source indices, as brute force does.
//! - [`BspConfig`]: how planes are chosen (candidates drawn per node, priced by splits and
//!   imbalance).
//! - [`BspPlane`], [`Side`] and [`RELATIVE_TOLERANCE`]: the plane of a triangle and the one
//!   tolerance every classification uses.
//! - [`BspValidationError`]: what [`BspTree::validate`] finds broken.

mod build;
mod order;
mod plane;
mod ray;
mod split;
mod tree;
mod validate;

pub use build::BspConfig;
pub use plane::{BspPlane, RELATIVE_TOLERANCE, Side, tolerance_for_scale};
pub use tree::{BspPiece, BspStats, BspTree};
pub use validate::BspValidationError;
