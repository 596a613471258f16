//! The grid's settings, and the density heuristic that picks its cell size.

use super::lattice::{CellHashBuilder, CellKey, Lattice};
use crate::Aabb;
use std::collections::HashMap;

/// How a [`UniformGrid`](super::UniformGrid) chooses its cell size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CellSize {
    /// Chosen from the entries by [`heuristic_cell_size`], and chosen again at
    /// [`maintain`](crate::query::DynamicIndex::maintain) when the population or the typical
    /// entry size has drifted by a factor of two since (see [`GridConfig`]). Until the first
    /// sizing, the cells are twice the mean side of the first entry inserted into the empty
    /// grid, or [`GridConfig::initial_cell_size`] when that entry is a point.
    Auto,
    /// A fixed side, in world units: positive and finite (anything else is taken as 1).
    Fixed(f32),
}

/// Tuning of a [`UniformGrid`](super::UniformGrid).
///
/// **When the cell size changes.** With [`CellSize::Auto`], `maintain` re-sizes the grid when
/// the number of entries has halved or doubled (and changed by at least
/// [`resize_min_change`](Self::resize_min_change)) since the last sizing, or when the mean
/// entry size has. A re-size bins every entry again, so it is a pass over the entries; the
/// factor of two makes that cost O(1) per edit over time, as a `Vec`'s doubling is. A world
/// that must never see that pass (a frame-time budget with no slack) gives a
/// [`CellSize::Fixed`] size instead.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridConfig {
    /// How the cell size is chosen.
    pub cell_size: CellSize,
    /// The side of the cells before the first automatic sizing, when the first entry gives
    /// no size to start from (see [`CellSize::Auto`]).
    pub initial_cell_size: f32,
    /// An entry overlapping more cells than this goes to the oversize list instead of the
    /// cells (Ericson, Real-Time Collision Detection, ch. 7, on cell size: one huge object
    /// would otherwise be copied into a whole region of cells, and every move would rewrite
    /// them all). Oversize entries are tested by every query, as a flat list; keep them few.
    pub max_cells_per_entry: u32,
    /// The least change in the number of entries that triggers a re-size, so that a grid
    /// of a handful of entries is not re-sized at every other insert.
    pub resize_min_change: usize,
}

impl Default for GridConfig {
    fn default() -> Self {
        Self {
            cell_size: CellSize::Auto,
            initial_cell_size: 1.0,
            max_cells_per_entry: 64,
            resize_min_change: 64,
        }
    }
}

impl GridConfig {
    /// The default settings with a fixed cell size.
    pub fn fixed(cell_size: f32) -> Self {
        Self {
            cell_size: CellSize::Fixed(cell_size),
            ..Self::default()
        }
    }
}

/// A usable cell side: positive and finite, else 1.
pub(super) fn sanitize(size: f32) -> f32 {
    if size.is_finite() && size > 0.0 {
        size
    } else {
        1.0
    }
}

/// Entries per cell the density term aims at, as an entry sees it: itself and one other,
/// on average over the entries. One to a few entries per cell is the classic target for
/// uniform grids (Cleary and Wyvill 1988; Ericson ch. 7): fewer wastes cells and ray steps,
/// more makes every cell visit test several candidates.
const ENTRIES_PER_CELL: f32 = 2.0;
/// The cell side stays at least this multiple of the median entry size: smaller cells copy
/// each entry into many cells.
const MIN_SIZE_FACTOR: f32 = 1.0;
/// The cell side stays above this fraction of the largest coordinate: below it, a ray's
/// rounding spans several cells and the lattice stops meaning anything.
const MIN_SIZE_OF_COORDINATES: f32 = 1e-5;
/// Centres binned per refinement step: enough for a stable mean, few enough that a
/// re-size of a large world costs a pass over its entries and not several.
const SAMPLE: usize = 4096;

/// The mean side of a box, the size an entry is measured by.
#[inline]
pub(super) fn mean_side(b: &Aabb) -> f32 {
    let e = b.extent();
    (e.x + e.y + e.z) / 3.0
}

/// The cell side for these boxes, or `None` when there are none.
///
/// First a guess from the average density: the side `c` at which a cell would hold
/// `ENTRIES_PER_CELL` entries if they were spread evenly over the box of their centres,
/// that box's thin axes counted as at least `c` thick (so a flat world gets square cells
/// for its plane): the fixed point of `c = cbrt(V(c) * k / n)`, by iteration from the whole
/// world's side. An average misleads where entries crowd (clusters in a sparse world), so
/// the guess is then refined on the entries themselves: a sample of centres is binned, the
/// number of entries in an entry's cell is averaged over the entries (crowded cells count
/// once per entry in them), and the side scaled by the cube root of target over measured,
/// until they agree. The side stays at least the median entry size; the median, so that a
/// few huge boxes (which go to the oversize list anyway) do not decide it for the rest.
pub fn heuristic_cell_size(boxes: &[Aabb]) -> Option<f32> {
    if boxes.is_empty() {
        return None;
    }
    let mut sides: Vec<f32> = boxes.iter().map(mean_side).collect();
    let mid = sides.len() / 2;
    let median = *sides.select_nth_unstable_by(mid, f32::total_cmp).1;
    let centres = boxes
        .iter()
        .fold(Aabb::EMPTY, |acc, b| acc.grow(b.center()));
    let extent = centres.extent();
    let n = boxes.len() as f32;
    let floor = median * MIN_SIZE_FACTOR;
    let mut c = extent.max_element();
    if n > ENTRIES_PER_CELL {
        for _ in 0..32 {
            let volume = extent.max(glam::Vec3A::splat(c));
            let next = (volume.x * volume.y * volume.z * ENTRIES_PER_CELL / n).cbrt();
            if next < c {
                c = next;
            } else {
                break;
            }
        }
        c = c.max(floor);
        if c > 0.0 {
            c = refine(boxes, c, floor);
        }
    }
    c = c.max(floor);
    if c.is_nan() || c <= 0.0 {
        // Every entry is the same point: nothing to measure, any size holds them in one cell.
        c = 1.0;
    }
    let coordinates = centres.min.abs().max(centres.max.abs()).max_element();
    c = c.max(coordinates * MIN_SIZE_OF_COORDINATES);
    Some(sanitize(c))
}

/// Scales the side `c` until the mean number of entries in an entry's cell, measured on a
/// sample of centres, is near the target; never below `floor`.
fn refine(boxes: &[Aabb], mut c: f32, floor: f32) -> f32 {
    let stride = boxes.len().div_ceil(SAMPLE);
    let sample: Vec<glam::Vec3A> = boxes.iter().step_by(stride).map(Aabb::center).collect();
    // A sample of a fraction `f` of the entries sees `f` of each cell's other entries:
    // scale the others back up.
    let fraction = sample.len() as f32 / boxes.len() as f32;
    let shared = |counts: &mut dyn Iterator<Item = u32>| {
        let squares: f32 = counts.map(|k| (k * k) as f32).sum();
        1.0 + (squares / sample.len() as f32 - 1.0) / fraction
    };
    let measure = |c: f32| {
        let lattice = Lattice::new(c);
        let mut counts: HashMap<CellKey, u32, CellHashBuilder> = HashMap::default();
        for &p in &sample {
            *counts.entry(lattice.key_of(p)).or_default() += 1;
        }
        shared(&mut counts.into_values())
    };
    // Entries with one centre share a cell at any size: no cell gets below their count.
    let mut same: HashMap<[u32; 3], u32> = HashMap::new();
    for p in &sample {
        *same.entry(p.to_array().map(f32::to_bits)).or_default() += 1;
    }
    let target = ENTRIES_PER_CELL.max(shared(&mut same.into_values()));
    for _ in 0..16 {
        let seen = measure(c);
        if (seen / target - 1.0).abs() < 0.1 {
            break;
        }
        let next = (c * (target / seen).cbrt().clamp(0.25, 4.0)).max(floor);
        if next == c {
            break;
        }
        c = next;
    }
    c
}

/// The population and entry size at the last sizing, to notice drift.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Sizing {
    pub population: usize,
    pub mean_side: f64,
}

impl Sizing {
    /// True when `now` differs enough from this sizing for a re-size (see [`GridConfig`]).
    pub fn drifted(&self, now: Sizing, min_change: usize) -> bool {
        let (a, b) = (self.population, now.population);
        let population = a.abs_diff(b) >= min_change.max(1) && (b > 2 * a || 2 * b < a);
        let size = now.population > 0
            && (now.mean_side > 2.0 * self.mean_side || 2.0 * now.mean_side < self.mean_side);
        population || size
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3A;

    fn cube(c: Vec3A, side: f32) -> Aabb {
        Aabb::from_center_half_extents(c, Vec3A::splat(side * 0.5))
    }

    #[test]
    fn dense_worlds_get_cells_near_the_entry_size_and_sparse_ones_larger() {
        let mut next = crate::test_floats(3);
        let mut world = |n: usize, half: f32| -> Vec<Aabb> {
            (0..n)
                .map(|_| cube(Vec3A::new(next(), next(), next()) * 2.0 * half - half, 1.0))
                .collect()
        };
        let dense = heuristic_cell_size(&world(10_000, 10.0)).unwrap();
        assert!((1.0..=1.5).contains(&dense), "{dense}");
        // One entry per 8,000,000 cubic units: cells of about 200 (two per cell as an entry
        // sees it, itself included, is one other on average).
        let sparse = heuristic_cell_size(&world(1_000, 1000.0)).unwrap();
        assert!((150.0..=260.0).contains(&sparse), "{sparse}");
    }

    #[test]
    fn crowds_in_a_sparse_world_get_cells_for_the_crowds() {
        let mut next = crate::test_floats(5);
        let mut boxes = Vec::new();
        for _ in 0..8 {
            let centre = Vec3A::new(next(), next(), next()) * 2000.0 - 1000.0;
            for _ in 0..500 {
                let p = centre + Vec3A::new(next(), next(), next()) * 10.0 - 5.0;
                boxes.push(cube(p, 0.1));
            }
        }
        // 500 in 1000 cubic units: one other entry within a cell of about 1.3.
        let c = heuristic_cell_size(&boxes).unwrap();
        assert!((0.8..=2.5).contains(&c), "{c}");
    }

    #[test]
    fn a_flat_world_gets_cells_for_its_plane() {
        let mut next = crate::test_floats(4);
        let points: Vec<Aabb> = (0..5000)
            .map(|_| Aabb::from_point(Vec3A::new(next() * 100.0, next() * 100.0, 0.0)))
            .collect();
        let c = heuristic_cell_size(&points).unwrap();
        // One point per square cell on average, of a 100 x 100 plane holding 5000: side 1.4.
        assert!((c - 2f32.sqrt()).abs() < 0.25, "{c}");
    }

    #[test]
    fn degenerate_inputs_still_give_a_usable_size() {
        assert_eq!(heuristic_cell_size(&[]), None);
        let same = vec![Aabb::from_point(Vec3A::splat(3.0)); 100];
        assert_eq!(heuristic_cell_size(&same), Some(1.0));
        let one = [cube(Vec3A::ZERO, 2.0)];
        let c = heuristic_cell_size(&one).unwrap();
        assert!((2.0..=8.0).contains(&c), "{c}");
        let far = [
            Aabb::from_point(Vec3A::splat(1e9)),
            Aabb::from_point(Vec3A::splat(-1e9)),
        ];
        assert!(heuristic_cell_size(&far).unwrap() >= 1e4);
    }

    #[test]
    fn drift_needs_a_factor_of_two_and_a_minimum_change() {
        let at = Sizing {
            population: 1000,
            mean_side: 1.0,
        };
        let now = |population, mean_side| Sizing {
            population,
            mean_side,
        };
        assert!(!at.drifted(now(1900, 1.0), 64));
        assert!(at.drifted(now(2001, 1.0), 64));
        assert!(at.drifted(now(499, 1.0), 64));
        assert!(at.drifted(now(1000, 2.5), 64));
        assert!(!at.drifted(now(1000, 0.6), 64));
        let small = now(10, 1.0);
        assert!(!small.drifted(now(30, 1.0), 64));
    }
}
