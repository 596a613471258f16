//! A ray-traced preview of the main view, made on the CPU from the same trees and mesh BVHs
//! that picking and culling use (cargo feature `preview`).
//!
//! - `scene`: the entity trees and mesh BVHs as the core tracer's scene.
//! - `extract`: the camera, lights, materials and objects read from the ECS.
//! - `trace`: the per-frame system: restart on change, trace within a time budget across
//!   Bevy's compute task pool, upload the image once.
//! - `display`: the image shown over the view by a camera of its own.

mod display;
mod extract;
mod scene;
#[cfg(test)]
mod tests;
mod trace;

use crate::AccelSystems;
use bevy::diagnostic::{Diagnostic, DiagnosticPath, RegisterDiagnostic};
use bevy::prelude::*;
use core::time::Duration;

/// What the preview draws: [`spatial_accel::preview::PreviewMode`], as a reflectable setting.
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq)]
#[reflect(Default)]
pub enum AccelPreviewMode {
    /// Direct light from every light with hard shadows, plus ambient and emission.
    #[default]
    Shaded,
    /// Ambient occlusion within `radius`, `samples` rays per pixel per sample.
    AmbientOcclusion {
        /// Occlusion rays per pixel per sample.
        samples: u32,
        /// How far an occluder counts, in world units.
        radius: f32,
    },
    /// Diffuse path tracing with `max_bounces` bounces: the converged reference.
    PathTraced {
        /// Bounces after the visible point.
        max_bounces: u32,
    },
    /// Shading normals.
    Normals,
    /// Distance from the eye.
    Depth,
    /// Mesh nodes and triangles visited per pixel (plus the entities reached), as a heat map.
    TraversalCost,
    /// Each entity in its own colour.
    EntityIds,
    /// The depth of the mesh BVH leaf each pixel's hit was found in.
    LeafDepth,
}

impl AccelPreviewMode {
    /// Every mode, with the default parameters of those that have some.
    pub const ALL: [AccelPreviewMode; 8] = [
        Self::Shaded,
        Self::AmbientOcclusion {
            samples: 1,
            radius: 2.0,
        },
        Self::PathTraced { max_bounces: 2 },
        Self::Normals,
        Self::Depth,
        Self::TraversalCost,
        Self::EntityIds,
        Self::LeafDepth,
    ];

    /// The core's view.
    pub fn to_core(self) -> spatial_accel::preview::PreviewMode {
        use spatial_accel::preview::PreviewMode as M;
        match self {
            Self::Shaded => M::Shaded,
            Self::AmbientOcclusion { samples, radius } => M::AmbientOcclusion { samples, radius },
            Self::PathTraced { max_bounces } => M::PathTraced { max_bounces },
            Self::Normals => M::Normals,
            Self::Depth => M::Depth,
            Self::TraversalCost => M::TraversalCost,
            Self::EntityIds => M::ObjectIds,
            Self::LeafDepth => M::LeafDepth,
        }
    }

    /// A short name for menus.
    pub fn name(self) -> &'static str {
        match self {
            Self::Shaded => "shaded",
            Self::AmbientOcclusion { .. } => "ambient occlusion",
            Self::PathTraced { .. } => "path traced",
            Self::Normals => "normals",
            Self::Depth => "depth",
            Self::TraversalCost => "traversal cost",
            Self::EntityIds => "entity ids",
            Self::LeafDepth => "leaf depth",
        }
    }
}

/// Where the preview image is shown.
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Default)]
pub enum PreviewPlacement {
    /// Over the whole view, in place of the raster image.
    #[default]
    Overlay,
    /// In the view's top-right quarter, beside the raster image.
    Corner,
}

/// Runtime settings of [`AccelPreviewPlugin`].
#[derive(Resource, Reflect, Clone, Debug, PartialEq)]
#[reflect(Resource, Default)]
pub struct AccelPreviewSettings {
    /// Whether the preview runs. Off, none of its systems but the key's run, and its image
    /// and camera are gone.
    pub enabled: bool,
    /// The key that switches it (`F2` by default; `None`: no key).
    pub toggle_key: Option<KeyCode>,
    /// What is drawn.
    pub mode: AccelPreviewMode,
    /// The image's size as a fraction of the view's, in `(0, 1]`.
    pub resolution_scale: f32,
    /// Wall time per frame the tracing may take, in milliseconds: the game stays
    /// interactive while the image refines.
    pub frame_budget_ms: f32,
    /// Samples per pixel after which the image stops refining (until something changes).
    pub max_samples: u32,
    /// Where the image is shown.
    pub placement: PreviewPlacement,
}

impl Default for AccelPreviewSettings {
    fn default() -> Self {
        Self {
            enabled: false,
            toggle_key: Some(KeyCode::F2),
            mode: AccelPreviewMode::default(),
            resolution_scale: 0.5,
            frame_budget_ms: 12.0,
            max_samples: 64,
            placement: PreviewPlacement::default(),
        }
    }
}

/// What the preview did in the last frame.
#[derive(Resource, Clone, Debug, Default)]
pub struct AccelPreviewStats {
    /// Image size in pixels.
    pub size: UVec2,
    /// Samples every pixel has (the image's least-sampled pixel).
    pub samples: u32,
    /// Pixel samples traced this frame.
    pub traced: u64,
    /// Wall time spent tracing this frame.
    pub time: Duration,
    /// Whether the image restarted this frame (the view or the scene changed).
    pub restarted: bool,
}

impl AccelPreviewStats {
    /// Tracing time per frame, in milliseconds.
    pub const TIME: DiagnosticPath = DiagnosticPath::const_new("bevy_accel/preview_time_ms");
}

/// The preview's systems: the key in `Update`, the tracing in `PostUpdate` after the trees
/// are up to date.
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct AccelPreviewSystems;

/// Traces the main view (the active 3D camera of lowest order) progressively on the CPU:
/// the entity trees are the top level, each entity's mesh BVH (built once per mesh asset,
/// shared with [`AccelPickingPlugin`](crate::AccelPickingPlugin)'s cache) the bottom. It
/// shades `StandardMaterial` base colours, textures and emission under directional, point
/// and spot lights with hard shadows, accumulates samples while nothing changes, and
/// restarts when the camera, a tracked entity, a light, a mesh, a material or the settings
/// change. Needs [`AccelPlugin`](crate::AccelPlugin) and [`AccelPickingPlugin`](crate::AccelPickingPlugin).
///
/// ```no_run
/// use bevy::prelude::*;
/// use bevy_accel::prelude::*;
/// App::new()
///     .add_plugins((DefaultPlugins, AccelPlugin::default(), AccelPickingPlugin))
///     .add_plugins(AccelPreviewPlugin)
///     .insert_resource(AccelPreviewSettings { enabled: true, ..default() })
///     .run();
/// ```
#[derive(Default)]
pub struct AccelPreviewPlugin;

impl Plugin for AccelPreviewPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<AccelPreviewSettings>()
            .init_resource::<AccelPreviewStats>()
            .init_resource::<trace::PreviewState>()
            .register_type::<AccelPreviewSettings>()
            .register_diagnostic(Diagnostic::new(AccelPreviewStats::TIME))
            .add_systems(Update, toggle_preview.in_set(AccelPreviewSystems))
            .add_systems(
                PostUpdate,
                (
                    trace::trace_preview
                        .run_if(|s: Res<AccelPreviewSettings>| s.enabled)
                        .run_if(resource_exists::<crate::AccelTrees>)
                        .run_if(resource_exists::<crate::picking::AccelMeshCache>),
                    display::place_display,
                )
                    .chain()
                    .in_set(AccelPreviewSystems)
                    .after(AccelSystems::Stats),
            );
    }

    fn finish(&self, app: &mut App) {
        crate::trees::step_aside::register_reader_plugin(app);
    }
}

fn toggle_preview(
    keys: Option<Res<ButtonInput<KeyCode>>>,
    mut settings: ResMut<AccelPreviewSettings>,
) {
    let pressed = match (keys, settings.toggle_key) {
        (Some(keys), Some(key)) => keys.just_pressed(key),
        _ => false,
    };
    if pressed {
        settings.enabled = !settings.enabled;
    }
}
