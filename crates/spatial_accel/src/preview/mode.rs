//! What the preview draws.

/// The view a [`PreviewTracer`](super::PreviewTracer) renders.
///
/// `Shaded` and `PathTraced` are radiometric (linear radiance, tonemapped at resolve);
/// ambient occlusion is a fraction and the rest are false-colour views of the scene or of
/// the acceleration structure, all already in display range. Every view accumulates: samples after the first are jittered within the pixel, so
/// even the false-colour views antialias as samples add up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PreviewMode {
    /// Direct light from every light with hard shadows, plus the ambient term and emission.
    Shaded,
    /// Ambient occlusion: the fraction of cosine-weighted directions from the visible
    /// point that leave within `radius` without hitting anything, in grey.
    AmbientOcclusion {
        /// Occlusion rays per pixel per sample.
        samples: u32,
        /// How far an occluder counts (world units).
        radius: f32,
    },
    /// Diffuse path tracing: direct light from the lights at every vertex, indirect light by
    /// cosine-weighted bounces, the ambient colour as the sky escaped paths see.
    PathTraced {
        /// Bounces after the visible point (0: emission and direct light at the visible point,
        /// `Shaded` without its ambient term).
        max_bounces: u32,
    },
    /// The shading normal, mapped from `[-1, 1]` to `[0, 1]` per axis.
    Normals,
    /// Distance from the eye, white near, falling to black at the depth scale.
    Depth,
    /// A heat map of the nodes visited and triangles tested by the primary ray.
    TraversalCost,
    /// Each object (instance or entity) in its own colour.
    ObjectIds,
    /// A ramp over the depth of the leaf the primary hit was found in.
    LeafDepth,
}

impl PreviewMode {
    /// True for the views of linear radiance, which are tonemapped when resolved; false for
    /// ambient occlusion and the false-colour views, already in `[0, 1]`, which are written
    /// as they are (a tonemap would only dim them).
    pub fn is_radiometric(&self) -> bool {
        matches!(self, Self::Shaded | Self::PathTraced { .. })
    }
}
