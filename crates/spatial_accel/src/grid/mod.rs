//! A uniform grid over moving boxes, for worlds of objects of similar size.
//!
//! [`UniformGrid`] is a hashed sparse grid of cubic cells in an unbounded world: each entry
//! sits in every cell its box overlaps, entries spanning too many cells in a flat oversize
//! list. It answers every [`SpatialQuery`](crate::SpatialQuery) itself (rays by a 3D DDA,
//! regions by their cells), reports each entry once per query without shared state, and is
//! a [`DynamicIndex`](crate::query::DynamicIndex): a move within the same cells writes one
//! box. See [`UniformGrid`] for the design, [`GridConfig`] for the cell size.
//!
//! Against a BVH: an update touches only the cells its entry enters or leaves, and nothing
//! degrades over time; but there is no hierarchy to skip empty space, so rays in a sparse
//! world cross many cells, and a frustum or views query looks at every non-empty cell (a
//! small view of a large world costs more than in a tree). Objects of widely varied size
//! suit no one cell size.

mod cells;
mod config;
mod dda;
mod edit;
mod lattice;
mod nearest;
mod queries;
mod slots;
mod uniform;
mod validate;

pub use config::{CellSize, GridConfig, heuristic_cell_size};
pub use slots::GridHandle;
pub use uniform::UniformGrid;
pub use validate::GridValidationError;
