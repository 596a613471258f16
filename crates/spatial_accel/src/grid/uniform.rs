//! The grid itself: its parts, its constructors and what it reports about itself.

use super::cells::CellTable;
use super::config::{self, CellSize, GridConfig, Sizing};
use super::lattice::Lattice;
use super::slots::{GridHandle, Slots};
use crate::Aabb;
use crate::query::DynamicIndex;

/// A uniform grid over boxes, by handle: cubic cells in an unbounded world, each entry in
/// every cell its box overlaps.
///
/// - **Storage**: a hashed sparse grid, cell coordinates to a dense array of non-empty
///   cells (Ericson, Real-Time Collision Detection, ch. 7). Memory follows the cells in use,
///   not the world's extent; a cell is freed when its last entry leaves, and
///   [`maintain`](DynamicIndex::maintain) gives back what churn left over, so a long run
///   does not grow. [`index_stats`](DynamicIndex::index_stats) reports it.
/// - **Cell size**: given, or picked from the entries' density and median size and picked
///   again when the population drifts ([`GridConfig`],
///   [`heuristic_cell_size`](super::heuristic_cell_size)).
/// - **Oversize entries**: one spanning more than
///   [`max_cells_per_entry`](GridConfig::max_cells_per_entry) cells is kept in a flat list
///   that every query tests, so one huge box cannot fill the grid.
/// - **Rays**: a 3D DDA (Amanatides and Woo 1987) over the occupied cells, front to back,
///   stopping once the next cell starts beyond the best hit. Every direction works: negative,
///   axis-parallel, with zero or negative-zero components.
/// - **Moves**: an update whose box still covers the same cells writes only the box
///   (`Ok(false)`); otherwise it leaves the cells it no longer covers and joins the new ones.
///
/// **Duplicates.** An entry in several cells is reported once per query
/// ([`SpatialQuery`](crate::SpatialQuery)'s contract), without any state shared between
/// queries: queries take `&self` and may run on many threads at once. Each query reports an
/// entry from one cell only, its *owner*, decided from the entry's cell range and the query
/// alone: for a box, the cell at the low corner of (entry ∩ query); for a frustum and views,
/// the entry's lowest cell; for the nearest neighbours, its cell nearest the query point; for
/// a ray step, the low corner of (entry ∩ the step's cells), in the first step that reaches
/// it. Flags in each cell's item list mark an entry's lowest cell and entries of one cell, so
/// most owners are settled without reading the entry. This is mailboxing (Amanatides and Woo
/// 1987; Ericson ch. 7, on avoiding retests) with the mailbox computed instead of stored: a
/// stored mailbox needs per-query marks in the entries (a write from every query, racing
/// between threads) or a per-query set (an allocation and a probe per candidate).
///
/// The grid is not a [`BoundingTree`](crate::BoundingTree): an entry lives in several cells,
/// so it answers every query with walks of its own. Queries test each candidate's own box
/// before the callback sees it, so callers get no false candidates from the grid itself.
///
/// ```
/// use spatial_accel::grid::UniformGrid;
/// use spatial_accel::query::DynamicIndex;
/// use spatial_accel::{Aabb, Ray, SpatialQuery};
/// use core::ops::ControlFlow;
/// use glam::Vec3A;
/// use std::time::Duration;
///
/// let mut grid = UniformGrid::new();
/// let boxes: Vec<Aabb> = (0..100)
///     .map(|i| Aabb::new(Vec3A::new(i as f32, 0.0, 0.0), Vec3A::new(i as f32 + 0.5, 1.0, 1.0)))
///     .collect();
/// let handles: Vec<_> = (0..100).map(|i| grid.insert(i, boxes[i as usize]).unwrap()).collect();
/// // One long wall spanning many cells goes to the oversize list.
/// let wall = Aabb::new(Vec3A::new(-1000.0, 5.0, -1000.0), Vec3A::new(1000.0, 6.0, 1000.0));
/// grid.insert(100, wall).unwrap();
/// grid.maintain(Duration::ZERO);
/// assert_eq!(grid.oversize_count(), 1);
///
/// // A ray down the row hits the box at x = 10 first.
/// let ray = Ray::new(Vec3A::new(9.75, 0.5, 0.5), Vec3A::X);
/// let hit = grid.cast_ray(&ray, |id, r| r.intersect_aabb(&boxes[id as usize])).unwrap();
/// assert_eq!(hit.primitive, 10);
///
/// // A box query reports each entry once, whatever the cells it spans.
/// let mut found = Vec::new();
/// let query = Aabb::new(Vec3A::new(2.2, 0.0, 0.0), Vec3A::new(4.2, 9.0, 1.0));
/// grid.for_each_overlapping_aabb(&query, |id| {
///     found.push(id);
///     ControlFlow::Continue(())
/// });
/// found.sort();
/// assert_eq!(found, [2, 3, 4, 100]);
///
/// // A small move stays in its cells and only writes the box.
/// let b = boxes[7];
/// let nudged = Aabb::new(b.min + Vec3A::splat(0.01), b.max + Vec3A::splat(0.01));
/// assert_eq!(grid.update(handles[7], nudged), Ok(false));
/// grid.validate().unwrap();
/// ```
#[derive(Clone, Debug)]
pub struct UniformGrid {
    pub(super) config: GridConfig,
    pub(super) lattice: Lattice,
    pub(super) cells: CellTable,
    pub(super) slots: Slots,
    /// Slots of the entries kept out of the cells.
    pub(super) oversize: Vec<u32>,
    /// The sum of the live entries' mean sides, for noticing that entries grew or shrank.
    pub(super) side_sum: f64,
    /// What the cell size was last chosen from; `None` before the first automatic sizing.
    pub(super) sizing: Option<Sizing>,
}

impl Default for UniformGrid {
    fn default() -> Self {
        Self::with_config(GridConfig::default())
    }
}

impl UniformGrid {
    /// An empty grid with the default settings (automatic cell size).
    pub fn new() -> Self {
        Self::default()
    }

    /// An empty grid with the given settings.
    pub fn with_config(config: GridConfig) -> Self {
        let size = match config.cell_size {
            CellSize::Fixed(size) => size,
            CellSize::Auto => config.initial_cell_size,
        };
        Self {
            config,
            lattice: Lattice::new(config::sanitize(size)),
            cells: CellTable::default(),
            slots: Slots::default(),
            oversize: Vec::new(),
            side_sum: 0.0,
            sizing: None,
        }
    }

    /// A grid over `boxes`, entry `i` with id `i`, sized for them before they go in (with
    /// [`CellSize::Auto`]), so that nothing is binned twice. Invalid boxes are left out, as
    /// a tree build leaves them out.
    pub fn from_boxes(boxes: &[Aabb], config: GridConfig) -> Self {
        let mut grid = Self::with_config(config);
        let valid: Vec<Aabb> = boxes.iter().copied().filter(valid_bounds).collect();
        if config.cell_size == CellSize::Auto
            && let Some(size) = config::heuristic_cell_size(&valid)
        {
            grid.lattice = Lattice::new(size);
            grid.sizing = Some(Sizing {
                population: valid.len(),
                mean_side: valid
                    .iter()
                    .map(|b| f64::from(config::mean_side(b)))
                    .sum::<f64>()
                    / valid.len() as f64,
            });
        }
        for (i, b) in boxes.iter().enumerate() {
            let _ = grid.insert(i as u32, *b);
        }
        grid
    }

    /// The settings.
    pub fn config(&self) -> &GridConfig {
        &self.config
    }

    /// The side of the cells in use.
    pub fn cell_size(&self) -> f32 {
        self.lattice.size()
    }

    /// Number of non-empty cells.
    pub fn cell_count(&self) -> usize {
        self.cells.len()
    }

    /// Number of entries in the oversize list.
    pub fn oversize_count(&self) -> usize {
        self.oversize.len()
    }

    /// Bytes held by the grid's arrays and its cell map.
    pub fn memory_bytes(&self) -> usize {
        self.cells.memory_bytes()
            + self.slots.memory_bytes()
            + self.oversize.capacity() * size_of::<u32>()
    }

    /// Sets a fixed cell size (a non-positive or non-finite one is taken as 1) and bins
    /// every entry again: a pass over the entries.
    pub fn set_cell_size(&mut self, size: f32) {
        let size = config::sanitize(size);
        self.config.cell_size = CellSize::Fixed(size);
        self.rebin(size);
    }

    /// The live handles with their ids and boxes, in slot order.
    pub fn entries(&self) -> impl Iterator<Item = (GridHandle, u32, Aabb)> + '_ {
        self.slots
            .entries
            .iter()
            .enumerate()
            .filter(|(_, e)| e.is_live())
            .map(|(slot, e)| (self.slots.handle(slot as u32), e.id, e.bounds))
    }
}

/// The bounds an entry may have: finite and not inverted (NaN fails both).
#[inline]
pub(super) fn valid_bounds(b: &Aabb) -> bool {
    b.is_finite()
}
