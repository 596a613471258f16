//! Debug overlays: what the trees hold and decide, drawn with gizmos.
//!
//! [`AccelOverlaysPlugin`] (cargo feature `overlays`) draws, each toggled at run time in
//! [`AccelOverlaySettings`]: the nodes of the static tree and of the dynamic index by depth,
//! coloured by level; the tracked entities' world boxes coloured by the verdict of a chosen
//! view (Bevy's own `Aabb` gizmos skip culled entities, which is the one thing a culling
//! overlay must show); that view's frustum, for seeing it from another camera; and, with the
//! `picking` feature, the pointers' rays with their hit, normal and the nodes they pass
//! through. Everything goes to one gizmo group, [`AccelGizmos`], whose line width and depth
//! bias the app sets as for any group.
//!
//! Why a line budget: a million entities or nodes would stall the frame in line building
//! alone. Each frame draws at most [`AccelOverlaySettings::line_budget`] lines: rays first,
//! then the frustum, the entity boxes nearest the view first, then tree levels shallowest
//! first; [`AccelOverlayStats::truncated`] says when something was left out.
//!
//! An overlay that is off costs its run condition only: its system does not run.

mod budget;
mod entity_bounds;
mod frustum;
#[cfg(feature = "picking")]
mod picking_rays;
mod tree_nodes;

pub use budget::AccelOverlayStats;

use crate::AccelSystems;
use bevy::camera::visibility::VisibilitySystems;
use bevy::prelude::*;
use budget::LineBudget;

/// The gizmo group every overlay draws in: set its line width or depth test through
/// `GizmoConfigStore` as for any group.
#[derive(Default, Reflect, GizmoConfigGroup)]
pub struct AccelGizmos;

/// What the overlays draw. A resource: change it at run time.
#[derive(Resource, Reflect, Clone, Debug, PartialEq)]
#[reflect(Resource, Default)]
pub struct AccelOverlaySettings {
    /// Nodes of the dynamic index, by depth (each structure's own nodes: the BVH's boxes, the
    /// octree's loose cells, the grid's occupied cells).
    pub dynamic_nodes: bool,
    /// Nodes of the static tree, by depth.
    pub static_nodes: bool,
    /// The shallowest tree level drawn (0 is the root).
    pub min_depth: u32,
    /// The deepest tree level drawn.
    pub max_depth: u32,
    /// The tracked entities' world boxes, coloured by the culling view's verdict.
    pub entity_bounds: bool,
    /// The camera whose verdicts colour the boxes and whose frustum is drawn; `None` takes the
    /// first active camera by order.
    pub culling_view: Option<Entity>,
    /// The culling view's frustum (far plane at infinity drawn at the trees' extent).
    pub frustum: bool,
    /// The pointers' picking rays, with their first hit, its normal, and the tree nodes the
    /// ray passes through (needs the `picking` feature and
    /// [`AccelPickingPlugin`](crate::AccelPickingPlugin)).
    pub picking_rays: bool,
    /// Lines drawn per frame at most, over all overlays.
    pub line_budget: usize,
}

impl Default for AccelOverlaySettings {
    fn default() -> Self {
        Self {
            dynamic_nodes: false,
            static_nodes: false,
            min_depth: 0,
            max_depth: 8,
            entity_bounds: false,
            culling_view: None,
            frustum: false,
            picking_rays: false,
            line_budget: 60_000,
        }
    }
}

impl AccelOverlaySettings {
    /// Every overlay on.
    pub fn all() -> Self {
        Self {
            dynamic_nodes: true,
            static_nodes: true,
            entity_bounds: true,
            frustum: true,
            picking_rays: true,
            ..default()
        }
    }

    fn any(&self) -> bool {
        self.dynamic_nodes
            || self.static_nodes
            || self.entity_bounds
            || self.frustum
            || self.picking_rays
    }
}

/// The overlays' systems, in `PostUpdate` after the visibility checks (so the boxes show this
/// frame's verdicts).
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct AccelOverlaySystems;

/// Draws the debug overlays of [`AccelOverlaySettings`]; needs [`AccelPlugin`](crate::AccelPlugin)
/// and Bevy's gizmos (`GizmoPlugin`, in `DefaultPlugins`).
///
/// ```no_run
/// use bevy::prelude::*;
/// use bevy_accel::prelude::*;
///
/// App::new()
///     .add_plugins((DefaultPlugins, AccelPlugin::default(), AccelOverlaysPlugin))
///     .insert_resource(AccelOverlaySettings { entity_bounds: true, ..default() })
///     .run();
/// ```
pub struct AccelOverlaysPlugin;

impl Plugin for AccelOverlaysPlugin {
    fn build(&self, app: &mut App) {
        app.init_gizmo_group::<AccelGizmos>()
            .register_type::<AccelOverlaySettings>()
            .init_resource::<AccelOverlaySettings>()
            .init_resource::<AccelOverlayStats>()
            .init_resource::<LineBudget>()
            .configure_sets(
                PostUpdate,
                AccelOverlaySystems
                    .after(VisibilitySystems::CheckVisibility)
                    .after(AccelSystems::Stats)
                    .run_if(|s: Res<AccelOverlaySettings>| s.any()),
            );
        let on =
            |pick: fn(&AccelOverlaySettings) -> bool| move |s: Res<AccelOverlaySettings>| pick(&s);
        app.add_systems(
            PostUpdate,
            (
                budget::start_frame,
                #[cfg(feature = "picking")]
                picking_rays::draw_picking_rays.run_if(
                    on(|s| s.picking_rays)
                        .and_then(resource_exists::<crate::picking::AccelMeshCache>),
                ),
                frustum::draw_culling_frustum.run_if(on(|s| s.frustum)),
                entity_bounds::draw_entity_bounds.run_if(on(|s| s.entity_bounds)),
                tree_nodes::draw_tree_nodes.run_if(on(|s| s.dynamic_nodes || s.static_nodes)),
                budget::publish_stats,
            )
                .chain()
                .in_set(AccelOverlaySystems),
        );
        // Stats of a frame with every overlay off say so.
        app.add_systems(
            PostUpdate,
            budget::clear_stats
                .run_if(|s: Res<AccelOverlaySettings>| !s.any())
                .after(VisibilitySystems::CheckVisibility),
        );
    }

    fn finish(&self, app: &mut App) {
        crate::trees::step_aside::register_reader_plugin(app);
    }
}

/// The camera the settings name, or the first active one by order.
pub(crate) fn culling_view<'a>(
    settings: &AccelOverlaySettings,
    cameras: impl Iterator<Item = (Entity, &'a Camera)>,
) -> Option<Entity> {
    let mut active: Vec<(isize, Entity)> = cameras
        .filter(|(e, c)| c.is_active && settings.culling_view.is_none_or(|v| v == *e))
        .map(|(e, c)| (c.order, e))
        .collect();
    active.sort_unstable();
    active.first().map(|&(_, e)| e)
}

/// The colour of tree level `depth`: hues around the wheel, a level apart by a fifth of it so
/// that neighbours differ; static levels darker than dynamic ones.
pub(crate) fn level_color(depth: u32, is_static: bool) -> Color {
    let hue = (depth as f32 * 72.0 + if is_static { 36.0 } else { 0.0 }) % 360.0;
    let lightness = if is_static { 0.40 } else { 0.60 };
    Color::hsl(hue, 0.9, lightness)
}
