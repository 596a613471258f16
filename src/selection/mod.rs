//! Selecting many entities: [`AccelSelectionPlugin`] (click, shift-click, drag a box, the
//! clear key) marks them [`Selected`]; [`AccelSelection`] selects by rectangle, frustum or
//! sphere in any system. Both find their candidates through the trees: a box over a million
//! units tests the units near the box, not every unit (BENCHMARKS.md, Selection).
//!
//! ```
//! use bevy::prelude::*;
//! use bevy_accel::prelude::*;
//!
//! let mut app = App::new();
//! app.add_plugins((MinimalPlugins, TransformPlugin, AccelPlugin::default()))
//!     .add_plugins(AccelSelectionPlugin)
//!     .insert_resource(AccelSelectionSettings {
//!         mode: SelectionMode::Enclosed,
//!         ..default()
//!     })
//!     .add_observer(|added: On<Add, Selected>| info!("{} selected", added.entity))
//!     .add_observer(|removed: On<Remove, Selected>| info!("{} deselected", removed.entity));
//! app.update();
//! ```

mod box_query;
mod input;
mod selected;
mod settings;
mod system_param;

pub use input::AccelSelectionDrag;
pub use selected::{Selected, SelectionChanged};
pub use settings::{AccelSelectionSettings, SelectionOrder};
pub use spatial_accel::SelectionMode;
pub use system_param::{AccelSelection, SelectionError};

use crate::AccelTrees;
use bevy::prelude::*;

/// The selection systems: the input in `Update` (on the trees as the last frame's sync left
/// them, which is what the screen shows), the rectangle's drawing after it.
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct AccelSelectionSystems;

/// Selection with the mouse: a click selects the entity under the pointer (the nearest
/// picking hit the rules allow), a click with shift toggles it, a drag selects what its
/// rectangle holds on release (by [`AccelSelectionSettings::mode`]; with shift, added to the
/// selection), the clear key (Escape) deselects all; a press over an egui panel selects
/// nothing. Selected entities carry [`Selected`]; observe `On<Add, Selected>` and
/// `On<Remove, Selected>`, or [`SelectionChanged`] once per change.
///
/// The rules are the picking backend's: `Pickable`, the camera's `RenderLayers`, the
/// visibility setting and the camera's viewport (see [`AccelSelection`]). Requires
/// [`AccelPlugin`](crate::AccelPlugin); clicks need a picking backend (such as
/// [`AccelPickingPlugin`](crate::AccelPickingPlugin)) for their hits, and the touching mode
/// its mesh cache for the triangles.
///
/// ```no_run
/// use bevy::prelude::*;
/// use bevy_accel::prelude::*;
///
/// App::new()
///     .add_plugins((DefaultPlugins, AccelPlugins))
///     // Every selected unit in red.
///     .add_systems(Update, |units: Query<&GlobalTransform, With<Selected>>, mut gizmos: Gizmos| {
///         for unit in &units {
///             gizmos.sphere(unit.translation(), 0.6, Color::srgb(1.0, 0.2, 0.2));
///         }
///     })
///     .run();
/// ```
#[derive(Default)]
pub struct AccelSelectionPlugin;

impl Plugin for AccelSelectionPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<AccelSelectionSettings>()
            .init_resource::<AccelSelectionDrag>()
            .register_type::<AccelSelectionSettings>()
            .register_type::<SelectionOrder>()
            .register_type::<Selected>()
            .add_systems(
                Update,
                input::selection_input
                    .in_set(AccelSelectionSystems)
                    .run_if(resource_exists::<AccelTrees>),
            );
        #[cfg(feature = "overlays")]
        app.add_systems(
            Update,
            input::draw_rectangle
                .in_set(AccelSelectionSystems)
                .after(input::selection_input)
                .run_if(resource_exists::<bevy::gizmos::config::GizmoConfigStore>),
        );
    }

    fn finish(&self, app: &mut App) {
        if !app.world().contains_resource::<AccelTrees>() {
            warn!("AccelSelectionPlugin needs AccelPlugin: add it, or nothing will be selected");
        }
        crate::trees::step_aside::register_reader_plugin(app);
    }
}
