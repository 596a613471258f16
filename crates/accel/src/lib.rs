//! # accel
//!
//! Acceleration data structures and robust geometry, engine-independent (glam only).
//!
//! - [`geometry`]: [`Aabb`], [`Sphere`], [`Ray`], [`Frustum`], [`Triangle`] and the tests between
//!   them: a conservative slab test (no ray slips between boxes), a numerically stable
//!   ray/sphere quadratic, the watertight ray/triangle test, and three-way frustum
//!   classification.
//!
//! Every test is NaN-safe: a NaN ray is a miss, a NaN box reports itself invalid, and nothing
//! panics on non-finite input.
#![warn(missing_docs)]

pub mod geometry;

pub use geometry::*;
