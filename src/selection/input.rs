//! The mouse and keys: a click selects what the pointer is over, shift-click toggles it, a
//! drag selects what its rectangle holds on release (shift adds), the clear key deselects
//! all. And the dragged rectangle, drawn with gizmos (cargo feature `overlays`).

use super::selected::{Selected, SelectionChanged};
use super::settings::{AccelSelectionSettings, SelectionOrder};
use super::system_param::AccelSelection;
use bevy::camera::RenderTarget;
use bevy::picking::hover::HoverMap;
use bevy::picking::pointer::{PointerId, PointerLocation};
use bevy::prelude::*;
use bevy::window::PrimaryWindow;
use spatial_accel::sort::sort_keys;

/// The drag in progress: where the button went down, through which camera, and where the
/// pointer is now. Read it to draw the rectangle yourself.
#[derive(Resource, Clone, Copy, Debug, Default)]
pub struct AccelSelectionDrag {
    /// The camera under the pointer at the press, and the press position (logical pixels of
    /// its render target), while the button is held.
    pub start: Option<(Entity, Vec2)>,
    /// The pointer's last position.
    pub current: Vec2,
    /// The pointer moved past the drag threshold since the press: the release selects a
    /// rectangle, not a click.
    pub dragging: bool,
}

impl AccelSelectionDrag {
    /// The camera and the rectangle dragged so far, once the press became a drag.
    pub fn rectangle(&self) -> Option<(Entity, Rect)> {
        let (camera, start) = self.start?;
        self.dragging
            .then(|| (camera, Rect::from_corners(start, self.current)))
    }
}

/// Whether egui has the pointer (cargo feature `egui`): a press over a panel selects nothing.
#[cfg(feature = "egui")]
type PointerOverUi<'w> = Option<Res<'w, bevy_egui::input::EguiWantsInput>>;
#[cfg(not(feature = "egui"))]
type PointerOverUi<'w> = ();

#[cfg(feature = "egui")]
fn over_ui(ui: &PointerOverUi) -> bool {
    ui.as_ref().is_some_and(|u| u.wants_any_pointer_input())
}
#[cfg(not(feature = "egui"))]
fn over_ui(_: &PointerOverUi) -> bool {
    false
}

/// Reads the mouse and keys and changes the selection.
// A system's parameters are its dependencies; bundling them would only hide them.
#[allow(clippy::too_many_arguments)]
pub(crate) fn selection_input(
    mut commands: Commands,
    settings: Res<AccelSelectionSettings>,
    buttons: Option<Res<ButtonInput<MouseButton>>>,
    keys: Option<Res<ButtonInput<KeyCode>>>,
    pointers: Query<(&PointerId, &PointerLocation)>,
    cameras: Query<(Entity, &Camera, &RenderTarget)>,
    primary: Query<Entity, With<PrimaryWindow>>,
    hover: Option<Res<HoverMap>>,
    selected: Query<Entity, With<Selected>>,
    mut drag: ResMut<AccelSelectionDrag>,
    mut selection: AccelSelection,
    ui: PointerOverUi,
) {
    if !settings.enabled {
        drag.start = None;
        return;
    }
    let keys = keys.as_deref();
    let adding = keys.is_some_and(|k| k.any_pressed(settings.add_keys.iter().copied()));
    if let (Some(k), Some(clear)) = (keys, settings.clear_key)
        && k.just_pressed(clear)
    {
        apply(&mut commands, &selected, &[], true, None);
        drag.start = None;
        return;
    }
    let Some(buttons) = buttons else {
        return;
    };
    let location = pointers
        .iter()
        .find(|(id, _)| **id == PointerId::Mouse)
        .and_then(|(_, at)| at.location.clone());
    if buttons.just_pressed(settings.button) && !over_ui(&ui) {
        // The camera that draws where the pointer is: the last drawn (highest order) wins,
        // as the picking backends order their hits.
        let camera = location.as_ref().and_then(|at| {
            cameras
                .iter()
                .filter(|(_, c, target)| c.is_active && at.is_in_viewport(c, target, &primary))
                .max_by_key(|(_, c, _)| c.order)
                .map(|(e, _, _)| (e, at.position))
        });
        drag.start = camera;
        drag.current = camera.map_or(Vec2::ZERO, |(_, p)| p);
        drag.dragging = false;
    }
    let Some((camera, start)) = drag.start else {
        return;
    };
    if let Some(at) = &location {
        drag.current = at.position;
    }
    if drag.current.distance(start) > settings.drag_threshold {
        drag.dragging = true;
    }
    if buttons.pressed(settings.button) {
        return;
    }
    drag.start = None;
    if drag.dragging {
        match selection.in_rect(
            camera,
            start,
            drag.current,
            settings.mode,
            SelectionOrder::ByEntity,
        ) {
            Ok(found) => apply(&mut commands, &selected, found, !adding, Some(camera)),
            Err(error) => warn_once!("bevy_accel selection: {error}; the drag selected nothing"),
        }
        return;
    }
    // A click: the nearest hovered entity that the rules allow through this camera.
    let layers = selection.camera_layers(camera);
    let clicked = hover
        .as_deref()
        .and_then(|h| h.get(&PointerId::Mouse))
        .and_then(|hits| {
            hits.iter()
                .filter(|(e, hit)| {
                    hit.camera == camera
                        && selection.trees().contains(**e)
                        && selection.passes(**e, Some(&layers))
                })
                .min_by(|a, b| a.1.depth.total_cmp(&b.1.depth).then(a.0.cmp(b.0)))
                .map(|(e, _)| *e)
        });
    match (clicked, adding) {
        (Some(entity), true) => {
            let on = selected.contains(entity);
            if on {
                commands.entity(entity).try_remove::<Selected>();
            } else {
                commands.entity(entity).try_insert(Selected);
            }
            commands.trigger(SelectionChanged {
                added: usize::from(!on),
                removed: usize::from(on),
                camera: Some(camera),
            });
        }
        (Some(entity), false) => apply(&mut commands, &selected, &[entity], true, Some(camera)),
        (None, true) => {}
        (None, false) => apply(&mut commands, &selected, &[], true, Some(camera)),
    }
}

/// Selects `found` (sorted by entity); with `replace`, deselects everything else.
fn apply(
    commands: &mut Commands,
    selected: &Query<Entity, With<Selected>>,
    found: &[Entity],
    replace: bool,
    camera: Option<Entity>,
) {
    // The selection as it stands, sorted, merged with `found` in one pass: asking the query
    // about each found entity and searching `found` for each selected one would cost a
    // random lookup a unit, and a drag can select tens of thousands (BENCHMARKS.md,
    // Selection).
    let mut current: Vec<u64> = selected.iter().map(Entity::to_bits).collect();
    sort_keys(&mut current);
    let (mut batch, mut gone) = (Vec::new(), Vec::new());
    let (mut old, mut new) = (current.iter().peekable(), found.iter().peekable());
    loop {
        match (old.peek(), new.peek()) {
            (Some(&&o), Some(&&n)) if o == n.to_bits() => {
                old.next();
                new.next();
            }
            (Some(&&o), Some(&&n)) if o > n.to_bits() => {
                batch.push((n, Selected));
                new.next();
            }
            (Some(&&o), _) => {
                old.next();
                if replace && let Some(entity) = Entity::try_from_bits(o) {
                    gone.push(entity);
                }
            }
            (None, Some(&&n)) => {
                batch.push((n, Selected));
                new.next();
            }
            (None, None) => break,
        }
    }
    // One command for every removal: a command each would add its queueing and dispatch to
    // each removal, and replacing a selection removes tens of thousands.
    let removed = gone.len();
    if removed > 0 {
        commands.queue(move |world: &mut World| {
            for entity in gone {
                if let Ok(mut entity) = world.get_entity_mut(entity) {
                    entity.remove::<Selected>();
                }
            }
        });
    }
    // One batch: Bevy moves each archetype's entities together, where one command per
    // entity would look every move up again.
    let added = batch.len();
    if added > 0 {
        commands.try_insert_batch(batch);
    }
    if added + removed > 0 {
        commands.trigger(SelectionChanged {
            added,
            removed,
            camera,
        });
    }
}

/// Draws the dragged rectangle just past the camera's near plane.
#[cfg(feature = "overlays")]
pub(crate) fn draw_rectangle(
    settings: Res<AccelSelectionSettings>,
    drag: Res<AccelSelectionDrag>,
    cameras: Query<(&Camera, &GlobalTransform)>,
    mut gizmos: Gizmos,
) {
    let Some((camera, rect)) = drag.rectangle() else {
        return;
    };
    let Ok((cam, transform)) = cameras.get(camera) else {
        return;
    };
    let corners = [
        rect.min,
        Vec2::new(rect.max.x, rect.min.y),
        rect.max,
        Vec2::new(rect.min.x, rect.max.y),
    ];
    // On each corner's ray, a hair past the near plane, so that nothing in the scene is in
    // front of the lines.
    let points: Option<Vec<Vec3>> = corners
        .iter()
        .map(|&c| {
            let ray = cam.viewport_to_world(transform, c).ok()?;
            Some(ray.origin + *ray.direction * 0.01)
        })
        .collect();
    if let Some(points) = points {
        gizmos.linestrip(
            points.iter().copied().chain(points.first().copied()),
            settings.rectangle_color,
        );
    }
}
