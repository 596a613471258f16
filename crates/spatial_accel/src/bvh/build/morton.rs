//! Morton codes and the LSD radix sort that orders primitives along the Z-order curve: the
//! first step of PLOC (Meister & Bittner 2018). Primitives close on the curve are close in
//! space, which is what lets the clustering look for a nearest neighbour only a few places to
//! either side.
//!
//! A key packs the code above the primitive's id in one `u64`, so the sort moves 8 bytes per
//! primitive and the id rides along in the low bits without being sorted: LSD radix sorting is
//! stable, so equal codes keep id order and the result is deterministic.

use super::top_down::centroid;
use crate::Aabb;
use glam::Vec3A;
use std::ops::Range;

/// Bits of the first, most significant, radix pass: 64 buckets.
const TOP_BITS: u32 = 6;

/// Most bits per LSD digit inside a bucket (2,048 counters, eight kilobytes: in L1).
const DIGIT_BITS: u32 = 11;

/// Most bits per axis: 8,192 cells an axis, 39-bit codes, which sort in one top pass and three
/// LSD passes. On both benchmark scenes (a million triangles, 100,000 entity boxes) PLOC's SAH
/// cost stays the same from 10 to 14 bits: finer codes only reorder nearly coincident
/// primitives, which the neighbour search does not notice.
const MAX_AXIS_BITS: u32 = 13;

/// How the keys of a build are laid out: `code << index_bits | id`.
#[derive(Clone, Copy, Debug)]
pub(super) struct KeyLayout {
    /// Low bits holding the primitive id.
    pub index_bits: u32,
    /// Bits of each axis in the code.
    pub axis_bits: u32,
}

impl KeyLayout {
    /// The layout for ids below `id_bound`: as many code bits as fit above the id, at most
    /// [`MAX_AXIS_BITS`] an axis.
    pub fn for_ids(id_bound: usize) -> Self {
        let index_bits = usize::BITS - id_bound.saturating_sub(1).leading_zeros();
        Self {
            index_bits,
            axis_bits: ((64 - index_bits) / 3).min(MAX_AXIS_BITS),
        }
    }

    /// The bits that order the keys (the code), above the id.
    pub fn code_bits(&self) -> Range<u32> {
        self.index_bits..self.index_bits + 3 * self.axis_bits
    }

    /// The primitive id of a key.
    #[inline]
    pub fn id(&self, key: u64) -> u32 {
        (key & ((1u64 << self.index_bits) - 1)) as u32
    }
}

/// Maps points in a box to integer grid cells of `bits` bits an axis.
#[derive(Clone, Copy, Debug)]
pub(super) struct Quantizer {
    origin: Vec3A,
    scale: Vec3A,
    last: Vec3A,
}

impl Quantizer {
    /// A grid over `bounds` (the centroid bounds). An axis with no extent maps to cell 0; so
    /// does an axis whose extent overflows to infinity (infinite input boxes), rather than
    /// producing NaN.
    pub fn new(bounds: &Aabb, bits: u32) -> Self {
        let cells = (1u32 << bits) as f32;
        let extent = bounds.extent();
        let scale = Vec3A::select(
            extent.cmpgt(Vec3A::ZERO) & extent.cmplt(Vec3A::INFINITY),
            Vec3A::splat(cells) / extent,
            Vec3A::ZERO,
        );
        Self {
            origin: bounds.min,
            scale,
            last: Vec3A::splat(cells - 1.0),
        }
    }

    /// The Morton code of a point: its cell's coordinates interleaved, x highest.
    #[inline]
    pub fn code(&self, p: Vec3A) -> u64 {
        // `as` saturates and maps NaN to 0, so even a point outside the grid gets a cell.
        let q = ((p - self.origin) * self.scale).min(self.last).as_uvec3();
        (spread14(q.x) << 2) | (spread14(q.y) << 1) | spread14(q.z)
    }
}

/// Bits 0 to 6 spread to bits 0, 3, ..., 18.
const SPREAD7: [u32; 128] = {
    let mut table = [0u32; 128];
    let mut i = 0;
    while i < 128 {
        let mut bit = 0;
        while bit < 7 {
            table[i] |= ((i as u32 >> bit) & 1) << (3 * bit);
            bit += 1;
        }
        i += 1;
    }
    table
};

/// Spreads the low 14 bits of `x` so that bit `i` lands on bit `3 i`, by two lookups: a
/// third of the instructions of the shift-and-mask version, which dominated making the keys.
#[inline(always)]
fn spread14(x: u32) -> u64 {
    const _: () = assert!(MAX_AXIS_BITS <= 14);
    u64::from(SPREAD7[(x & 127) as usize]) | (u64::from(SPREAD7[((x >> 7) & 127) as usize]) << 21)
}

/// Spreads the low 21 bits of `x` so that bit `i` lands on bit `3 i` (the "magic bits" of
/// Baert et al., as in every Morton encoder): the reference for [`spread14`].
#[cfg(test)]
fn spread3(x: u32) -> u64 {
    let mut x = u64::from(x & 0x1f_ffff);
    x = (x | x << 32) & 0x001f_0000_0000_ffff;
    x = (x | x << 16) & 0x001f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    x = (x | x << 2) & 0x1249_2492_4924_9249;
    x
}

/// The valid boxes of `bounds` as keys sorted along the Morton curve of their centroids
/// (`code << index_bits | id`, on a grid over the centroids' bounds), with the layout that
/// reads them; invalid boxes are left out. The first step of PLOC and of LBVH.
pub(super) fn sorted_keys(bounds: &[Aabb]) -> (KeyLayout, Vec<u64>) {
    assert!(
        bounds.len() < u32::MAX as usize,
        "a BVH holds at most u32::MAX - 1 primitives"
    );
    let mut centroids = Aabb::EMPTY;
    let mut n = 0usize;
    for b in bounds {
        if b.is_valid() {
            centroids = centroids.grow(centroid(b));
            n += 1;
        }
    }
    let layout = KeyLayout::for_ids(bounds.len());
    let grid = Quantizer::new(&centroids, layout.axis_bits);
    let mut keys = Vec::with_capacity(n);
    for (i, b) in bounds.iter().enumerate() {
        if b.is_valid() {
            keys.push((grid.code(centroid(b)) << layout.index_bits) | i as u64);
        }
    }
    radix_sort(&mut keys, layout.code_bits());
    (layout, keys)
}

/// Sorts `keys` by the bits in `bits`; lower bits ride along in their input order (the sort is
/// stable).
///
/// One most-significant-digit pass of [`TOP_BITS`] splits the keys into buckets, then each
/// bucket is sorted least-significant digit first, at most [`DIGIT_BITS`] a pass. A plain LSD
/// sort of a million keys scatters every pass to 2,048 places across 8 MB: on 4 KB pages that
/// is a TLB miss per key, which on a virtual machine (two-level page walks) dominates the
/// sort. The top pass scatters to only 64 places; each bucket (a sixty-fourth of the
/// keys) is then sorted inside L2. An LSD pass whose digit is the same for every key of its
/// bucket is skipped.
pub(crate) fn radix_sort(keys: &mut Vec<u64>, bits: Range<u32>) {
    let n = keys.len();
    let width = bits.end.saturating_sub(bits.start);
    if n < 2 || width == 0 {
        return;
    }
    let top = width.min(TOP_BITS);
    let top_shift = bits.end - top;
    let buckets = 1usize << top;
    let mask = buckets as u64 - 1;
    let mut hist = vec![0u32; buckets];
    for &k in keys.iter() {
        hist[((k >> top_shift) & mask) as usize] += 1;
    }
    let mut scratch = vec![0u64; n];
    let mut ends = vec![0u32; buckets];
    let mut sum = 0u32;
    for (h, e) in hist.iter_mut().zip(ends.iter_mut()) {
        sum += *h;
        *e = sum;
        *h = sum - *h;
    }
    for &k in keys.iter() {
        let slot = &mut hist[((k >> top_shift) & mask) as usize];
        scratch[*slot as usize] = k;
        *slot += 1;
    }
    let low = bits.start..top_shift;
    let mut counts = Vec::new();
    let mut begin = 0usize;
    for &end in &ends {
        let end = end as usize;
        if end - begin > 1 {
            lsd(
                &mut scratch[begin..end],
                &mut keys[begin..end],
                low.clone(),
                &mut counts,
            );
        }
        begin = end;
    }
    std::mem::swap(keys, &mut scratch);
}

/// LSD radix sort of `keys` by `bits`, with `tmp` as the other buffer; the result is left in
/// `keys`.
fn lsd(keys: &mut [u64], tmp: &mut [u64], bits: Range<u32>, counts: &mut Vec<u32>) {
    let n = keys.len();
    let width = bits.end.saturating_sub(bits.start);
    if width == 0 {
        return;
    }
    let passes = width.div_ceil(DIGIT_BITS) as usize;
    let digit = width.div_ceil(passes as u32);
    let radix = 1usize << digit;
    let mask = radix as u64 - 1;
    let shift = |pass: usize| bits.start + pass as u32 * digit;
    counts.clear();
    counts.resize(passes * radix, 0);
    for &k in keys.iter() {
        for (pass, h) in counts.chunks_exact_mut(radix).enumerate() {
            h[((k >> shift(pass)) & mask) as usize] += 1;
        }
    }
    let mut in_keys = true;
    for (pass, h) in counts.chunks_exact_mut(radix).enumerate() {
        if h.iter().any(|&c| c as usize == n) {
            continue;
        }
        let mut sum = 0u32;
        for c in h.iter_mut() {
            let here = *c;
            *c = sum;
            sum += here;
        }
        let s = shift(pass);
        let (src, dst) = if in_keys {
            (&*keys, &mut *tmp)
        } else {
            (&*tmp, &mut *keys)
        };
        for &k in src {
            let slot = &mut h[((k >> s) & mask) as usize];
            dst[*slot as usize] = k;
            *slot += 1;
        }
        in_keys = !in_keys;
    }
    if !in_keys {
        keys.copy_from_slice(tmp);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reference(keys: &[u64], bits: Range<u32>) -> Vec<u64> {
        let mut v = keys.to_vec();
        let mask = if bits.end >= 64 {
            u64::MAX
        } else {
            (1u64 << bits.end) - 1
        };
        v.sort_by_key(|&k| (k & mask) >> bits.start);
        v
    }

    #[test]
    fn radix_sort_is_a_stable_sort_by_the_given_bits() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        for n in [0, 1, 2, 255, 256, 257, 5_000, 70_000] {
            for bits in [0..0, 3..17, 20..62, 0..64, 40..44, 5..9, 7..8] {
                let keys: Vec<u64> = (0..n)
                    .map(|_| {
                        state ^= state << 13;
                        state ^= state >> 7;
                        state ^= state << 17;
                        // Few distinct values in the sorted bits, so stability is exercised.
                        ((state % 97) << bits.start) | (state >> 40)
                    })
                    .collect();
                let mut got = keys.clone();
                radix_sort(&mut got, bits.clone());
                assert!(got == reference(&keys, bits.clone()), "n {n} bits {bits:?}");
            }
        }
    }

    #[test]
    fn codes_interleave_x_highest() {
        assert_eq!(spread3(0b111), 0b1001001);
        for x in 0..1 << 14 {
            assert_eq!(spread14(x), spread3(x));
        }
        let q = Quantizer::new(&Aabb::new(Vec3A::ZERO, Vec3A::ONE), 1);
        assert_eq!(q.code(Vec3A::new(1.0, 0.0, 0.0)), 0b100);
        assert_eq!(q.code(Vec3A::new(0.0, 0.0, 1.0)), 0b001);
        assert_eq!(q.code(Vec3A::ONE), 0b111);
        let layout = KeyLayout::for_ids(1 << 20);
        assert_eq!(layout.index_bits, 20);
        assert_eq!(layout.code_bits(), 20..59);
        assert_eq!(layout.id((5 << 20) | 77), 77);
        assert_eq!(KeyLayout::for_ids(1).index_bits, 0);
    }
}
