//! The per-frame tracing: restart the image when anything it shows changed, trace as many
//! rows as the time budget allows across Bevy's compute task pool, and write the image
//! asset once.

use super::extract::PreviewWorld;
use super::scene::{EntityPreviewScene, PreviewObjects};
use super::{AccelPreviewSettings, AccelPreviewStats};
use bevy::asset::RenderAssetUsages;
use bevy::diagnostic::Diagnostics;
use bevy::image::Image;
use bevy::platform::collections::HashMap;
use bevy::prelude::*;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};
use bevy::tasks::ComputeTaskPool;
use spatial_accel::preview::{
    FrameBudget, PreviewImage, PreviewLight, PreviewSettings, PreviewTracer, Texture,
};
use std::sync::Arc;
use std::time::Instant;

/// The preview's image and what it was made from.
#[derive(Resource, Default)]
pub(crate) struct PreviewState {
    pub(super) image: PreviewImage,
    tracer: Option<PreviewTracer>,
    objects: PreviewObjects,
    textures: HashMap<AssetId<Image>, Option<Arc<Texture>>>,
    budget: FrameBudget,
    /// The image asset shown, sized as `image`.
    pub(super) handle: Option<Handle<Image>>,
    /// The camera traced last, and its view size.
    pub(super) view: Option<(Entity, UVec2)>,
    rgba: Vec<u8>,
    settings: Option<AccelPreviewSettings>,
}

/// Anything the image shows changed since the frame before: the objects' transforms and
/// visibility, meshes, materials and images (asset events).
type Moved = Or<(
    Changed<GlobalTransform>,
    Changed<InheritedVisibility>,
    Changed<Mesh3d>,
    Changed<MeshMaterial3d<StandardMaterial>>,
)>;

// A system's parameters are its dependencies; bundling them would only hide them.
#[allow(clippy::too_many_arguments)]
pub(super) fn trace_preview(
    settings: Res<AccelPreviewSettings>,
    world: PreviewWorld,
    moved: Query<(), (With<Mesh3d>, Moved)>,
    mut mesh_events: MessageReader<AssetEvent<Mesh>>,
    mut material_events: MessageReader<AssetEvent<StandardMaterial>>,
    mut image_events: MessageReader<AssetEvent<Image>>,
    mut images: ResMut<Assets<Image>>,
    mut state: ResMut<PreviewState>,
    mut stats: ResMut<AccelPreviewStats>,
    mut diagnostics: Diagnostics,
) {
    let start = Instant::now();
    let state = &mut *state;
    let Some(view) = world.view() else {
        return;
    };
    let camera_size = world
        .cameras
        .get(view.entity)
        .ok()
        .and_then(|(_, c, _, _)| c.physical_viewport_size())
        .unwrap_or(UVec2::new(640, 360));
    let scale = settings.resolution_scale.clamp(0.05, 1.0);
    let size = (camera_size.as_vec2() * scale)
        .round()
        .as_uvec2()
        .max(UVec2::ONE);
    let lights: Vec<PreviewLight> = world.lights();
    let assets_changed = mesh_events.read().count()
        + material_events.read().count()
        + image_events
            .read()
            .filter(|e| state.handle.as_ref().is_none_or(|h| event_id(e) != h.id()))
            .count()
        > 0;
    let restart = state.tracer.as_ref().is_none_or(|t| {
        t.camera != view.camera || t.lights != lights || t.settings.exposure != view.exposure
    }) || state.view != Some((view.entity, size))
        || state.settings.as_ref() != Some(&*settings)
        || world.trees.is_changed()
        || !moved.is_empty()
        // A posed entity moves with its joints, whose changes `moved` does not see.
        || !world.posed_targets.is_empty()
        || assets_changed;
    if restart {
        if assets_changed {
            state.textures.clear();
        }
        let materials = world.objects(&mut state.objects, &images, &mut state.textures);
        let mut tracer = PreviewTracer::new(view.camera, settings.mode.to_core());
        tracer.lights = lights;
        tracer.materials = materials;
        tracer.settings = PreviewSettings {
            ambient: world.ambient(),
            exposure: view.exposure,
            ..PreviewSettings::default()
        };
        state.tracer = Some(tracer);
        if state.view != Some((view.entity, size)) {
            state.image = PreviewImage::new(size.x, size.y);
            state.handle = Some(images.add(blank_image(size)));
        } else {
            state.image.restart();
        }
        state.view = Some((view.entity, size));
        state.settings = Some(settings.clone());
    }
    stats.restarted = restart;
    stats.size = size;
    stats.samples = state.image.min_samples();
    stats.traced = 0;
    if stats.samples < settings.max_samples
        && let Some(tracer) = &state.tracer
    {
        let pool = ComputeTaskPool::get_or_init(Default::default);
        let threads = pool.thread_num().max(1) as u32;
        let budget = std::time::Duration::from_secs_f32(settings.frame_budget_ms.max(0.0) / 1e3);
        let rows = state.budget.rows_for(budget, size.x, threads);
        let rows = state.image.next_rows(rows);
        let per_tile = rows.len().div_ceil(threads as usize).max(1) as u32;
        let scene = EntityPreviewScene {
            trees: &world.trees,
            objects: &state.objects,
        };
        let traced = (rows.len() as u64) * u64::from(size.x);
        let tiles = state.image.tiles(rows, per_tile);
        let times = pool.scope(|s| {
            for mut tile in tiles {
                let scene = &scene;
                s.spawn(async move {
                    let t = Instant::now();
                    tracer.trace_tile(scene, &mut tile);
                    t.elapsed()
                });
            }
        });
        state.budget.record(traced, times.iter().sum());
        // Counted as the trees' other ray users count theirs: the automatic index choice and
        // the BVH's ray snapshot follow the rays that walk the trees, and a preview frame
        // casts at least one a pixel.
        world
            .trees
            .count_rays(u32::try_from(traced).unwrap_or(u32::MAX));
        stats.traced = traced;
        tracer.resolve_rgba8(&state.image, &mut state.rgba);
        if let Some(mut image) = state.handle.as_ref().and_then(|h| images.get_mut(h)) {
            image.data = Some(std::mem::take(&mut state.rgba));
        }
    }
    stats.time = start.elapsed();
    let ms = stats.time.as_secs_f64() * 1e3;
    diagnostics.add_measurement(&AccelPreviewStats::TIME, || ms);
}

/// The asset an event is about.
fn event_id(event: &AssetEvent<Image>) -> AssetId<Image> {
    match *event {
        AssetEvent::Added { id }
        | AssetEvent::Modified { id }
        | AssetEvent::Removed { id }
        | AssetEvent::Unused { id }
        | AssetEvent::LoadedWithDependencies { id } => id,
    }
}

/// A transparent image of `size`, in the format the resolve writes.
fn blank_image(size: UVec2) -> Image {
    Image::new_fill(
        Extent3d {
            width: size.x,
            height: size.y,
            depth_or_array_layers: 1,
        },
        TextureDimension::D2,
        &[0, 0, 0, 0],
        TextureFormat::Rgba8UnormSrgb,
        RenderAssetUsages::RENDER_WORLD | RenderAssetUsages::MAIN_WORLD,
    )
}
