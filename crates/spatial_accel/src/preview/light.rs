//! Punctual lights with Bevy's falloff, and the shadow-ray origin that keeps a surface from
//! shadowing itself.

use glam::{Vec3, Vec3A};

/// A light. Colours are linear RGB times intensity, in units the exposure setting brings
/// to display range; a plugin converting Bevy's lights passes a point or spot light's
/// lumens over `4 pi` (candela, as Bevy's shaders do) and a directional light's lux.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PreviewLight {
    /// Parallel light from infinitely far (the sun).
    Directional {
        /// The direction the light travels (from the light towards the scene); need not be
        /// unit length.
        direction: Vec3,
        /// Colour times illuminance on a surface facing the light.
        illuminance: Vec3,
    },
    /// Light from a point, equal in every direction.
    Point {
        /// Where the light is.
        position: Vec3,
        /// Colour times radiant (luminous) intensity.
        intensity: Vec3,
        /// Beyond this distance the light contributes nothing (see [`distance_attenuation`]).
        range: f32,
    },
    /// A point light limited to a cone.
    Spot {
        /// Where the light is.
        position: Vec3,
        /// The cone's axis, the way the light shines; need not be unit length.
        direction: Vec3,
        /// Colour times intensity along the axis.
        intensity: Vec3,
        /// Beyond this distance the light contributes nothing.
        range: f32,
        /// Half-angle (radians) inside which the cone is at full intensity.
        inner_angle: f32,
        /// Half-angle (radians) outside which the cone is dark.
        outer_angle: f32,
    },
}

/// What a light sends to one surface point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    /// Unit direction from the point towards the light.
    pub to_light: Vec3A,
    /// Distance to the light along `to_light` (infinite for a directional light): how far
    /// a shadow ray must look.
    pub distance: f32,
    /// Irradiance at the point from this light if nothing blocks it: intensity, falloff and
    /// the cosine with the normal. Zero where the light is behind the surface.
    pub irradiance: Vec3,
}

/// Bevy's (and Frostbite's) distance falloff: inverse square, multiplied by a window that
/// takes it smoothly to zero at `range`, `(1 - (d/range)^4)^2` clamped (Lagarde and de
/// Rousiers 2014, "Moving Frostbite to Physically Based Rendering", eq. 26), so that a light
/// can be skipped beyond its range with no visible edge. The square distance is held above
/// `1e-4` as Bevy does, so a surface at the light is bright, not infinite.
pub fn distance_attenuation(distance_squared: f32, range: f32) -> f32 {
    let inverse_range_squared = 1.0 / (range * range);
    let factor = distance_squared * inverse_range_squared;
    let window = (1.0 - factor * factor).clamp(0.0, 1.0);
    window * window / distance_squared.max(1e-4)
}

/// Bevy's spot cone: full inside `inner_angle`, zero outside `outer_angle`, and in between
/// the square of a linear ramp in the cosine of the angle off the axis.
pub fn spot_attenuation(cos_off_axis: f32, inner_angle: f32, outer_angle: f32) -> f32 {
    let (cos_outer, cos_inner) = (outer_angle.cos(), inner_angle.cos());
    let scale = 1.0 / (cos_inner - cos_outer).max(1e-4);
    let ramp = (cos_off_axis * scale - cos_outer * scale).clamp(0.0, 1.0);
    ramp * ramp
}

impl PreviewLight {
    /// What the light sends to `point` on a surface of unit normal `normal` (the side the
    /// light must be on); `None` when it sends nothing there (behind the surface, out of
    /// range or cone, or a light given non-finite values).
    pub fn illuminate(&self, point: Vec3A, normal: Vec3A) -> Option<LightSample> {
        let (to_light, distance, incident) = match *self {
            Self::Directional {
                direction,
                illuminance,
            } => (
                -Vec3A::from(direction).normalize_or_zero(),
                f32::INFINITY,
                illuminance,
            ),
            Self::Point {
                position,
                intensity,
                range,
            } => {
                let offset = Vec3A::from(position) - point;
                let d2 = offset.length_squared();
                let d = d2.sqrt();
                (offset / d, d, intensity * distance_attenuation(d2, range))
            }
            Self::Spot {
                position,
                direction,
                intensity,
                range,
                inner_angle,
                outer_angle,
            } => {
                let offset = Vec3A::from(position) - point;
                let d2 = offset.length_squared();
                let d = d2.sqrt();
                let to_light = offset / d;
                let axis = Vec3A::from(direction).normalize_or_zero();
                let cone = spot_attenuation(-to_light.dot(axis), inner_angle, outer_angle);
                (
                    to_light,
                    d,
                    intensity * (distance_attenuation(d2, range) * cone),
                )
            }
        };
        let cos = to_light.dot(normal);
        let irradiance = incident * cos;
        // `cos > 0` is false for NaN: a broken light (or a point at the light) sends nothing.
        (cos > 0.0 && irradiance.is_finite() && irradiance != Vec3::ZERO).then_some(LightSample {
            to_light,
            distance,
            irradiance,
        })
    }
}

/// The origin for a ray leaving a surface at `point` on the side of `normal` (unit, the
/// geometric normal on the side the ray leaves by), moved off the surface by an amount that
/// grows with the point's magnitude.
///
/// Why: a hit point is rounded, so it lies a little in front of or behind the true surface,
/// by an error proportional to its coordinates' magnitude. A shadow or bounce ray started
/// there can hit the very triangle it leaves ("shadow acne", dark speckles over every lit
/// surface); a fixed epsilon is too small far from the origin and too large (light leaking
/// through thin walls) near it. This is the method of Wächter and Binder, "A Fast and Robust
/// Method for Avoiding Self-Intersection" (Ray Tracing Gems, ch. 6, 2019): each coordinate
/// moves a fixed number of units in the last place (256 times the normal component) in
/// integer space, which scales with its magnitude, except near zero, where ulps vanish and a
/// small absolute offset (`1/65536` times the normal, below `1/32`) is used instead.
/// Non-finite input gives non-finite output, which makes a degenerate ray that misses.
pub fn offset_ray_origin(point: Vec3A, normal: Vec3A) -> Vec3A {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let offset = |p: f32, n: f32| {
        if p.abs() < ORIGIN {
            return p + FLOAT_SCALE * n;
        }
        // `as` saturates and takes NaN to 0; the wrapping add cannot overflow for finite,
        // normal-sized points, and for the others leaves a non-finite point non-finite or a
        // huge one huge.
        let ulps = (INT_SCALE * n) as i32;
        let ulps = if p < 0.0 { -ulps } else { ulps };
        f32::from_bits((p.to_bits() as i32).wrapping_add(ulps) as u32)
    };
    Vec3A::new(
        offset(point.x, normal.x),
        offset(point.y, normal.y),
        offset(point.z, normal.z),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn falloff_is_inverse_square_near_and_zero_at_range() {
        let near = distance_attenuation(1.0, 1000.0);
        assert!((near - 1.0).abs() < 1e-6);
        assert!((distance_attenuation(4.0, 1000.0) - 0.25).abs() < 1e-6);
        assert_eq!(distance_attenuation(100.0, 10.0), 0.0);
        assert_eq!(distance_attenuation(200.0, 10.0), 0.0);
        assert!(distance_attenuation(0.0, 10.0).is_finite());
    }

    #[test]
    fn spot_cone_is_full_inside_and_dark_outside() {
        let (inner, outer) = (0.3f32, 0.5f32);
        assert_eq!(spot_attenuation(1.0, inner, outer), 1.0);
        assert_eq!(spot_attenuation(0.6f32.cos(), inner, outer), 0.0);
        let mid = spot_attenuation(0.4f32.cos(), inner, outer);
        assert!(mid > 0.0 && mid < 1.0);
    }

    #[test]
    fn lights_behind_the_surface_or_broken_send_nothing() {
        let sun = PreviewLight::Directional {
            direction: Vec3::NEG_Y,
            illuminance: Vec3::ONE,
        };
        let lit = sun.illuminate(Vec3A::ZERO, Vec3A::Y).unwrap();
        assert_eq!((lit.to_light, lit.irradiance), (Vec3A::Y, Vec3::ONE));
        assert!(sun.illuminate(Vec3A::ZERO, Vec3A::NEG_Y).is_none());
        let broken = PreviewLight::Point {
            position: Vec3::NAN,
            intensity: Vec3::ONE,
            range: 10.0,
        };
        assert!(broken.illuminate(Vec3A::ZERO, Vec3A::Y).is_none());
        let at_point = PreviewLight::Point {
            position: Vec3::ZERO,
            intensity: Vec3::ONE,
            range: 10.0,
        };
        assert!(at_point.illuminate(Vec3A::ZERO, Vec3A::Y).is_none());
    }

    #[test]
    fn offset_origins_leave_the_surface_on_the_normal_side_at_any_magnitude() {
        for scale in [1e-3f32, 1.0, 1e3, 1e6] {
            let p = Vec3A::new(0.7, -0.3, 0.2) * scale;
            let n = Vec3A::new(0.36, -0.48, 0.8);
            let o = offset_ray_origin(p, n);
            assert!((o - p).dot(n) > 0.0, "scale {scale}");
            // Small next to the point (a few hundred ulps), or to 1/32 near the origin.
            assert!(
                (o - p).length() <= (p.length() * 1e-4).max(1e-4),
                "scale {scale}"
            );
        }
        assert!(!offset_ray_origin(Vec3A::NAN, Vec3A::Y).is_finite());
    }
}
