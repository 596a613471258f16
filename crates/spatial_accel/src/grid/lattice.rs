//! The lattice: how world coordinates map to integer cell coordinates, ranges of cells, and
//! the conservative world boxes of cells.
//!
//! Every structure and query of the grid goes through [`Lattice::coord`], one monotone
//! function (`floor(x / size)`, clamped), so an entry and a query that share a point always
//! share a cell: overlap tests on cell ranges are exact in integers, whatever the rounding.
//! Only the way back, from a cell to a world box, is rounded; those boxes are padded.

use crate::Aabb;
use core::hash::{BuildHasherDefault, Hash, Hasher};
use glam::Vec3A;

/// The largest cell coordinate magnitude. Coordinates are clamped to `[-LIMIT, LIMIT]`, so
/// the two outermost cells of each axis reach to infinity, and `LIMIT + 1` never overflows.
pub(super) const LIMIT: i32 = 1 << 30;

/// Relative padding of a cell's world box: a few hundred ulps, far more than the rounding of
/// `x / size` and of `i * size` (two ulps each), so a point always lies in the padded box of
/// the cell it maps to.
const PAD: f32 = 1e-5;

/// The integer coordinates of one cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct CellKey(pub [i32; 3]);

impl Hash for CellKey {
    /// One word per key: the three coordinates multiplied by distinct odd constants (a
    /// Weyl-style mix), finished by [`CellHasher`]. Neighbouring cells differ in every bit
    /// that the table uses, so a slab of cells does not collide into one group.
    #[inline]
    fn hash<H: Hasher>(&self, state: &mut H) {
        let [x, y, z] = self.0.map(|c| u64::from(c as u32));
        state.write_u64(
            x.wrapping_mul(0x9E37_79B9_7F4A_7C15)
                ^ y.wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
                ^ z.wrapping_mul(0x1656_67B1_9E37_79F9),
        );
    }
}

/// The hasher of the cell table: the finaliser of MurmurHash3 over the one word a
/// [`CellKey`] writes. The standard SipHash would cost more than the probe it feeds; cell
/// keys come from the caller's geometry, not from an adversary.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct CellHasher(u64);

impl Hasher for CellHasher {
    #[inline]
    fn finish(&self) -> u64 {
        let mut h = self.0;
        h ^= h >> 33;
        h = h.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
        h ^= h >> 33;
        h = h.wrapping_mul(0xC4CE_B9FE_1A85_EC53);
        h ^ (h >> 33)
    }

    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        // Not reached by `CellKey`, which writes one u64; kept correct for any other use.
        for &b in bytes {
            self.0 = (self.0.rotate_left(8) ^ u64::from(b)).wrapping_mul(0x100_0000_01B3);
        }
    }

    #[inline]
    fn write_u64(&mut self, v: u64) {
        self.0 ^= v;
    }
}

/// The `BuildHasher` of the cell table.
pub(super) type CellHashBuilder = BuildHasherDefault<CellHasher>;

/// A box of cells, `lo..=hi` on each axis; empty when `lo > hi` on some axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct CellRange {
    pub lo: [i32; 3],
    pub hi: [i32; 3],
}

impl Default for CellRange {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl CellRange {
    /// The range that contains nothing and is the identity of [`CellRange::union`].
    pub const EMPTY: Self = Self {
        lo: [i32::MAX; 3],
        hi: [i32::MIN; 3],
    };

    /// The range of one cell.
    #[inline]
    pub fn single(key: CellKey) -> Self {
        Self {
            lo: key.0,
            hi: key.0,
        }
    }

    #[inline]
    pub fn is_empty(&self) -> bool {
        (0..3).any(|a| self.lo[a] > self.hi[a])
    }

    /// Number of cells (0 when empty). A u64: a range over the whole lattice has 2^93.
    #[inline]
    pub fn count(&self) -> u64 {
        if self.is_empty() {
            return 0;
        }
        (0..3)
            .map(|a| (i64::from(self.hi[a]) - i64::from(self.lo[a]) + 1) as u64)
            .fold(1u64, u64::saturating_mul)
    }

    #[inline]
    pub fn contains(&self, key: CellKey) -> bool {
        (0..3).all(|a| self.lo[a] <= key.0[a] && key.0[a] <= self.hi[a])
    }

    #[inline]
    pub fn intersects(&self, other: &Self) -> bool {
        (0..3).all(|a| self.lo[a] <= other.hi[a] && other.lo[a] <= self.hi[a])
    }

    #[inline]
    pub fn intersection(&self, other: &Self) -> Self {
        Self {
            lo: [0, 1, 2].map(|a| self.lo[a].max(other.lo[a])),
            hi: [0, 1, 2].map(|a| self.hi[a].min(other.hi[a])),
        }
    }

    #[inline]
    pub fn union(&self, other: &Self) -> Self {
        Self {
            lo: [0, 1, 2].map(|a| self.lo[a].min(other.lo[a])),
            hi: [0, 1, 2].map(|a| self.hi[a].max(other.hi[a])),
        }
    }

    /// True when `inner` lies within this range.
    #[inline]
    pub fn contains_range(&self, inner: &Self) -> bool {
        (0..3).all(|a| self.lo[a] <= inner.lo[a] && inner.hi[a] <= self.hi[a])
    }

    /// The cell of the range nearest to `key` on every axis.
    #[inline]
    pub fn clamp(&self, key: CellKey) -> CellKey {
        CellKey([0, 1, 2].map(|a| key.0[a].clamp(self.lo[a], self.hi[a])))
    }

    /// The cells of the range, x fastest.
    pub fn keys(self) -> impl Iterator<Item = CellKey> {
        let [x0, y0, z0] = self.lo;
        let [x1, y1, z1] = self.hi;
        (z0..=z1).flat_map(move |z| {
            (y0..=y1).flat_map(move |y| (x0..=x1).map(move |x| CellKey([x, y, z])))
        })
    }
}

/// The cell size and its reciprocal: the map from world coordinates to cells.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Lattice {
    size: f32,
    inv: f32,
}

impl Lattice {
    /// A lattice of cubic cells of side `size` (positive and finite; checked by the caller).
    pub fn new(size: f32) -> Self {
        Self {
            size,
            inv: size.recip(),
        }
    }

    #[inline]
    pub fn size(&self) -> f32 {
        self.size
    }

    /// The cell coordinate of `x`: `floor(x / size)`, clamped to `[-LIMIT, LIMIT]`.
    /// Monotone in `x`, which every overlap and dedupe argument of the grid rests on.
    #[inline]
    pub fn coord(&self, x: f32) -> i32 {
        // Clamped first, so the truncation below is exact and in range (NaN, which callers
        // never pass, goes to 0). The floor is taken by hand: `f32::floor` is a call into libm
        // on baseline x86-64 (no SSE4.1 `roundss`), six per edit of a box, enough to show in
        // the grid's update profile (BENCHMARKS.md, Uniform grid). A float at or above 2^23 is an integer already, so
        // `i as f32` is exact wherever the comparison matters.
        let y = (x * self.inv).clamp(-LIMIT as f32, LIMIT as f32);
        let i = y as i32;
        i - i32::from((i as f32) > y)
    }

    #[inline]
    pub fn key_of(&self, p: Vec3A) -> CellKey {
        CellKey([self.coord(p.x), self.coord(p.y), self.coord(p.z)])
    }

    /// The cells a closed box overlaps: every cell holding one of its points.
    #[inline]
    pub fn range_of(&self, b: &Aabb) -> CellRange {
        CellRange {
            lo: self.key_of(b.min).0,
            hi: self.key_of(b.max).0,
        }
    }

    /// A world box holding every point that maps into `range`, padded against rounding.
    /// The outermost cells reach to infinity.
    pub fn world_box(&self, range: &CellRange) -> Aabb {
        let lo = range.lo.map(|i| {
            if i <= -LIMIT {
                f32::NEG_INFINITY
            } else {
                let v = i as f32 * self.size;
                v - (v.abs() + self.size) * PAD
            }
        });
        let hi = range.hi.map(|i| {
            if i >= LIMIT {
                f32::INFINITY
            } else {
                let v = (i + 1) as f32 * self.size;
                v + (v.abs() + self.size) * PAD
            }
        });
        Aabb::new(Vec3A::from_array(lo), Vec3A::from_array(hi))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_lie_in_the_padded_box_of_their_cell() {
        let mut next = crate::test_floats(7);
        for size in [1e-3, 0.37, 1.0, 3.0, 1000.0] {
            let lattice = Lattice::new(size);
            for _ in 0..2000 {
                let scale = 10f32.powf(next() * 8.0 - 3.0);
                let p = Vec3A::new(next() - 0.5, next() - 0.5, next() - 0.5) * scale;
                let key = lattice.key_of(p);
                let b = lattice.world_box(&CellRange::single(key));
                assert!(
                    b.contains_point(p),
                    "{p:?} not in its cell {key:?} at {size}"
                );
            }
        }
    }

    #[test]
    fn coordinates_clamp_and_boundaries_round_down() {
        let lattice = Lattice::new(2.0);
        assert_eq!(lattice.coord(f32::MAX), LIMIT);
        assert_eq!(lattice.coord(f32::INFINITY), LIMIT);
        assert_eq!(lattice.coord(-f32::MAX), -LIMIT);
        assert_eq!(lattice.coord(4.0), 2);
        assert_eq!(lattice.coord(-4.0), -2);
        assert_eq!(lattice.coord(-0.0), 0);
        assert_eq!(lattice.coord(-1e-30), -1);
        let outer = lattice.world_box(&CellRange::single(CellKey([LIMIT, -LIMIT, 0])));
        assert_eq!(outer.max.x, f32::INFINITY);
        assert_eq!(outer.min.y, f32::NEG_INFINITY);
    }

    #[test]
    fn coordinates_equal_the_floor_of_the_scaled_value() {
        let reference =
            |l: &Lattice, x: f32| ((x * l.inv).floor() as i64).clamp(-LIMIT as i64, LIMIT as i64);
        let mut next = crate::test_floats(11);
        for size in [1e-3, 0.37, 1.0, 3.0, 1000.0] {
            let lattice = Lattice::new(size);
            let check = |x: f32| {
                assert_eq!(
                    i64::from(lattice.coord(x)),
                    reference(&lattice, x),
                    "{x} at {size}"
                );
            };
            for _ in 0..20_000 {
                let scale = 10f32.powf(next() * 16.0 - 6.0);
                let x = (next() - 0.5) * scale;
                check(x);
                // Cell boundaries and their neighbours, where rounding down matters.
                let edge = x.round() * size;
                check(edge);
                check(edge.next_up());
                check(edge.next_down());
            }
            for x in [
                0.0, -0.0, 8388608.0, -8388608.0, 8388607.5, -8388607.5, 1e12, -1e12,
            ] {
                check(x);
            }
        }
    }

    #[test]
    fn ranges_count_and_iterate() {
        let r = CellRange {
            lo: [-1, 0, 2],
            hi: [1, 1, 2],
        };
        assert_eq!(r.count(), 6);
        assert_eq!(r.keys().count(), 6);
        assert!(r.keys().all(|k| r.contains(k)));
        assert_eq!(CellRange::EMPTY.count(), 0);
        let all = CellRange {
            lo: [-LIMIT; 3],
            hi: [LIMIT; 3],
        };
        assert_eq!(all.count(), u64::MAX);
    }
}
