//! Rays through the grid: a 3D DDA over the occupied cells (Amanatides and Woo, "A Fast Voxel
//! Traversal Algorithm for Ray Tracing", 1987), made conservative for the crate's widened
//! slab test.
//!
//! The DDA only chooses where the walk's steps end: at each cell boundary the ray crosses,
//! found from the next boundary's distance on each axis (A&W's `tMax`). What a step visits is
//! computed afresh from the ray's positions at the step's two ends, widened by a tolerance
//! and mapped through the same monotone `floor(x / size)` the entries were filed with. So a
//! rounding in the DDA can make a step longer or shorter, never skip a cell; and a box that
//! the widened slab test says the ray touches (it may miss by a few ulps) lies within the
//! tolerance of the path, so in a visited cell. A ray through a cell corner visits the cells
//! around the corner; one along a cell face, the cells on both sides.
//!
//! Each step's cells form a box of cells whose ends only move forward along the ray on
//! every axis. Hence an entry reached at some step was reached at every step in between,
//! and "first reached at this step" is "overlaps this step's cells but not the last step's",
//! which needs no memory: the walk's mailbox is computed, not stored (see `UniformGrid`).

use super::cells::{MULTI, SLOT_MASK};
use super::lattice::{CellKey, CellRange};
use super::uniform::UniformGrid;
use crate::Ray;
use crate::query::RayWalk;
use core::ops::ControlFlow;
use glam::Vec3A;

/// The walk's tolerance, relative to the coordinates' magnitude: ten times the error of the
/// widened slab test (`SLAB_WIDENING`, about 3.6e-7) plus the rounding of a ray position
/// and of its cell coordinate (a few ulps each).
const TOLERANCE: f32 = 4e-6;

/// The walk gives way to a pass over the cell list when it would take more than this many
/// steps per non-empty cell. A step costs about one map lookup, a few times a ray/box test;
/// and the walk may stop early at a hit, which the pass cannot.
const STEPS_PER_CELL: u64 = 4;

impl RayWalk for UniformGrid {
    /// The oversize entries the ray reaches, nearest first, then the cells front to back;
    /// each entry whose box the ray touches within its current range, once.
    fn walk_ray<V>(&self, ray: &mut Ray, mut visit: V)
    where
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        // Not only degenerate rays: a NaN direction would step the DDA by NaN (see
        // `Ray::is_traceable`).
        if !ray.is_traceable() || self.walk_oversize(ray, &mut visit).is_break() {
            return;
        }
        if self.cells.len() == 0 {
            return;
        }
        let size = self.lattice.size();
        let occupied = self.cells.occupied();
        let world = self.lattice.world_box(&occupied);
        // The error of a position on the ray grows with the coordinates it passes through
        // and with the distance travelled, bounded by both ends' magnitudes.
        let reach =
            ray.origin.abs().max_element() + world.min.abs().max(world.max.abs()).max_element();
        let delta = TOLERANCE * (reach + size);
        let world = world.expanded(Vec3A::splat(delta));
        // Clip to the occupied cells first: a ray from far away starts at their edge.
        let (t_start, t_end) = ray.slab_interval(world.min, world.max);
        if t_start > t_end {
            return;
        }
        let walk = Walk {
            grid: self,
            occupied,
            delta,
            t_start,
            t_end,
        };
        let steps = walk.estimate(ray);
        // When the tolerance is a large part of a cell, each step would visit many cells;
        // when the path is long for the cells there are, most steps would find nothing.
        if delta * 4.0 >= size || steps > STEPS_PER_CELL * self.cells.len() as u64 + 16 {
            walk.gather(ray, &mut visit);
        } else {
            walk.dda(ray, steps, &mut visit);
        }
    }
}

impl UniformGrid {
    /// Visits the oversize entries the ray touches, nearest first.
    fn walk_oversize<V>(&self, ray: &mut Ray, visit: &mut V) -> ControlFlow<()>
    where
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        if self.oversize.is_empty() {
            return ControlFlow::Continue(());
        }
        let entries = &self.slots.entries;
        let mut hits: Vec<(f32, u32)> = self
            .oversize
            .iter()
            .filter_map(|&s| {
                ray.intersect_aabb(&entries[s as usize].bounds)
                    .map(|t| (t, s))
            })
            .collect();
        hits.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        for (t, slot) in hits {
            if t > ray.t_max {
                break;
            }
            visit(entries[slot as usize].id, ray)?;
        }
        ControlFlow::Continue(())
    }
}

/// One ray's walk over the cells, clipped to the occupied range.
struct Walk<'a> {
    grid: &'a UniformGrid,
    occupied: CellRange,
    /// How far from the computed path a touched box may lie, in world units.
    delta: f32,
    t_start: f32,
    t_end: f32,
}

impl Walk<'_> {
    /// The cells within `delta` of the path between two of its points, clipped to the
    /// occupied range.
    #[inline]
    fn cells_between(&self, a: Vec3A, b: Vec3A) -> CellRange {
        let lattice = &self.grid.lattice;
        let d = Vec3A::splat(self.delta);
        CellRange {
            lo: lattice.key_of(a.min(b) - d).0,
            hi: lattice.key_of(a.max(b) + d).0,
        }
        .intersection(&self.occupied)
    }

    /// About how many cell boundaries the clipped path crosses: the DDA's step count.
    fn estimate(&self, ray: &Ray) -> u64 {
        let lattice = &self.grid.lattice;
        let a = lattice.key_of(ray.at(self.t_start)).0;
        let b = lattice.key_of(ray.at(self.t_end.min(ray.t_max))).0;
        (0..3)
            .map(|i| (i64::from(a[i]) - i64::from(b[i])).unsigned_abs())
            .sum::<u64>()
            + 1
    }

    /// Amanatides and Woo's traversal: from the cell of the entry point, step across the
    /// nearest boundary each time. Stops once a step would start beyond `ray.t_max`, which
    /// the visitor shrinks as it finds hits: nothing behind the best hit is visited.
    fn dda<V>(&self, ray: &mut Ray, max_steps: u64, visit: &mut V)
    where
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        let size = self.grid.lattice.size();
        let (o, d, inv) = (ray.origin, ray.direction, ray.inv_direction);
        let start = self
            .occupied
            .clamp(self.grid.lattice.key_of(ray.at(self.t_start)));
        let mut cell = start.0;
        let step: [i32; 3] = [0, 1, 2].map(|a| (d[a] > 0.0) as i32 - (d[a] < 0.0) as i32);
        // The distance to the boundary a step along axis `a` crosses next (A&W's tMax).
        // Recomputed from the cell index rather than accumulated, so it does not drift.
        let boundary = |a: usize, c: i32| -> f32 {
            if step[a] == 0 {
                return f32::INFINITY;
            }
            let plane = (c.saturating_add((step[a] > 0) as i32)) as f32 * size;
            (plane - o[a]) * inv[a]
        };
        let mut t_next = [0, 1, 2].map(|a| boundary(a, cell[a]));
        let mut t0 = self.t_start;
        let mut p0 = ray.at(t0);
        let mut previous = CellRange::EMPTY;
        // Rounding near huge coordinates can stall the boundaries; the cap and the last
        // step below still cover the whole path.
        for _ in 0..max_steps + 8 {
            if t0 > ray.t_max {
                return;
            }
            let t_end = self.t_end.min(ray.t_max);
            let axis = (0..3).fold(0, |m, a| if t_next[a] < t_next[m] { a } else { m });
            let t1 = t_next[axis].min(t_end).max(t0);
            let p1 = o + d * t1;
            let cells = self.cells_between(p0, p1);
            if self.visit_step(&cells, &previous, ray, visit).is_break() || t1 >= t_end {
                return;
            }
            previous = cells;
            (t0, p0) = (t1, p1);
            cell[axis] = cell[axis].saturating_add(step[axis]);
            t_next[axis] = boundary(axis, cell[axis]);
        }
        let t_end = self.t_end.min(ray.t_max);
        if t0 <= t_end {
            let cells = self.cells_between(p0, ray.at(t_end));
            let _ = self.visit_step(&cells, &previous, ray, visit);
        }
    }

    /// Visits the entries of the cells in `cells` but not in `previous` that this step
    /// reaches first: an entry of one cell always; one of several cells when it does not
    /// overlap `previous` (else an earlier step reported it) and this is the low corner of
    /// its cells within the step (else another cell of this step reports it).
    fn visit_step<V>(
        &self,
        cells: &CellRange,
        previous: &CellRange,
        ray: &mut Ray,
        visit: &mut V,
    ) -> ControlFlow<()>
    where
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        if cells.is_empty() {
            return ControlFlow::Continue(());
        }
        let entries = &self.grid.slots.entries;
        for key in cells.keys() {
            if previous.contains(key) {
                continue;
            }
            let Some(cell) = self.grid.cells.get(key) else {
                continue;
            };
            for item in cell.items() {
                let e = &entries[(item & SLOT_MASK) as usize];
                if item & MULTI != 0
                    && (e.range.intersects(previous)
                        || CellKey(e.range.intersection(cells).lo) != key)
                {
                    continue;
                }
                if ray.hits_aabb(&e.bounds) {
                    visit(e.id, ray)?;
                }
            }
        }
        ControlFlow::Continue(())
    }

    /// The walk for paths much longer than the grid is full: every non-empty cell the
    /// (widened) ray touches, their entries gathered once each and visited nearest first by
    /// their own boxes' entry distance.
    fn gather<V>(&self, ray: &mut Ray, visit: &mut V)
    where
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        let grid = self.grid;
        let pad = Vec3A::splat(self.delta);
        let mut slots: Vec<u32> = Vec::new();
        for (key, cell) in grid.cells.iter() {
            let b = grid
                .lattice
                .world_box(&CellRange::single(key))
                .expanded(pad);
            if ray.hits_aabb(&b) {
                slots.extend(cell.items().map(|i| i & SLOT_MASK));
            }
        }
        slots.sort_unstable();
        slots.dedup();
        let entries = &grid.slots.entries;
        let mut hits: Vec<(f32, u32)> = slots
            .into_iter()
            .filter_map(|s| {
                ray.intersect_aabb(&entries[s as usize].bounds)
                    .map(|t| (t, s))
            })
            .collect();
        hits.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        for (t, slot) in hits {
            if t > ray.t_max || visit(entries[slot as usize].id, ray).is_break() {
                return;
            }
        }
    }
}
