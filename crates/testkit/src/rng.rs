//! The one seeded generator of the tests and benchmarks.

use glam::{DVec3, Vec3, Vec3A};

/// The LCG multiplier and increment under PCG32 (Knuth's MMIX constants).
const MUL: u64 = 6364136223846793005;
const INC: u64 = 1442695040888963407;

/// A small, fast, seedable generator: PCG32 (PCG-XSH-RR, O'Neill 2014), 64 bits of state and 32
/// bits out per step.
///
/// Tests need reproducible streams, not cryptographic ones: the same seed gives the same
/// numbers on every platform, so a failing case is reproduced by its seed alone. Owning it
/// keeps the tests free of a dependency whose stream could change with a version bump.
///
/// Every draw is built from [`next_u32`](Self::next_u32) in a fixed order (a vector's `x`
/// first), so a scene made from a seed never changes unless its maker does.
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
}

impl Rng {
    /// A generator seeded with `seed`: the seed is stepped through the LCG once and the first
    /// output discarded, so that small neighbouring seeds give unrelated streams.
    pub fn new(seed: u64) -> Self {
        let mut rng = Self::from_state(seed.wrapping_mul(MUL).wrapping_add(INC));
        rng.next_u32();
        rng
    }

    /// A generator whose state is `state` as it is, without [`new`](Self::new)'s scrambling
    /// (the plugin's tests were written against this stream).
    pub fn from_state(state: u64) -> Self {
        Self { state }
    }

    /// The next 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(MUL).wrapping_add(INC);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }

    /// The next 64 random bits: two 32-bit draws, the first as the high half.
    pub fn next_u64(&mut self) -> u64 {
        let hi = u64::from(self.next_u32());
        (hi << 32) | u64::from(self.next_u32())
    }

    /// Uniform in `[0, 1)`, on a grid of 2^-24 (every value exactly representable).
    pub fn f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    /// Uniform in `[0, 1)` with all 53 bits of the mantissa used.
    pub fn f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in `[lo, hi)` (up to the rounding of `lo + (hi - lo) * u`).
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }

    /// Uniform in `[lo, hi)`, in `f64`.
    pub fn range_f64(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.f64()
    }

    /// Uniform in `0..n` (by multiplication, not modulo, so without bias for small `n`); 0
    /// when `n` is 0.
    pub fn below(&mut self, n: usize) -> usize {
        ((u128::from(self.next_u32()) * n as u128) >> 32) as usize
    }

    /// A fair coin.
    pub fn bool(&mut self) -> bool {
        self.next_u32() >> 31 == 1
    }

    /// True with probability `p`.
    pub fn chance(&mut self, p: f32) -> bool {
        self.f32() < p
    }

    /// A uniformly chosen element of `items` (which must not be empty).
    pub fn pick<T: Copy>(&mut self, items: &[T]) -> T {
        items[self.below(items.len())]
    }

    /// Log-uniform magnitude in `[lo, hi]` (both positive): spreads values over many binades,
    /// where uniform sampling would almost never produce a small one.
    pub fn log_range(&mut self, lo: f32, hi: f32) -> f32 {
        (lo.ln() + (hi.ln() - lo.ln()) * self.f32()).exp()
    }

    /// [`log_range`](Self::log_range) with a random sign.
    pub fn signed_log(&mut self, lo: f32, hi: f32) -> f32 {
        let m = self.log_range(lo, hi);
        if self.bool() { m } else { -m }
    }

    /// Uniform in the box `[lo, hi)^3`.
    pub fn vec3a(&mut self, lo: f32, hi: f32) -> Vec3A {
        Vec3A::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }

    /// [`vec3a`](Self::vec3a) as a `Vec3` (the same draws).
    pub fn vec3(&mut self, lo: f32, hi: f32) -> Vec3 {
        self.vec3a(lo, hi).into()
    }

    /// A direction uniform on the unit sphere, by rejection from the cube `[-1, 1)^3` and
    /// normalisation in `f32`: unit length to a few ulps.
    pub fn unit_vector(&mut self) -> Vec3A {
        loop {
            let v = self.vec3a(-1.0, 1.0);
            let l = v.length_squared();
            if l > 1e-4 && l <= 1.0 {
                return v / l.sqrt();
            }
        }
    }

    /// A direction uniform on the unit sphere, computed in `f64` (uniform height and angle)
    /// and rounded once: unit length to half an ulp per coordinate.
    pub fn unit_vector_f64(&mut self) -> Vec3A {
        let z = self.range_f64(-1.0, 1.0);
        let phi = self.range_f64(0.0, std::f64::consts::TAU);
        let s = (1.0 - z * z).sqrt();
        DVec3::new(s * phi.cos(), s * phi.sin(), z).as_vec3a()
    }
}

#[cfg(test)]
mod tests {
    use super::Rng;

    /// The stream is PCG32's: `new` is `from_state` of the stepped seed after one draw.
    #[test]
    fn new_is_a_stepped_from_state() {
        let mut a = Rng::new(7);
        let mut b = Rng::from_state(7u64.wrapping_mul(super::MUL).wrapping_add(super::INC));
        b.next_u32();
        for _ in 0..100 {
            assert_eq!(a.next_u32(), b.next_u32());
        }
    }

    #[test]
    fn draws_stay_in_range() {
        let mut rng = Rng::new(1);
        for n in [1, 2, 3, 17, 1000] {
            for _ in 0..1000 {
                assert!(rng.below(n) < n);
            }
        }
        for _ in 0..10_000 {
            let (x, y) = (rng.f32(), rng.f64());
            assert!((0.0..1.0).contains(&x) && (0.0..1.0).contains(&y));
            let v = rng.log_range(1e-6, 1e6);
            assert!((1e-6 * 0.999..=1e6 * 1.001).contains(&v));
            assert!((rng.unit_vector().length() - 1.0).abs() < 1e-6);
            assert!((rng.unit_vector_f64().length() - 1.0).abs() < 1e-6);
        }
        assert_eq!(rng.below(0), 0);
    }
}
