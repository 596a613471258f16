//! The preview's random numbers: a hashed stream per pixel and sample, the sub-pixel jitter
//! sequence, and the hemisphere sampling that ambient occlusion and path tracing use.
//!
//! Everything is a pure function of (pixel, sample index, seed): a pixel's k-th sample is
//! the same whichever thread traces it and however the rows are split, which is what lets a
//! caller trace tiles in any order and still get one image.

use glam::{Vec2, Vec3A};

/// The PCG hash (Jarzynski and Olano 2020, "Hash Functions for GPU Rendering", JCGT 9(3)):
/// one step of a 32-bit LCG followed by PCG's RXS-M-XS output permutation. Their tests rank
/// it the best quality per cost of the small hashes, and it needs no state beyond a `u32`.
#[inline]
pub fn pcg_hash(x: u32) -> u32 {
    let state = x.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// A stream of uniform numbers for one pixel's one sample: a PCG generator seeded by
/// hashing the pixel, the sample index and the image seed together.
#[derive(Clone, Copy, Debug)]
pub struct Sampler {
    state: u32,
}

impl Sampler {
    /// The stream of sample `sample` of pixel `pixel` (`y * width + x`) under `seed`.
    #[inline]
    pub fn new(pixel: u32, sample: u32, seed: u32) -> Self {
        // Hashed in turn rather than added: `pixel + sample` would give pixel 1's sample 0
        // pixel 0's sample 1, correlating neighbours.
        Self {
            state: pcg_hash(pixel ^ pcg_hash(sample ^ pcg_hash(seed))),
        }
    }

    /// The next 32 random bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        self.state = pcg_hash(self.state);
        self.state
    }

    /// The next float, uniform in `[0, 1)` (24 random bits, so 1.0 is never reached).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Two floats for a 2D sample.
    #[inline]
    pub fn next_vec2(&mut self) -> Vec2 {
        Vec2::new(self.next_f32(), self.next_f32())
    }
}

/// `1 / g` and `1 / g^2` in 0.32 fixed point, `g` the plastic number (the R2 sequence,
/// Roberts 2018, "The Unreasonable Effectiveness of Quasirandom Sequences").
const R2_STEP: [u32; 2] = [3_242_174_889, 2_447_445_414];

/// The sub-pixel position of sample `sample`, in `[0, 1)^2`: the R2 low-discrepancy sequence
/// started at the pixel centre.
///
/// Why R2: it is stratified at every prefix length, so an image stopped after any number
/// of samples is as evenly antialiased as that count allows (random jitter clumps), and it
/// needs no precomputed table. Sample 0 is the centre, so the first frame of every view is
/// the rasteriser's own sampling and a false-colour view (ids, depth) is exact there. Every
/// pixel uses the same pattern, as an MSAA pattern does; the other random dimensions come
/// from [`Sampler`], decorrelated per pixel. The steps are kept in fixed point so that a
/// large sample index wraps exactly instead of losing the fraction to `f32` rounding.
#[inline]
pub fn pixel_jitter(sample: u32) -> Vec2 {
    let step = |axis: usize| {
        let fixed = (1u32 << 31).wrapping_add(sample.wrapping_mul(R2_STEP[axis]));
        // The top 24 bits: exact in `f32`, and below 1.
        (fixed >> 8) as f32 * (1.0 / 16_777_216.0)
    };
    Vec2::new(step(0), step(1))
}

/// A unit vector around `normal` (unit), cosine-distributed, from a uniform `u` in
/// `[0, 1)^2` (Malley's method: a uniform disc sample lifted to the hemisphere). The density
/// is `cos(theta) / pi`, which cancels the cosine of the rendering equation and the `1 / pi`
/// of a Lambertian surface, so a sample's weight is the albedo alone.
#[inline]
pub fn cosine_hemisphere(normal: Vec3A, u: Vec2) -> Vec3A {
    let r = u.x.sqrt();
    let (sin, cos) = (core::f32::consts::TAU * u.y).sin_cos();
    let z = (1.0 - u.x).max(0.0).sqrt();
    let (t, b) = orthonormal_basis(normal);
    (t * (r * cos) + b * (r * sin) + normal * z).normalize_or(normal)
}

/// Two unit vectors completing `n` (unit) to an orthonormal basis, without the branch on the
/// smallest component that loses precision near the poles (Duff et al. 2017, "Building an
/// Orthonormal Basis, Revisited", JCGT 6(1)).
#[inline]
pub fn orthonormal_basis(n: Vec3A) -> (Vec3A, Vec3A) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3A::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3A::new(b, sign + n.y * n.y * a, -n.y),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_differ_by_pixel_and_sample_and_repeat_exactly() {
        let first = |p, s| Sampler::new(p, s, 7).next_u32();
        assert_eq!(first(3, 4), first(3, 4));
        assert_ne!(first(0, 1), first(1, 0));
        assert_ne!(first(5, 0), Sampler::new(5, 0, 8).next_u32());
    }

    #[test]
    fn uniform_floats_stay_in_range_and_average_a_half() {
        let mut s = Sampler::new(11, 0, 0);
        let n = 20_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let x = s.next_f32();
            assert!((0.0..1.0).contains(&x));
            sum += f64::from(x);
        }
        assert!((sum / f64::from(n) - 0.5).abs() < 0.01);
    }

    #[test]
    fn jitter_starts_at_the_centre_and_fills_the_pixel_evenly() {
        assert_eq!(pixel_jitter(0), Vec2::splat(0.5));
        // Every cell of a 4x4 grid gets a sample within the first 64.
        let mut cells = [0u32; 16];
        for k in 0..64 {
            let j = pixel_jitter(k);
            assert!(j.cmpge(Vec2::ZERO).all() && j.cmplt(Vec2::ONE).all());
            cells[(j.x * 4.0) as usize + 4 * (j.y * 4.0) as usize] += 1;
        }
        assert!(cells.iter().all(|&c| (1..=8).contains(&c)), "{cells:?}");
    }

    #[test]
    fn cosine_samples_stay_above_the_surface_with_mean_cosine_two_thirds() {
        let n = Vec3A::new(0.3, -0.5, 0.8).normalize();
        let (t, b) = orthonormal_basis(n);
        assert!(t.dot(n).abs() < 1e-6 && b.dot(n).abs() < 1e-6 && t.dot(b).abs() < 1e-6);
        let mut s = Sampler::new(1, 2, 3);
        let count = 20_000;
        let mut mean = 0.0f64;
        for _ in 0..count {
            let d = cosine_hemisphere(n, s.next_vec2());
            assert!((d.length() - 1.0).abs() < 1e-5 && d.dot(n) >= 0.0);
            mean += f64::from(d.dot(n));
        }
        // E[cos] under the cos/pi density is 2/3.
        assert!((mean / f64::from(count) - 2.0 / 3.0).abs() < 0.01);
    }
}
