//! A progressive CPU ray-traced preview: the engine-independent core.
//!
//! An engine extracts its scene into a [`PreviewScene`] (or uses [`InstancedPreviewScene`]
//! over the crate's two-level [`InstancedScene`](crate::mesh::InstancedScene)), describes the
//! view as a [`PreviewTracer`] (camera, lights, materials, [`PreviewMode`]), and each frame
//! adds samples to some rows of a [`PreviewImage`], tile by tile on as many threads as it
//! likes, then uploads the bytes of [`PreviewTracer::resolve_rgba8`]. The image sharpens while the
//! view holds still; [`PreviewImage::restart`] clears it when the view changes.
//!
//! - [`PreviewScene`], [`SurfaceHit`]: the scene interface and the hit record;
//!   [`MeshSurface`] turns a mesh hit into one.
//! - [`IndexedPreviewScene`]: any [`DynamicIndex`](crate::query::DynamicIndex) of
//!   instance boxes as the top level, each instance's mesh BVH below it.
//! - [`BruteForcePreviewScene`]: every triangle tested, the oracle the tree's images match.
//! - [`PreviewCamera`]: world rays from Bevy's inverse view-projection (reverse Z).
//! - [`PreviewMaterial`], [`Texture`]: Lambertian albedo, sRGB textures, emission.
//! - [`PreviewLight`]: directional, point and spot lights with Bevy's falloff, hard shadows
//!   from rays started by [`offset_ray_origin`].
//! - [`PreviewImage`], [`ImageTile`], [`FrameBudget`]: accumulation, tiling and pacing.
//! - [`Tonemap`]: the display curves and exact sRGB encoding.
//! - [`rng`]: the hashed sample streams, the jitter sequence and hemisphere sampling.

mod accumulate;
mod budget;
mod camera;
mod indexed;
mod integrate;
mod light;
mod material;
mod mode;
mod reference;
pub mod rng;
mod scene;
mod tonemap;
mod tracer;

pub use crate::mesh::{CountedHit, TraversalCost};
pub use accumulate::{ImageTile, PreviewImage};
pub use budget::FrameBudget;
pub use camera::PreviewCamera;
pub use indexed::IndexedPreviewScene;
pub use light::{
    LightSample, PreviewLight, distance_attenuation, offset_ray_origin, spot_attenuation,
};
pub use material::{PreviewMaterial, Texture, TextureFilter, srgb_to_linear};
pub use mode::PreviewMode;
pub use reference::BruteForcePreviewScene;
pub use scene::{InstancedPreviewScene, MeshSurface, PreviewInstance, PreviewScene, SurfaceHit};
pub use tonemap::{Tonemap, linear_to_srgb8};
pub use tracer::{PreviewSettings, PreviewTracer, heat, id_colour};
