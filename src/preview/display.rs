//! The preview image on screen: a sprite drawn by a camera of its own over the main view.

use super::trace::PreviewState;
use super::{AccelPreviewSettings, PreviewPlacement};
use bevy::camera::visibility::RenderLayers;
use bevy::camera::{ClearColorConfig, Viewport};
use bevy::prelude::*;

/// The render layer of the preview's sprite and camera: the main view does not draw it.
pub const PREVIEW_RENDER_LAYER: usize = 31;

/// Marks the camera and the sprite that show the preview.
#[derive(Component)]
pub(super) struct PreviewDisplay;

/// The preview's sprite (or camera) entity.
type DisplayItem = (
    Entity,
    Option<&'static mut Sprite>,
    Option<&'static mut Camera>,
);

/// Spawns the preview's camera and sprite while it runs, despawns them when it stops, and
/// keeps the sprite on the current image at the placement's size.
pub(super) fn place_display(
    mut commands: Commands,
    settings: Res<AccelPreviewSettings>,
    state: Res<PreviewState>,
    cameras: Query<&Camera, Without<PreviewDisplay>>,
    mut shown: Query<DisplayItem, With<PreviewDisplay>>,
) {
    let Some((handle, (view, _))) = state
        .handle
        .clone()
        .zip(state.view)
        .filter(|_| settings.enabled)
    else {
        for (entity, _, _) in &shown {
            commands.entity(entity).despawn();
        }
        return;
    };
    let Ok(main) = cameras.get(view) else {
        return;
    };
    let (Some(rect), Some(physical)) =
        (main.logical_viewport_rect(), main.physical_viewport_rect())
    else {
        return;
    };
    let (size, viewport) = match settings.placement {
        PreviewPlacement::Overlay => (rect.size(), physical),
        PreviewPlacement::Corner => {
            let half = physical.size() / 2;
            let corner = URect::from_corners(
                UVec2::new(physical.max.x - half.x, physical.min.y),
                UVec2::new(physical.max.x, physical.min.y + half.y),
            );
            (rect.size() / 2.0, corner)
        }
    };
    let viewport = Viewport {
        physical_position: viewport.min,
        physical_size: viewport.size().max(UVec2::ONE),
        ..default()
    };
    if shown.is_empty() {
        commands.spawn((
            Camera2d,
            Camera {
                // Above the main view and anything the app draws over it.
                order: main.order + 1_000,
                clear_color: ClearColorConfig::None,
                viewport: Some(viewport),
                ..default()
            },
            RenderLayers::layer(PREVIEW_RENDER_LAYER),
            PreviewDisplay,
        ));
        commands.spawn((
            Sprite {
                image: handle,
                custom_size: Some(size),
                ..default()
            },
            RenderLayers::layer(PREVIEW_RENDER_LAYER),
            PreviewDisplay,
        ));
        return;
    }
    for (_, sprite, camera) in &mut shown {
        if let Some(mut sprite) = sprite
            && (sprite.image != handle || sprite.custom_size != Some(size))
        {
            sprite.image = handle.clone();
            sprite.custom_size = Some(size);
        }
        let same = |v: &Viewport| {
            (v.physical_position, v.physical_size)
                == (viewport.physical_position, viewport.physical_size)
        };
        if let Some(mut camera) = camera
            && !camera.viewport.as_ref().is_some_and(same)
        {
            camera.viewport = Some(viewport.clone());
        }
    }
}
