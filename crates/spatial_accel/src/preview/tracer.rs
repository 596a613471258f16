//! The tracer: one sample of one pixel in the chosen view, and rows or tiles of them.

use super::accumulate::{ImageTile, PreviewImage};
use super::camera::PreviewCamera;
use super::integrate;
use super::light::PreviewLight;
use super::material::PreviewMaterial;
use super::mode::PreviewMode;
use super::rng::{Sampler, pcg_hash, pixel_jitter};
use super::scene::PreviewScene;
use super::tonemap::Tonemap;
use glam::{Vec2, Vec3};
use std::ops::Range;

/// What the views need beyond camera, lights and materials.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreviewSettings {
    /// Radiance of a uniform sky: the ambient term of the shaded view, and what escaped
    /// paths see in the path-traced one.
    pub ambient: Vec3,
    /// What a ray that hits nothing shows, in every view.
    pub background: Vec3,
    /// Multiplies radiance before the tonemap.
    pub exposure: f32,
    /// The curve the radiometric views are resolved through.
    pub tonemap: Tonemap,
    /// Seeds every random stream; a different seed, a different (equally valid) noise.
    pub seed: u32,
    /// The distance from the eye at which the depth view reaches black.
    pub depth_scale: f32,
    /// Nodes plus triangles of a primary ray at the hot end of the traversal-cost ramp.
    pub cost_scale: f32,
    /// Leaf depth at the hot end of the leaf-depth ramp.
    pub leaf_depth_scale: u32,
}

impl Default for PreviewSettings {
    fn default() -> Self {
        Self {
            ambient: Vec3::splat(0.03),
            background: Vec3::ZERO,
            exposure: 1.0,
            tonemap: Tonemap::default(),
            seed: 0,
            depth_scale: 100.0,
            cost_scale: 200.0,
            leaf_depth_scale: 16,
        }
    }
}

/// Everything a frame is traced with besides the scene: camera, lights, materials, view.
///
/// Immutable while tracing and `Sync`, so one tracer serves every thread; each pixel's
/// sample is a pure function of the pixel, its sample index and the settings' seed, so an
/// image is the same however its rows are split among threads.
///
/// A hit whose material index names no material is shaded with
/// [`PreviewMaterial::default`].
#[derive(Clone, Debug, PartialEq)]
pub struct PreviewTracer {
    /// The view's camera.
    pub camera: PreviewCamera,
    /// Every light.
    pub lights: Vec<PreviewLight>,
    /// Materials, by the index hits report.
    pub materials: Vec<PreviewMaterial>,
    /// What is drawn.
    pub mode: PreviewMode,
    /// The views' settings.
    pub settings: PreviewSettings,
}

/// The fallback material, kept in a static so a lookup can return a reference.
static DEFAULT_MATERIAL: std::sync::LazyLock<PreviewMaterial> =
    std::sync::LazyLock::new(PreviewMaterial::default);

impl PreviewTracer {
    /// A tracer with no lights and no materials, in `mode`, with default settings.
    pub fn new(camera: PreviewCamera, mode: PreviewMode) -> Self {
        Self {
            camera,
            lights: Vec::new(),
            materials: Vec::new(),
            mode,
            settings: PreviewSettings::default(),
        }
    }

    /// Material `index`, or the default material.
    pub fn material(&self, index: u32) -> &PreviewMaterial {
        self.materials
            .get(index as usize)
            .unwrap_or(&DEFAULT_MATERIAL)
    }

    /// Sample `sample` of pixel `(x, y)` of a `width` x `height` image: linear RGB, finite
    /// and non-negative (a non-finite result, from a broken light or material, is black).
    pub fn sample_pixel<S: PreviewScene + ?Sized>(
        &self,
        scene: &S,
        (width, height): (u32, u32),
        x: u32,
        y: u32,
        sample: u32,
    ) -> Vec3 {
        let jitter = pixel_jitter(sample);
        let ray = self
            .camera
            .pixel_ray(Vec2::new(x as f32, y as f32) + jitter, width, height);
        let mut sampler = Sampler::new(
            y.wrapping_mul(width).wrapping_add(x),
            sample,
            self.settings.seed,
        );
        let s = &self.settings;
        let value = match self.mode {
            PreviewMode::Shaded => integrate::shaded(self, scene, &ray),
            PreviewMode::AmbientOcclusion { samples, radius } => {
                integrate::ambient_occlusion(self, scene, &ray, samples, radius, &mut sampler)
            }
            PreviewMode::PathTraced { max_bounces } => {
                integrate::path_traced(self, scene, &ray, max_bounces, &mut sampler)
            }
            PreviewMode::Normals => scene
                .closest(&ray)
                .map_or(s.background, |h| Vec3::from(h.shading_normal) * 0.5 + 0.5),
            PreviewMode::Depth => scene.closest(&ray).map_or(s.background, |h| {
                let d = (Vec3::from(h.position) - self.camera.position).length();
                Vec3::splat((1.0 - d / s.depth_scale).clamp(0.0, 1.0))
            }),
            PreviewMode::TraversalCost => {
                // Misses too: a ray that finds nothing may still have walked half the tree.
                let c = scene.closest_counted(&ray).cost;
                heat(c.nodes.saturating_add(c.triangles) as f32 / s.cost_scale)
            }
            PreviewMode::ObjectIds => scene
                .closest(&ray)
                .map_or(s.background, |h| id_colour(h.object)),
            PreviewMode::LeafDepth => {
                let counted = scene.closest_counted(&ray);
                match (counted.hit, counted.leaf_depth) {
                    (None, _) => s.background,
                    (Some(_), Some(depth)) => heat(depth as f32 / s.leaf_depth_scale.max(1) as f32),
                    // A structure without leaves (brute force): grey.
                    (Some(_), None) => Vec3::splat(0.5),
                }
            }
        };
        if value.is_finite() {
            value.max(Vec3::ZERO)
        } else {
            Vec3::ZERO
        }
    }

    /// Sample `sample` of every pixel of `rows` of a `width` x `height` image, written to
    /// `out` row by row (`out[(y - rows.start) * width + x]`); rows outside the image, and
    /// pixels `out` has no room for, are skipped. Disjoint row ranges can be traced on
    /// different threads into different buffers.
    pub fn trace_rows<S: PreviewScene + ?Sized>(
        &self,
        scene: &S,
        (width, height): (u32, u32),
        rows: Range<u32>,
        sample: u32,
        out: &mut [Vec3],
    ) {
        let rows = rows.start.min(height)..rows.end.min(height);
        let pixels = rows
            .flat_map(|y| (0..width).map(move |x| (x, y)))
            .zip(out.iter_mut());
        for ((x, y), slot) in pixels {
            *slot = self.sample_pixel(scene, (width, height), x, y, sample);
        }
    }

    /// Adds one sample to every pixel of `tile`, each pixel taking its own next sample
    /// index (its count so far).
    pub fn trace_tile<S: PreviewScene + ?Sized>(&self, scene: &S, tile: &mut ImageTile<'_>) {
        let size = tile.image_size();
        for y in tile.rows() {
            for x in 0..size.0 {
                let sample = tile.sample_count(x, y);
                let value = self.sample_pixel(scene, size, x, y, sample);
                tile.add_sample(x, y, value);
            }
        }
    }

    /// `image` as RGBA8 for this view: the radiometric views through the exposure and the
    /// settings' tonemap, the others clamped as they are (see
    /// [`PreviewMode::is_radiometric`]).
    pub fn resolve_rgba8(&self, image: &PreviewImage, out: &mut Vec<u8>) {
        if self.mode.is_radiometric() {
            image.resolve_rgba8(self.settings.tonemap, self.settings.exposure, out);
        } else {
            image.resolve_rgba8(Tonemap::Clamp, 1.0, out);
        }
    }
}

/// A colour for object `id`, from its hash: neighbours' ids get unrelated colours, and
/// every channel stays above a fifth so no object reads as background black.
pub fn id_colour(id: u32) -> Vec3 {
    let h = pcg_hash(id);
    let channel = |shift: u32| 0.2 + 0.8 * ((h >> shift) & 0xff) as f32 / 255.0;
    Vec3::new(channel(0), channel(8), channel(16))
}

/// A heat ramp over `v` in `[0, 1]` (clamped): blue, cyan, green, yellow, red.
pub fn heat(v: f32) -> Vec3 {
    const STOPS: [Vec3; 5] = [
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(0.0, 1.0, 1.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
    ];
    // NaN clamps to... NaN, so it is taken to 0 first.
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) } * (STOPS.len() - 1) as f32;
    let i = (v as usize).min(STOPS.len() - 2);
    STOPS[i].lerp(STOPS[i + 1], v - i as f32)
}
