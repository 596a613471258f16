//! What the examples share: `mod support;` in an example brings it in.

pub mod screenshot;
