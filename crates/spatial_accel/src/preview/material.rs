//! Surface materials: a Lambertian base colour, optionally textured, and emission.

use glam::{Vec2, Vec3};
use std::sync::{Arc, OnceLock};

/// How a texture is read between texel centres.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum TextureFilter {
    /// The texel the coordinate falls in.
    Nearest,
    /// The four nearest texels, weighted by distance (in linear colour, so that blending
    /// two sRGB texels does not darken their average as blending encoded values does).
    #[default]
    Bilinear,
}

/// An RGBA8 texture whose colour channels are sRGB-encoded (a glTF base colour texture),
/// sampled with wrapping (repeat) addressing.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    width: u32,
    height: u32,
    texels: Vec<[u8; 4]>,
    /// How samples between texel centres are read.
    pub filter: TextureFilter,
}

impl Texture {
    /// A texture from its texels, row by row from the top (`v = 0`); `None` when the size is
    /// zero or does not match the texel count.
    pub fn new(
        width: u32,
        height: u32,
        texels: Vec<[u8; 4]>,
        filter: TextureFilter,
    ) -> Option<Self> {
        let count = (width as usize).checked_mul(height as usize)?;
        (count > 0 && count == texels.len()).then_some(Self {
            width,
            height,
            texels,
            filter,
        })
    }

    /// Width in texels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in texels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The linear RGB colour of texel `(x, y)`, wrapped into the texture.
    fn texel(&self, x: i64, y: i64) -> Vec3 {
        let x = x.rem_euclid(i64::from(self.width)) as usize;
        let y = y.rem_euclid(i64::from(self.height)) as usize;
        let [r, g, b, _] = self.texels[y * self.width as usize + x];
        let lut = srgb_to_linear_table();
        Vec3::new(lut[r as usize], lut[g as usize], lut[b as usize])
    }

    /// The linear RGB colour at texture coordinate `uv` (`(0, 0)` the top-left corner,
    /// repeating outside `[0, 1)`). A non-finite coordinate reads texel `(0, 0)`.
    pub fn sample(&self, uv: Vec2) -> Vec3 {
        let uv = if uv.is_finite() { uv } else { Vec2::ZERO };
        // Wrapped before scaling: a coordinate of 1e9 would otherwise leave no fraction.
        let uv = uv - uv.floor();
        let p = uv * Vec2::new(self.width as f32, self.height as f32);
        match self.filter {
            TextureFilter::Nearest => self.texel(p.x as i64, p.y as i64),
            TextureFilter::Bilinear => {
                // Texel centres sit at half-integers.
                let p = p - Vec2::splat(0.5);
                let base = p.floor();
                let f = p - base;
                let (x, y) = (base.x as i64, base.y as i64);
                let top = self.texel(x, y).lerp(self.texel(x + 1, y), f.x);
                let bottom = self.texel(x, y + 1).lerp(self.texel(x + 1, y + 1), f.x);
                top.lerp(bottom, f.y)
            }
        }
    }
}

/// The sRGB decoding of every 8-bit value (IEC 61966-2-1's piecewise curve), computed once.
fn srgb_to_linear_table() -> &'static [f32; 256] {
    static TABLE: OnceLock<[f32; 256]> = OnceLock::new();
    TABLE.get_or_init(|| core::array::from_fn(|i| srgb_to_linear(i as f32 / 255.0)))
}

/// One sRGB-encoded value in `[0, 1]` to linear.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// A surface's look: Lambertian reflection of `base_color` (times the texture, where there
/// is one and the hit has texture coordinates) plus emission.
///
/// Alpha is not read: the preview treats every surface as opaque.
#[derive(Clone, Debug, PartialEq)]
pub struct PreviewMaterial {
    /// Linear RGB albedo, each channel in `[0, 1]` for an energy-conserving surface.
    pub base_color: Vec3,
    /// Multiplies `base_color` at the hit's texture coordinate.
    pub base_color_texture: Option<Arc<Texture>>,
    /// Linear RGB radiance the surface emits, in the lights' units.
    pub emissive: Vec3,
}

impl Default for PreviewMaterial {
    /// A mid-grey, untextured, non-emissive surface (what a hit whose material id names no
    /// material is drawn with).
    fn default() -> Self {
        Self {
            base_color: Vec3::splat(0.5),
            base_color_texture: None,
            emissive: Vec3::ZERO,
        }
    }
}

impl PreviewMaterial {
    /// An untextured, non-emissive material of albedo `base_color`.
    pub fn diffuse(base_color: Vec3) -> Self {
        Self {
            base_color,
            ..Self::default()
        }
    }

    /// The albedo at a hit with texture coordinate `uv`.
    pub fn albedo(&self, uv: Option<Vec2>) -> Vec3 {
        match (&self.base_color_texture, uv) {
            (Some(texture), Some(uv)) => self.base_color * texture.sample(uv),
            _ => self.base_color,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker(filter: TextureFilter) -> Texture {
        let (b, w) = ([0, 0, 0, 255], [255, 255, 255, 255]);
        Texture::new(2, 2, vec![b, w, w, b], filter).unwrap()
    }

    #[test]
    fn nearest_reads_the_texel_and_wraps() {
        let t = checker(TextureFilter::Nearest);
        assert_eq!(t.sample(Vec2::new(0.25, 0.25)), Vec3::ZERO);
        assert_eq!(t.sample(Vec2::new(0.75, 0.25)), Vec3::ONE);
        assert_eq!(t.sample(Vec2::new(1.75, -0.75)), Vec3::ONE);
        assert_eq!(t.sample(Vec2::NAN), Vec3::ZERO);
    }

    #[test]
    fn bilinear_blends_linear_values_between_centres() {
        let t = checker(TextureFilter::Bilinear);
        assert_eq!(t.sample(Vec2::new(0.25, 0.25)), Vec3::ZERO);
        // Halfway between a black and a white centre: a linear half, not sRGB's 0.5.
        assert!((t.sample(Vec2::new(0.5, 0.25)) - Vec3::splat(0.5)).length() < 1e-6);
    }

    #[test]
    fn bad_sizes_are_refused() {
        assert!(Texture::new(0, 0, vec![], TextureFilter::Nearest).is_none());
        assert!(Texture::new(2, 2, vec![[0; 4]; 3], TextureFilter::Nearest).is_none());
    }

    #[test]
    fn srgb_decoding_meets_the_ends_and_the_mid_grey() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_to_linear(0.5) - 0.214).abs() < 1e-3);
    }
}
