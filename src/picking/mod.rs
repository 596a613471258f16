//! Picking on the trees: a `bevy_picking` backend ([`AccelPickingPlugin`]) and a ray-cast
//! system parameter ([`AccelRayCast`]) that answer what Bevy's `MeshPickingPlugin` and
//! `MeshRayCast` answer, without testing every entity and every triangle per ray.
//!
//! Bevy's mesh ray cast inverts every entity's transform to test its box, then scans every
//! triangle of each candidate (bevy issue 15817 and the notes in this repository). Here the
//! [`AccelTrees`] give the candidates in distance order, nearest blocking
//! hits cut the search, and each mesh asset has a triangle BVH built the first time a ray
//! reaches it ([`AccelMeshCache`]). While rays are many, a [`SlotMeshTable`] gives each
//! candidate's mesh by tree slot, so the ECS is read only for the meshes a ray hits.

mod backend;
mod posed_pass;
mod ray_cast;
#[cfg(feature = "sprite_picking")]
mod sprites;
mod stats;

pub use crate::meshes::{
    AccelMeshCache, AccelPosedMeshes, CachedMesh, MeshShape, SkinnedShape, SlotMeshTable,
    SlotMeshTableMode,
};
pub use backend::{AccelHitExtra, update_hits};
pub use ray_cast::AccelRayCast;
#[cfg(feature = "sprite_picking")]
pub use sprites::{
    AccelSpritePickingMode, AccelSpritePickingPlugin, AccelSpritePickingSettings,
    update_sprite_hits,
};
pub use stats::AccelPickingStats;
pub(crate) use stats::add_picking_measurements;

use crate::meshes;

use crate::{AccelSettings, AccelSystems, AccelTrees};
use bevy::asset::AssetEventSystems;
use bevy::mesh::morph::MeshMorphWeights;
use bevy::mesh::skinning::SkinnedMesh;
use bevy::picking::PickingSystems;
use bevy::picking::backend::PointerHits;
use bevy::picking::backend::ray::RayMap;
use bevy::picking::mesh_picking::ray_cast::RayCastVisibility;
use bevy::prelude::*;

/// The picking systems: the backends in bevy_picking's `PickingSystems::Backend` (in
/// `PreUpdate`), and the upkeep of the mesh cache and the slot mesh table in `PostUpdate`.
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct AccelPickingSystems;

/// Marks the cameras the backend casts from when [`AccelPickingSettings::require_markers`]
/// is set (ignored otherwise).
#[derive(Debug, Clone, Copy, Default, Component, Reflect)]
#[reflect(Debug, Default, Component)]
pub struct AccelPickingCamera;

/// Runtime settings of the [`AccelPickingPlugin`] backend (those of Bevy's
/// `MeshPickingSettings`, which this backend does not read; likewise it looks for
/// [`AccelPickingCamera`], not `MeshPickingCamera`).
#[derive(Resource, Clone, Reflect)]
#[reflect(Resource, Default)]
pub struct AccelPickingSettings {
    /// The backend casts pointer rays. Off, it reports no hits (other backends still do);
    /// [`AccelRayCast`] keeps working.
    pub enabled: bool,
    /// Only cameras with [`AccelPickingCamera`] cast, and only entities with `Pickable` are
    /// hit. `false` by default.
    pub require_markers: bool,
    /// Which entities rays see: by default only those visible in a view
    /// ([`RayCastVisibility::VisibleInView`]), as Bevy's backend.
    pub ray_cast_visibility: RayCastVisibility,
    /// When ray casts find a candidate's mesh through the [`SlotMeshTable`] (no ECS read for
    /// the meshes a ray misses) rather than the ECS: by default while rays are many (see
    /// [`SlotMeshTableMode::Auto`]).
    pub slot_mesh_table: SlotMeshTableMode,
    /// Under [`SlotMeshTableMode::Auto`], the rays per frame, per tracked entity, from which
    /// the table is kept: `1/300` by default. Keeping it costs a scan of every mesh entity's
    /// change ticks each frame, and it saves time on every ray cast; the default is where the
    /// two meet on the picking bench (BENCHMARKS.md, Picking).
    pub slot_mesh_table_rays_per_entity: f32,
}

impl Default for AccelPickingSettings {
    fn default() -> Self {
        Self {
            enabled: true,
            require_markers: false,
            ray_cast_visibility: RayCastVisibility::VisibleInView,
            slot_mesh_table: SlotMeshTableMode::Auto,
            slot_mesh_table_rays_per_entity: 1.0 / 300.0,
        }
    }
}

/// The picking backend on the trees, in place of Bevy's `MeshPickingPlugin` (add one or the
/// other, not both, or every mesh is reported twice). Reads `RayMap`, writes `PointerHits` in
/// `PickingSystems::Backend`, honouring `Pickable`, `RenderLayers`, camera order,
/// [`AccelPickingSettings`] and `RayCastBackfaces`/`SimplifiedMesh`. Each `HitData` carries
/// the world position, the normal and an [`AccelHitExtra`] (triangle, barycentrics, uv).
///
/// Also sets up [`AccelRayCast`] (its mesh cache). Requires [`AccelPlugin`](crate::AccelPlugin)
/// and Bevy's `PickingPlugin` (in `DefaultPlugins`) for the backend.
///
/// ```no_run
/// use bevy::prelude::*;
/// use bevy_accel::prelude::*;
///
/// App::new()
///     .add_plugins((DefaultPlugins, AccelPlugin::default(), AccelPickingPlugin))
///     .add_systems(Startup, |mut commands: Commands, mut meshes: ResMut<Assets<Mesh>>| {
///         commands.spawn(Camera3d::default());
///         // Picked through the trees: the usual bevy_picking events follow.
///         commands
///             .spawn((Mesh3d(meshes.add(Cuboid::default())), Transform::from_xyz(0.0, 0.0, -4.0)))
///             .observe(|click: On<Pointer<Click>>| info!("clicked {}", click.entity));
///     })
///     .run();
/// ```
#[derive(Default)]
pub struct AccelPickingPlugin;

impl Plugin for AccelPickingPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<AccelPickingSettings>()
            .init_resource::<AccelPickingStats>()
            .init_resource::<AccelMeshCache>()
            .init_resource::<AccelPosedMeshes>()
            .init_resource::<SlotMeshTable>()
            .init_resource::<meshes::PendingSlotMeshes>()
            .register_type::<AccelPickingSettings>()
            .register_type::<SlotMeshTableMode>()
            .register_type::<AccelPickingCamera>()
            .add_systems(
                PostUpdate,
                meshes::invalidate_changed_meshes
                    .in_set(AccelPickingSystems)
                    .after(AssetEventSystems)
                    .run_if(resource_exists::<Assets<Mesh>>)
                    // Checked by the executor, so a frame without mesh edits spawns no task.
                    .run_if(on_message::<AssetEvent<Mesh>>),
            )
            .add_systems(
                PostUpdate,
                meshes::keep_slot_mesh_table
                    .in_set(AccelPickingSystems)
                    .after(AccelSystems::Maintain)
                    .after(meshes::invalidate_changed_meshes)
                    .before(AccelSystems::Stats)
                    // The trees stand still while the plugin is off, and so does the table.
                    .run_if(resource_exists::<AccelTrees>)
                    .run_if(|s: Option<Res<AccelSettings>>| s.is_some_and(|s| s.enabled))
                    .run_if(meshes::slot_mesh_table_in_use),
            )
            .add_systems(
                PostUpdate,
                posed_pass::watch_posed_meshes
                    .in_set(AccelPickingSystems)
                    .run_if(
                        any_with_component::<SkinnedMesh>
                            .or_else(any_with_component::<MeshMorphWeights>),
                    ),
            )
            .add_systems(
                PreUpdate,
                backend::update_hits
                    .in_set(PickingSystems::Backend)
                    .in_set(AccelPickingSystems)
                    // Without Bevy's picking plugins (or AccelPlugin) there is nothing to read
                    // or write: stay idle instead of failing parameter validation.
                    .run_if(resource_exists::<AccelTrees>)
                    .run_if(resource_exists::<Assets<Mesh>>)
                    .run_if(resource_exists::<RayMap>)
                    .run_if(resource_exists::<Messages<PointerHits>>),
            );
        meshes::add_slot_mesh_observers(app);
        app.add_observer(meshes::forget_unposed)
            .add_observer(posed_pass::first_pass_changed)
            .add_observer(posed_pass::first_pass_lost);
    }

    fn finish(&self, app: &mut App) {
        // Ray casts read the trees; without them the backend stays idle, so say why once.
        if !app.world().contains_resource::<AccelTrees>() {
            warn!("AccelPickingPlugin needs AccelPlugin: add it, or nothing will be picked");
        }
        crate::trees::step_aside::register_reader_plugin(app);
    }
}
