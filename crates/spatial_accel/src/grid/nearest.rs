//! The k nearest entries to a point: cells in rings of growing Chebyshev radius around the
//! point's cell, until the next ring lies beyond the k-th best distance: the grid's form of
//! a best-first search, each ring a shell of cells no nearer than the rings before it.
//!
//! An entry is considered once, at its cell nearest the point on every axis (its range
//! clamped to the point's cell). That cell is also its cell of least ring radius and least
//! distance, so the entry comes up no later than its nearest cell would, and the ring bound
//! stays valid for what is left.

use super::cells::{MULTI, SLOT_MASK};
use super::lattice::{CellKey, CellRange, LIMIT};
use super::slots::{Entry, IN_CELLS};
use super::uniform::UniformGrid;
use core::cmp::Ordering;
use glam::Vec3A;
use std::collections::BinaryHeap;

/// The ring walk gives way to a pass over the cell list, sorted by distance, once its
/// lookups would exceed this many per non-empty cell: a point far from a sparse world
/// would otherwise look up every empty cell between.
const LOOKUPS_PER_CELL: u64 = 2;

impl UniformGrid {
    /// [`SpatialQuery::nearest_k`](crate::SpatialQuery::nearest_k) for the grid.
    pub(super) fn nearest<F>(&self, point: Vec3A, k: usize, distance_squared: F) -> Vec<(u32, f32)>
    where
        F: FnMut(u32) -> f32,
    {
        if k == 0 || self.slots.len() == 0 {
            return Vec::new();
        }
        let mut best = Best {
            // Capped: a huge `k` overflowed `k + 1` (see `query::walks::nearest_k`).
            heap: BinaryHeap::with_capacity(k.min(crate::query::walks::NEAREST_PREALLOCATION) + 1),
            k,
            point,
            distance_squared,
        };
        let entries = &self.slots.entries;
        for &slot in &self.oversize {
            best.consider(&entries[slot as usize]);
        }
        if !point.is_finite() {
            // No cell to start from: every entry, as the flat list would.
            for e in entries.iter().filter(|e| e.place == IN_CELLS) {
                best.consider(e);
            }
            return best.into_sorted();
        }
        self.rings(&mut best);
        best.into_sorted()
    }

    /// The ring walk, then the sorted pass if the rings grow too costly.
    fn rings<F: FnMut(u32) -> f32>(&self, best: &mut Best<F>) {
        let occupied = self.cells.occupied();
        if occupied.is_empty() {
            return;
        }
        let centre = self.lattice.key_of(best.point);
        let reach = |a: usize| {
            let c = i64::from(centre.0[a]);
            (i64::from(occupied.lo[a]) - c, i64::from(occupied.hi[a]) - c)
        };
        // Rings inside `first` hold no cell; those beyond `last` neither.
        let first = (0..3)
            .map(|a| reach(a).0.max(-reach(a).1).max(0))
            .max()
            .unwrap_or(0);
        let last = (0..3)
            .map(|a| (-reach(a).0).max(reach(a).1))
            .max()
            .unwrap_or(0);
        let budget = LOOKUPS_PER_CELL * self.cells.len() as u64 + 64;
        let mut lookups = 0u64;
        for r in first..=last {
            if best.full() && self.outside_block(best.point, centre, r - 1) > best.worst() {
                return;
            }
            let ring = block(centre, r).intersection(&occupied);
            let inner = block(centre, r - 1).intersection(&occupied);
            let cost = ring.count() - inner.count();
            if lookups + cost > budget {
                self.sorted_pass(best, centre, r);
                return;
            }
            lookups += cost;
            for_each_ring_key(&ring, &inner, |key| self.consider_cell(best, centre, key));
        }
    }

    /// Every cell at ring radius `r` or more, nearest first by its box, until the rest lie
    /// beyond the k-th best.
    fn sorted_pass<F: FnMut(u32) -> f32>(&self, best: &mut Best<F>, centre: CellKey, r: i64) {
        let mut order: Vec<(f32, CellKey)> = self
            .cells
            .iter()
            .filter(|&(key, _)| chebyshev(key, centre) >= r)
            .map(|(key, _)| {
                let b = self.lattice.world_box(&CellRange::single(key));
                (b.distance_squared_to_point(best.point), key)
            })
            .collect();
        order.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        for (d2, key) in order {
            if best.full() && d2 > best.worst() {
                return;
            }
            self.consider_cell(best, centre, key);
        }
    }

    /// The entries that cell `key` owns for a search from `centre`.
    fn consider_cell<F: FnMut(u32) -> f32>(
        &self,
        best: &mut Best<F>,
        centre: CellKey,
        key: CellKey,
    ) {
        let Some(cell) = self.cells.get(key) else {
            return;
        };
        let entries = &self.slots.entries;
        for item in cell.items() {
            let e = &entries[(item & SLOT_MASK) as usize];
            if item & MULTI == 0 || e.range.clamp(centre) == key {
                best.consider(e);
            }
        }
    }

    /// A lower bound on the squared distance from `point` (in cell `centre`) to any point
    /// outside the block of cells within Chebyshev radius `r` of `centre` (0 for `r < 0`).
    fn outside_block(&self, point: Vec3A, centre: CellKey, r: i64) -> f32 {
        if r < 0 {
            return 0.0;
        }
        let size = self.lattice.size();
        let mut nearest = f32::INFINITY;
        for a in 0..3 {
            let c = i64::from(centre.0[a]);
            // The outermost cells reach to infinity: nothing lies beyond them.
            if c - r > -i64::from(LIMIT) {
                nearest = nearest.min(point[a] - (c - r) as f32 * size);
            }
            if c + r < i64::from(LIMIT) {
                nearest = nearest.min((c + r + 1) as f32 * size - point[a]);
            }
        }
        // Less the rounding of the faces and of the point's cell, as the padded cell boxes.
        let pad = (point.abs().max_element() + size) * 2e-5;
        let d = (nearest - pad).max(0.0);
        d * d
    }
}

/// The cells within Chebyshev radius `r` of `centre` (empty for `r < 0`).
fn block(centre: CellKey, r: i64) -> CellRange {
    if r < 0 {
        return CellRange::EMPTY;
    }
    let clamp = |v: i64| v.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32;
    CellRange {
        lo: centre.0.map(|c| clamp(i64::from(c) - r)),
        hi: centre.0.map(|c| clamp(i64::from(c) + r)),
    }
}

fn chebyshev(a: CellKey, b: CellKey) -> i64 {
    (0..3)
        .map(|i| (i64::from(a.0[i]) - i64::from(b.0[i])).abs())
        .max()
        .unwrap_or(0)
}

/// Calls `f` on each cell of `ring` not in `inner` (a sub-box of it): whole layers where
/// a layer misses `inner`, else the rows and the two ends of each row around it, so a ring
/// costs its own cells and not the block's.
fn for_each_ring_key(ring: &CellRange, inner: &CellRange, mut f: impl FnMut(CellKey)) {
    if ring.is_empty() {
        return;
    }
    for z in ring.lo[2]..=ring.hi[2] {
        let z_in = !inner.is_empty() && inner.lo[2] <= z && z <= inner.hi[2];
        for y in ring.lo[1]..=ring.hi[1] {
            let y_in = z_in && inner.lo[1] <= y && y <= inner.hi[1];
            if !y_in {
                for x in ring.lo[0]..=ring.hi[0] {
                    f(CellKey([x, y, z]));
                }
                continue;
            }
            for x in (ring.lo[0]..inner.lo[0]).chain(inner.hi[0] + 1..=ring.hi[0]) {
                f(CellKey([x, y, z]));
            }
        }
    }
}

/// The k best so far: a max-heap by (distance, id), so the worst is on top.
struct Best<F> {
    heap: BinaryHeap<Candidate>,
    k: usize,
    point: Vec3A,
    distance_squared: F,
}

impl<F: FnMut(u32) -> f32> Best<F> {
    #[inline]
    fn full(&self) -> bool {
        self.heap.len() == self.k
    }

    #[inline]
    fn worst(&self) -> f32 {
        self.heap.peek().map_or(f32::INFINITY, |c| c.d2)
    }

    /// Asks for the exact distance unless the entry's box is already farther than the
    /// k-th best (the box is a lower bound: the primitive lies in it).
    fn consider(&mut self, e: &Entry) {
        if self.full() && e.bounds.distance_squared_to_point(self.point) > self.worst() {
            return;
        }
        let d2 = (self.distance_squared)(e.id);
        if d2.is_nan() {
            return;
        }
        let c = Candidate { d2, id: e.id };
        if !self.full() {
            self.heap.push(c);
        } else if self.heap.peek().is_some_and(|w| c < *w) {
            self.heap.pop();
            self.heap.push(c);
        }
    }

    fn into_sorted(self) -> Vec<(u32, f32)> {
        self.heap
            .into_sorted_vec()
            .into_iter()
            .map(|c| (c.id, c.d2))
            .collect()
    }
}

/// A (distance, id) pair ordered by distance then id, for deterministic ties.
#[derive(Clone, Copy, Debug)]
struct Candidate {
    d2: f32,
    id: u32,
}

impl PartialEq for Candidate {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Candidate {}

impl PartialOrd for Candidate {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Candidate {
    fn cmp(&self, other: &Self) -> Ordering {
        self.d2.total_cmp(&other.d2).then(self.id.cmp(&other.id))
    }
}
