//! PLOC's nearest-neighbour search for a radius above 1: every cluster's best partner among
//! the `radius` clusters on either side of it on the curve.

use super::ploc::{Cluster, Clusters, Merger, fmax, fmin};

/// Clusters handled together: their boxes are copied into arrays of one coordinate each (so
/// that the area loop vectorises) and stay in L1 across the `radius` sweeps over them.
const BLOCK: usize = 512;

/// No neighbour chosen (only a cluster whose every union area is NaN).
const NO_PICK: u32 = u32::MAX;

/// The search state, allocated once per build.
///
/// Each union area is computed once for both of its clusters (what the paper's implementation
/// does with a cache of recent areas). A cluster's choice is the smallest of its candidates
/// under one total order on pairs: area, then distance on the curve, then pairs whose left
/// member has an even slot, then the left member's slot. With a total order the globally
/// smallest pair is chosen by both its members, so every iteration merges at least once
/// whatever the ties, and the result does not depend on the order the pairs are visited in
/// (which the blocking changes).
pub(super) struct Search {
    pub(super) best: Vec<f32>,
    /// The chosen pair's rank among equal areas: `4 * distance + 2 * (left slot odd) +
    /// (neighbour on the right)`; [`NO_PICK`] before any.
    pub(super) pick: Vec<u32>,
    areas: Vec<f32>,
    /// The block's boxes, one coordinate an array: `lo` x, y, z then `hi` x, y, z.
    coords: [Vec<f32>; 6],
}

impl Search {
    /// A search for up to `n` clusters (0 for none: radius 1 never searches).
    pub fn new(n: usize) -> Self {
        let (block, span) = match n {
            0 => (0, 0),
            _ => (BLOCK, BLOCK + super::MAX_SEARCH_RADIUS as usize),
        };
        Self {
            best: vec![0.0; n],
            pick: vec![NO_PICK; n],
            areas: vec![0.0; block],
            coords: std::array::from_fn(|_| vec![0.0; span]),
        }
    }

    /// The neighbour cluster `i` chose.
    #[inline(always)]
    fn neighbour(&self, i: usize) -> Option<usize> {
        let p = self.pick[i];
        let d = (p >> 2) as usize;
        match (p == NO_PICK, p & 1 == 1) {
            (true, _) => None,
            (false, true) => Some(i + d),
            (false, false) => Some(i - d),
        }
    }

    /// Finds every cluster's best neighbour within `radius`.
    pub fn find(&mut self, cl: &[Cluster], radius: usize) {
        let count = cl.len();
        self.best[..count].fill(f32::INFINITY);
        self.pick[..count].fill(NO_PICK);
        let radius = radius.min(count - 1);
        for start in (0..count).step_by(BLOCK) {
            let end = (start + BLOCK).min(count);
            let span = &cl[start..(end + radius).min(count)];
            for (k, c) in span.iter().enumerate() {
                for axis in 0..3 {
                    self.coords[axis][k] = c.lo[axis];
                    self.coords[3 + axis][k] = c.hi[axis];
                }
            }
            for d in 1..=radius {
                // Pairs (a, a + d) with `a` in this block.
                let stop = end.min(count - d);
                if stop <= start {
                    break;
                }
                let len = stop - start;
                self.block_areas(len, d);
                let rank = 4 * d as u32 + 2 * (start as u32 & 1);
                let areas = &self.areas[..len];
                // The left member looks right (rank + 1), the right member looks left.
                offer(
                    areas,
                    &mut self.best[start..stop],
                    &mut self.pick[start..stop],
                    rank + 1,
                );
                offer(
                    areas,
                    &mut self.best[start + d..stop + d],
                    &mut self.pick[start + d..stop + d],
                    rank,
                );
            }
        }
    }

    /// `areas[k]`: the union area of block clusters `k` and `k + d`, for `k < len`.
    #[inline(always)]
    fn block_areas(&mut self, len: usize, d: usize) {
        let [lx, ly, lz, hx, hy, hz] = &self.coords;
        fn window(v: &[f32], from: usize, len: usize) -> &[f32] {
            &v[from..from + len]
        }
        let a = |v| window(v, 0, len);
        let b = |v| window(v, d, len);
        let (alx, aly, alz, ahx, ahy, ahz) = (a(lx), a(ly), a(lz), a(hx), a(hy), a(hz));
        let (blx, bly, blz, bhx, bhy, bhz) = (b(lx), b(ly), b(lz), b(hx), b(hy), b(hz));
        let areas = &mut self.areas[..len];
        for k in 0..len {
            let dx = fmax(ahx[k], bhx[k]) - fmin(alx[k], blx[k]);
            let dy = fmax(ahy[k], bhy[k]) - fmin(aly[k], bly[k]);
            let dz = fmax(ahz[k], bhz[k]) - fmin(alz[k], blz[k]);
            areas[k] = dx * dy + dy * dz + dz * dx;
        }
    }

    /// Merges the mutual pairs, each into its left member's place, and compacts the rest;
    /// returns the number of clusters left.
    pub fn merge_mutual(&self, cur: &mut Clusters, merger: &mut Merger<'_>) -> usize {
        let mut to = 0;
        for i in 0..cur.cl.len() {
            match self.neighbour(i) {
                Some(j) if self.neighbour(j) == Some(i) => {
                    if j > i {
                        cur.merge(i, j, to, merger);
                        to += 1;
                    }
                }
                _ => {
                    cur.keep(i, to);
                    to += 1;
                }
            }
        }
        to
    }
}

/// Offers pair `k` to cluster `k` of `best`/`pick`. `rank` is for an even left slot at
/// `k = 0`; the parity bit flips with `k`.
#[inline(always)]
fn offer(areas: &[f32], best: &mut [f32], pick: &mut [u32], rank: u32) {
    let len = areas.len();
    let (best, pick) = (&mut best[..len], &mut pick[..len]);
    for k in 0..len {
        let r = rank ^ ((k as u32 & 1) << 1);
        let a = areas[k];
        let better = a < best[k] || (a == best[k] && r < pick[k]);
        best[k] = if better { a } else { best[k] };
        pick[k] = if better { r } else { pick[k] };
    }
}

#[cfg(test)]
mod tests {
    use super::super::ploc::tests::{clusters_of, coarse_boxes};
    use super::*;

    /// The blocked search picks what a plain scan of every candidate under the total order
    /// picks.
    #[test]
    fn search_matches_a_plain_scan() {
        for (n, radius) in [
            (2, 3),
            (7, 6),
            (1_500, 2),
            (1_500, 9),
            (2_000, 14),
            (600, 40),
        ] {
            let cl = clusters_of(&coarse_boxes(n, 11)).cl;
            let mut search = Search::new(n);
            search.find(&cl, radius);
            for i in 0..n {
                let mut want = (f32::INFINITY, NO_PICK);
                for j in i.saturating_sub(radius)..(i + radius + 1).min(n) {
                    if j == i {
                        continue;
                    }
                    let (lo, d) = (i.min(j), i.abs_diff(j));
                    let rank = 4 * d as u32 + 2 * (lo as u32 & 1) + u32::from(j > i);
                    let a = cl[i].union_area(&cl[j]);
                    if a < want.0 || (a == want.0 && rank < want.1) {
                        want = (a, rank);
                    }
                }
                assert_eq!(
                    (search.best[i], search.pick[i]),
                    want,
                    "n {n} r {radius} i {i}"
                );
            }
        }
    }
}
