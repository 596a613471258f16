//! [`AccelSelectionSettings`]: the mode, the keys and the rules of the selection plugin.

use bevy::picking::mesh_picking::ray_cast::RayCastVisibility;
use bevy::prelude::*;
use spatial_accel::SelectionMode;

/// The order of a selection's results.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Reflect)]
#[reflect(Debug, Default, PartialEq, Hash)]
pub enum SelectionOrder {
    /// Sorted by entity: cheapest, and what set operations want.
    #[default]
    ByEntity,
    /// Nearest first, by the distance from the eye (or the sphere's centre) to each entity's
    /// world box; ties by entity.
    ByDistance,
}

/// Runtime settings of [`AccelSelectionPlugin`](super::AccelSelectionPlugin): what the mouse
/// and keys do, which [`SelectionMode`] a drag uses, and which entities may be selected (the
/// rules of the picking backend, so that what a click can pick a drag can select).
#[derive(Resource, Clone, Reflect)]
#[reflect(Resource, Default)]
pub struct AccelSelectionSettings {
    /// The mouse and keys select. Off, the input is ignored; [`AccelSelection`](super::AccelSelection)
    /// keeps working.
    pub enabled: bool,
    /// How a drag decides what its rectangle holds: by default the centre of each entity's
    /// world box, as strategy games select units.
    #[reflect(ignore)]
    pub mode: SelectionMode,
    /// The button that clicks and drags.
    pub button: MouseButton,
    /// Held with a click, toggles the entity; held with a drag, adds to the selection instead
    /// of replacing it. Either shift key by default.
    pub add_keys: Vec<KeyCode>,
    /// Clears the selection: Escape by default; `None` for no key.
    pub clear_key: Option<KeyCode>,
    /// How far (logical pixels) the pointer must move while pressed for a click to become a
    /// drag.
    pub drag_threshold: f32,
    /// Only entities with a `Pickable` can be selected (as the picking backend's
    /// `require_markers`); an entity whose `Pickable` is not hoverable never is.
    pub require_pickable: bool,
    /// Which entities a selection sees: by default those visible in some view, as picking.
    pub visibility: RayCastVisibility,
    /// Draw the dragged rectangle (with gizmos; cargo feature `overlays`).
    pub draw_rectangle: bool,
    /// The rectangle's colour.
    pub rectangle_color: Color,
}

impl Default for AccelSelectionSettings {
    fn default() -> Self {
        Self {
            enabled: true,
            mode: SelectionMode::Center,
            button: MouseButton::Left,
            add_keys: vec![KeyCode::ShiftLeft, KeyCode::ShiftRight],
            clear_key: Some(KeyCode::Escape),
            drag_threshold: 4.0,
            require_pickable: false,
            visibility: RayCastVisibility::VisibleInView,
            draw_rectangle: true,
            rectangle_color: Color::srgb(0.3, 0.9, 0.4),
        }
    }
}
