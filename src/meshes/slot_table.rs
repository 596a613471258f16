//! The mesh of each tree slot, kept beside the trees so that a ray's mesh test needs no ECS
//! read until it hits.
//!
//! Why: without it, a ray's candidate that passes its oriented-box test reads its entity's
//! location record, its `Mesh3d` row and its visibility rows before its mesh BVH can be
//! walked, and half of those walks miss. Those reads are most of a candidate's time; with the
//! mesh found by slot, the walks that miss cost no ECS read at all (BENCHMARKS.md, Picking).
//!
//! The price is upkeep: Bevy has no hook on a mutated `Mesh3d`, so the table is kept current
//! by a `Changed` scan over every mesh entity each frame.
//! That pays only when rays are many, so by default the table is kept only while rays per
//! frame outnumber the entities by a set ratio ([`SlotMeshTableMode::Auto`]).

use super::cache::{AccelMeshCache, MeshShape};
use crate::AccelTrees;
use crate::stats::AccelStats;
use bevy::asset::AssetId;
use bevy::ecs::entity::EntityHashSet;
use bevy::mesh::{Mesh2d, Mesh3d};
use bevy::picking::mesh_picking::ray_cast::{RayCastBackfaces, SimplifiedMesh};
use bevy::platform::collections::HashMap;
use bevy::prelude::*;
use std::sync::OnceLock;

/// When [`AccelRayCast`](crate::picking::AccelRayCast) finds a candidate's mesh through the slot mesh
/// table instead of the ECS (see [`AccelPickingSettings`](crate::picking::AccelPickingSettings)).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Reflect)]
#[reflect(Debug, Default, PartialEq)]
pub enum SlotMeshTableMode {
    /// Kept while rays per frame (averaged, see
    /// [`AccelStats::rays_per_frame`](crate::AccelStats)) reach
    /// [`AccelPickingSettings::slot_mesh_table_rays_per_entity`](crate::picking::AccelPickingSettings)
    /// times the tracked entities, and dropped below half that. A pointer or two per frame
    /// never pays for the table's upkeep; hundreds of rays per frame do. Switching it on
    /// costs one pass over the tracked entities, in that frame.
    #[default]
    Auto,
    /// Always kept: for scenes that cast many rays from the first frame.
    Always,
    /// Never kept: every candidate's mesh is read from the ECS.
    Never,
}

/// No mesh: the slot's entity has no `Mesh3d`, `Mesh2d` or `SimplifiedMesh`, so mesh ray
/// casts skip it.
const NO_MESH: u32 = u32::MAX;

/// One slot's entry: the entity it was written for, and that entity's mesh then.
#[derive(Clone, Copy, Debug)]
struct SlotMesh {
    /// The entry holds only while the slot's entity is this one (slots are reused).
    entity: Option<Entity>,
    /// Index into [`SlotMeshTable::meshes`], or [`NO_MESH`].
    mesh: u32,
    /// Back faces count (`RayCastBackfaces`, or a 2d mesh, whose back faces Bevy never culls).
    two_sided: bool,
    /// The entity has both `InheritedVisibility` and `ViewVisibility` (see
    /// [`SlotMeshLookup::Mesh::visibility_rows`]). Cleared at once when it loses either.
    visibility_rows: bool,
}

impl SlotMesh {
    const UNKNOWN: Self = Self {
        entity: None,
        mesh: NO_MESH,
        two_sided: false,
        visibility_rows: false,
    };
}

/// The mesh Bevy's ray cast tests for an entity (its `SimplifiedMesh`, else its `Mesh3d`, else
/// its `Mesh2d`), and whether back faces count (`RayCastBackfaces`, or a 2d mesh: Bevy never
/// culls those). `None` for an entity with none of the three.
pub(crate) fn ray_cast_mesh<'a>(
    mesh3d: Option<&'a Mesh3d>,
    mesh2d: Option<&'a Mesh2d>,
    simplified: Option<&'a SimplifiedMesh>,
    backfaces: bool,
) -> Option<(&'a Handle<Mesh>, bool)> {
    let handle = simplified
        .map(|m| &m.0)
        .or(mesh3d.map(|m| &m.0))
        .or(mesh2d.map(|m| &m.0))?;
    Some((handle, backfaces || mesh2d.is_some()))
}

/// What decides a slot's entry: the entity's ray-cast mesh and back-face rule (see
/// [`ray_cast_mesh`]; `None`: no mesh), and whether it has both visibility components.
#[derive(Clone, Copy, Debug)]
struct SlotMeshSource {
    mesh: Option<(AssetId<Mesh>, bool)>,
    visibility_rows: bool,
}

/// One mesh asset named by some slot, with its shape once a ray has needed it.
#[derive(Debug)]
pub(crate) struct MeshCell {
    id: AssetId<Mesh>,
    /// Filled from [`AccelMeshCache`] by the first ray that reaches the mesh; emptied when
    /// the asset changes.
    shape: OnceLock<MeshShape>,
}

impl MeshCell {
    /// The mesh's shape, built and cached on first use; `None` while the asset is not loaded
    /// (Bevy skips such meshes too).
    #[inline]
    pub(crate) fn shape(
        &self,
        cache: &AccelMeshCache,
        meshes: &Assets<Mesh>,
    ) -> Option<&MeshShape> {
        if let Some(shape) = self.shape.get() {
            return Some(shape);
        }
        let shape = cache.get_or_build(self.id, meshes)?;
        Some(self.shape.get_or_init(|| shape))
    }
}

/// What the table says of a candidate.
pub(crate) enum SlotMeshLookup<'a> {
    /// The entity has no mesh: a mesh ray skips it.
    NoMesh,
    /// The entity's mesh, and whether back faces count.
    Mesh {
        /// The mesh asset's cell.
        cell: &'a MeshCell,
        /// Back faces count.
        two_sided: bool,
        /// The entity has both visibility components, as Bevy's ray cast requires of what it
        /// hits. A ray cast whose [`RayCastVisibility`] is `Any` then needs no ECS read for
        /// a hit, and skips the wait for the entity's location and its two visibility rows.
        ///
        /// [`RayCastVisibility`]: bevy::picking::mesh_picking::ray_cast::RayCastVisibility
        visibility_rows: bool,
    },
}

/// Each tree slot's mesh, as of the last sync, for [`AccelRayCast`](crate::picking::AccelRayCast).
///
/// Kept by a system after the sync while [`AccelPickingSettings::slot_mesh_table`] says so
/// (see [`SlotMeshTableMode`]); empty otherwise, and ray casts then read meshes from the ECS.
/// An entry names the entity it was written for, so a slot handed to another entity is never
/// read for the new one before the table learns it. Like the trees' boxes, the table sees a
/// mesh handle changed after the sync from the next frame.
///
/// [`AccelPickingSettings::slot_mesh_table`]: crate::picking::AccelPickingSettings::slot_mesh_table
#[derive(Resource, Default)]
pub struct SlotMeshTable {
    active: bool,
    /// The [`AccelMeshCache::generation`] the cells' shapes were taken at.
    cache_generation: u64,
    by_slot: Vec<SlotMesh>,
    ids: HashMap<AssetId<Mesh>, u32>,
    meshes: Vec<MeshCell>,
}

impl SlotMeshTable {
    /// True while the table is kept and ray casts use it.
    pub fn is_active(&self) -> bool {
        self.active
    }

    /// Distinct mesh assets the table has named since it was last (re)filled.
    pub fn mesh_count(&self) -> usize {
        self.meshes.len()
    }

    /// True when the table holds an entry for `entity` in `slot` (ray casts then read no
    /// ECS data for it unless they hit its mesh). After each sync, every tracked entity has
    /// one while the table is on.
    pub fn has_entry(&self, slot: u32, entity: Entity) -> bool {
        self.by_slot
            .get(slot as usize)
            .is_some_and(|e| e.entity == Some(entity))
    }

    /// Asks for `slot`'s entry ahead of its [`SlotMeshTable::lookup`]. A hint only.
    #[inline]
    pub(crate) fn prefetch(&self, slot: u32) {
        if let Some(entry) = self.by_slot.get(slot as usize) {
            spatial_accel::prefetch::prefetch(entry);
        }
    }

    /// What the table says of the entity in `slot`; `None` when it has no entry for that
    /// entity (the table is off, or the slot changed hands after the last sync).
    #[inline]
    pub(crate) fn lookup(&self, slot: u32, entity: Entity) -> Option<SlotMeshLookup<'_>> {
        let entry = self.by_slot.get(slot as usize)?;
        if entry.entity != Some(entity) {
            return None;
        }
        Some(match self.meshes.get(entry.mesh as usize) {
            None => SlotMeshLookup::NoMesh,
            Some(cell) => SlotMeshLookup::Mesh {
                cell,
                two_sided: entry.two_sided,
                visibility_rows: entry.visibility_rows,
            },
        })
    }

    /// Forgets every cell's shape when entries were dropped from the cache since the cells
    /// took theirs ([`AccelMeshCache::generation`]): they are taken again as rays need them.
    /// Called every frame, whether the plugin is on or off, since asset edits go on either way.
    pub(crate) fn follow_cache(&mut self, cache: &AccelMeshCache) {
        if self.cache_generation != cache.generation() {
            self.cache_generation = cache.generation();
            for cell in &mut self.meshes {
                cell.shape = OnceLock::new();
            }
        }
    }

    /// Empties the table and switches it off.
    fn deactivate(&mut self) {
        self.active = false;
        self.by_slot = Vec::new();
        self.ids.clear();
        self.meshes.clear();
    }

    /// Writes the entry of `slot`, now held by `entity`, from what its components say.
    fn write(&mut self, slot: u32, entity: Entity, source: SlotMeshSource) {
        let (mesh, two_sided) = match source.mesh {
            None => (NO_MESH, false),
            Some((id, two_sided)) => {
                let next = self.meshes.len() as u32;
                let index = *self.ids.entry(id).or_insert(next);
                if index == next {
                    self.meshes.push(MeshCell {
                        id,
                        shape: OnceLock::new(),
                    });
                }
                (index, two_sided)
            }
        };
        let slot = slot as usize;
        if self.by_slot.len() <= slot {
            self.by_slot.resize(slot + 1, SlotMesh::UNKNOWN);
        }
        self.by_slot[slot] = SlotMesh {
            entity: Some(entity),
            mesh,
            two_sided,
            visibility_rows: source.visibility_rows,
        };
    }

    /// Notes that the entity in `slot` lost a visibility component.
    fn forget_visibility_rows(&mut self, slot: u32, entity: Entity) {
        if let Some(entry) = self.by_slot.get_mut(slot as usize)
            && entry.entity == Some(entity)
        {
            entry.visibility_rows = false;
        }
    }
}

/// What decides a slot's entry (see [`SlotMeshSource`]).
type MeshComponentsQuery = (
    Option<&'static Mesh3d>,
    Option<&'static Mesh2d>,
    Option<&'static SimplifiedMesh>,
    Has<RayCastBackfaces>,
    Has<InheritedVisibility>,
    Has<ViewVisibility>,
);

/// Entities that lost a mesh component (or `RayCastBackfaces`) since the last refresh: a
/// removal marks nothing `Changed`, so observers queue them.
#[derive(Resource, Default)]
pub(crate) struct PendingSlotMeshes(EntityHashSet);

/// Queues an entity that lost a component its slot's entry depends on.
fn queue_removed_mesh(
    event: On<Remove, (Mesh3d, Mesh2d, SimplifiedMesh, RayCastBackfaces)>,
    table: Res<SlotMeshTable>,
    mut pending: ResMut<PendingSlotMeshes>,
) {
    // A despawn removes every component: while the table is off, queue nothing.
    if table.active {
        pending.0.insert(event.event_target());
    }
}

/// Clears the entry's visibility flag of an entity that lost a visibility component, in
/// the observer rather than at the next refresh: a ray cast later in the same frame must not
/// hit what Bevy's ray cast can no longer hit. (Gaining them back needs no hook: an entry
/// without the flag reads the rows, which are then found.)
fn forget_removed_visibility(
    event: On<Remove, (InheritedVisibility, ViewVisibility)>,
    trees: Res<AccelTrees>,
    mut table: ResMut<SlotMeshTable>,
) {
    if !table.active {
        return;
    }
    let entity = event.event_target();
    if let Some((slot, _)) = trees.tracked_location(entity) {
        table.forget_visibility_rows(slot, entity);
    }
}

/// Registers the removal observers that keep entries current between refreshes.
pub(crate) fn add_slot_mesh_observers(app: &mut App) {
    app.add_observer(queue_removed_mesh);
    app.add_observer(forget_removed_visibility);
}

/// Whether [`keep_slot_mesh_table`] has work this frame: the table is wanted, or still
/// active and to be let go. A run condition, checked by the executor: in the common frame of
/// a few rays, no task is spawned for the table.
pub(crate) fn slot_mesh_table_in_use(
    settings: Res<crate::picking::AccelPickingSettings>,
    stats: Res<AccelStats>,
    trees: Res<AccelTrees>,
    table: Res<SlotMeshTable>,
) -> bool {
    table.active
        || wanted(
            settings.slot_mesh_table,
            settings.slot_mesh_table_rays_per_entity,
            table.active,
            stats.rays_per_frame,
            trees.len(),
        )
}

/// Whether the table should be kept this frame.
fn wanted(
    mode: SlotMeshTableMode,
    rays_per_entity: f32,
    active: bool,
    rays_per_frame: f32,
    entities: usize,
) -> bool {
    match mode {
        SlotMeshTableMode::Always => true,
        SlotMeshTableMode::Never => false,
        SlotMeshTableMode::Auto => {
            // Hysteresis: a frame or two of fewer rays does not throw away a table whose
            // refill costs a pass over every tracked entity.
            let needed = rays_per_entity * entities as f32 * if active { 0.5 } else { 1.0 };
            entities > 0 && rays_per_frame >= needed
        }
    }
}

/// The changes the table follows: mesh handles set or mutated, `RayCastBackfaces` added.
type ChangedMeshFilter = Or<(
    Changed<Mesh3d>,
    Changed<Mesh2d>,
    Changed<SimplifiedMesh>,
    Changed<RayCastBackfaces>,
)>;

/// Keeps the [`SlotMeshTable`] current: fills it when it is switched on, then rewrites the
/// entries of slots handed to new entities, of entities whose mesh components changed, and
/// of those that lost one. Runs after the sync, so slots are this frame's.
pub(crate) fn keep_slot_mesh_table(
    settings: Res<crate::picking::AccelPickingSettings>,
    stats: Res<AccelStats>,
    trees: Res<AccelTrees>,
    mut table: ResMut<SlotMeshTable>,
    mut pending: ResMut<PendingSlotMeshes>,
    components: Query<MeshComponentsQuery>,
    changed: Query<Entity, ChangedMeshFilter>,
) {
    let keep = wanted(
        settings.slot_mesh_table,
        settings.slot_mesh_table_rays_per_entity,
        table.active,
        stats.rays_per_frame,
        trees.len(),
    );
    if !keep {
        if table.active {
            table.deactivate();
            pending.0.clear();
        }
        return;
    }
    let entry_of = |entity: Entity| {
        let Ok((mesh3d, mesh2d, simplified, backfaces, inherited, view)) = components.get(entity)
        else {
            return SlotMeshSource {
                mesh: None,
                visibility_rows: false,
            };
        };
        SlotMeshSource {
            mesh: ray_cast_mesh(mesh3d, mesh2d, simplified, backfaces)
                .map(|(h, two)| (h.id(), two)),
            visibility_rows: inherited && view,
        }
    };
    if !table.active {
        // Anything may have changed since the table was last kept: fill it from scratch.
        table.active = true;
        for (entity, slot) in trees.iter() {
            table.write(slot, entity, entry_of(entity));
        }
        pending.0.clear();
        return;
    }
    let refresh = |table: &mut SlotMeshTable, entity: Entity| {
        if let Some((slot, _)) = trees.tracked_location(entity) {
            table.write(slot, entity, entry_of(entity));
        }
    };
    for &slot in trees.assigned_slots() {
        if let Some(entity) = trees.entity(slot) {
            table.write(slot, entity, entry_of(entity));
        }
    }
    for entity in pending.0.drain() {
        refresh(&mut table, entity);
    }
    for entity in &changed {
        refresh(&mut table, entity);
    }
}

#[cfg(test)]
mod tests {
    use super::{SlotMeshTableMode, wanted};

    #[test]
    fn auto_keeps_the_table_only_while_rays_pay_for_it() {
        let auto = |active, rays| wanted(SlotMeshTableMode::Auto, 0.01, active, rays, 10_000);
        assert!(!auto(false, 99.0), "below the ratio: not switched on");
        assert!(auto(false, 100.0), "at the ratio: switched on");
        assert!(auto(true, 60.0), "kept above half the ratio");
        assert!(!auto(true, 49.0), "dropped below half of it");
        assert!(!wanted(SlotMeshTableMode::Auto, 0.01, false, 5.0, 0));
        assert!(wanted(SlotMeshTableMode::Always, 0.01, false, 0.0, 10));
        assert!(!wanted(SlotMeshTableMode::Never, 0.01, true, 1e9, 10));
    }
}
