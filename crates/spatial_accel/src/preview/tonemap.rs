//! From linear radiance to display bytes: the tonemap curves and sRGB encoding.

use super::material::srgb_to_linear;
use glam::Vec3;
use std::sync::OnceLock;

/// How linear values above display range are brought into it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Tonemap {
    /// Clamp to `[0, 1]` (for values already in display range).
    Clamp,
    /// Reinhard's operator per channel, `c / (1 + c)` (Reinhard et al. 2002, "Photographic
    /// Tone Reproduction for Digital Images"): never clips, but greys highlights.
    Reinhard,
    /// Narkowicz's fit of the ACES filmic curve (2015, "ACES Filmic Tone Mapping Curve"),
    /// with his 0.6 pre-scale so that it brightens like Reinhard at mid-grey: a toe and a
    /// shoulder, as film and Bevy's own filmic tonemappers give.
    #[default]
    AcesFitted,
}

impl Tonemap {
    /// The curve applied to one linear colour (negative and NaN channels go to 0).
    pub fn apply(self, c: Vec3) -> Vec3 {
        let c = c.max(Vec3::ZERO);
        let mapped = match self {
            Self::Clamp => c,
            Self::Reinhard => c / (Vec3::ONE + c),
            Self::AcesFitted => {
                let x = c * 0.6;
                (x * (x * 2.51 + 0.03)) / (x * (x * 2.43 + 0.59) + 0.14)
            }
        };
        // `max` first keeps NaN out (glam's `max` returns the non-NaN operand); an infinite
        // channel is NaN after Reinhard's or the fit's division, and is white, its limit.
        let mapped = Vec3::select(c.cmpeq(Vec3::INFINITY), Vec3::ONE, mapped);
        mapped.clamp(Vec3::ZERO, Vec3::ONE)
    }
}

/// A linear value in `[0, 1]` to its nearest 8-bit sRGB code (IEC 61966-2-1), exactly:
/// the code whose decoded interval holds the value, found among the 255 decoded midpoints
/// between codes by binary search (eight comparisons, no `powf` per pixel).
pub fn linear_to_srgb8(c: f32) -> u8 {
    static MIDPOINTS: OnceLock<[f32; 255]> = OnceLock::new();
    let midpoints = MIDPOINTS
        .get_or_init(|| core::array::from_fn(|k| srgb_to_linear((k as f32 + 0.5) / 255.0)));
    // NaN compares false everywhere, so finds code 0.
    midpoints.partition_point(|&m| m <= c) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_codes_round_to_the_nearest_encoded_value() {
        assert_eq!(linear_to_srgb8(0.0), 0);
        assert_eq!(linear_to_srgb8(1.0), 255);
        assert_eq!(linear_to_srgb8(2.0), 255);
        assert_eq!(linear_to_srgb8(f32::NAN), 0);
        // Linear 0.214 is sRGB 0.5, code 127.5: either neighbour.
        assert!((127..=128).contains(&linear_to_srgb8(0.214)));
        for code in 0..=255u8 {
            assert_eq!(
                linear_to_srgb8(srgb_to_linear(f32::from(code) / 255.0)),
                code
            );
        }
    }

    #[test]
    fn curves_keep_order_and_stay_in_range() {
        for t in [Tonemap::Clamp, Tonemap::Reinhard, Tonemap::AcesFitted] {
            let mut last = -1.0;
            for i in 0..100 {
                let v = t.apply(Vec3::splat(i as f32 * 0.2)).x;
                assert!((0.0..=1.0).contains(&v) && v >= last, "{t:?}");
                last = v;
            }
            assert_eq!(t.apply(Vec3::NAN), Vec3::ZERO);
            assert_eq!(t.apply(Vec3::splat(-1.0)), Vec3::ZERO);
            assert_eq!(t.apply(Vec3::INFINITY), Vec3::ONE);
        }
        assert!((Tonemap::Reinhard.apply(Vec3::ONE).x - 0.5).abs() < 1e-6);
    }
}
