//! Deciding entities straight from the columns of Bevy's tables, reached through the row each
//! entity was last seen in instead of an entity lookup.

use super::view_pass::{BoundsItem, DecideFilter, DecideItem};
use crate::culling::bevy_rules::{ViewFilter, bevy_frustum_test};
use crate::culling::class_lists::ClassLists;
use crate::culling::slot_order::prefetch_entry;
use bevy::camera::primitives::{Aabb, Frustum, Sphere};
use bevy::camera::visibility::{NoCpuCulling, RenderLayers, SetViewVisibility, VisibilityClass};
use bevy::ecs::change_detection::{ContiguousMut, MaybeLocation, Tick};
use bevy::ecs::entity::Entities;
use bevy::prelude::*;
use core::marker::PhantomData;
use core::panic::Location;
use spatial_accel::prefetch::{prefetch, prefetch_ptr};

/// Where an entity's components were last found: a table (by `TableId`) and a row in it.
///
/// Why remember it: deciding an entity through a query looks its location up in Bevy's entity
/// records (a cache miss per entity, the records being 32 MB at 1M entities) and then sets the
/// query up for its table, each time. A remembered row is checked with one read of the
/// table's entity column, which is read anyway when neighbours are decided. Rows move when an
/// entity changes archetype or a neighbour is despawned; the check catches that, and the row
/// is looked up again.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct RowHint {
    table: u32,
    row: u32,
}

impl RowHint {
    /// No row known: the first decision looks it up.
    pub(crate) const UNKNOWN: Self = Self {
        table: u32::MAX,
        row: u32::MAX,
    };
}

/// An entity a tree walk found in a view, with its tree slot, its row hint, and whether its
/// leaf crosses a plane of the view (it then gets Bevy's frustum test; a tree proved the
/// others inside).
#[derive(Clone, Copy, Debug)]
pub(crate) struct FoundEntity {
    pub(crate) entity: Entity,
    pub(crate) slot: u32,
    pub(crate) hint: RowHint,
    pub(crate) exact: bool,
}

impl FoundEntity {
    /// A place in a list, to be filled.
    pub(crate) const VACANT: Self = Self {
        entity: Entity::PLACEHOLDER,
        slot: u32::MAX,
        hint: RowHint::UNKNOWN,
        exact: false,
    };

    /// A tree slot found by a walk, `exact` if its leaf crosses a plane, with the entity and
    /// row hint the slot has now (a free slot gets `Entity::PLACEHOLDER`, which no decision
    /// finds).
    #[inline]
    pub(crate) fn of_slot(
        slot: u32,
        exact: bool,
        slot_entities: &[Option<Entity>],
        slot_rows: &SlotRows,
    ) -> Self {
        Self {
            entity: slot_entities
                .get(slot as usize)
                .copied()
                .flatten()
                .unwrap_or(Entity::PLACEHOLDER),
            slot,
            hint: slot_rows.get(slot),
            exact,
        }
    }
}

/// The row hint of each tree slot's entity, shared by every view, so that a walk made afresh
/// (a moving camera) starts from the rows the last frame found.
#[derive(Default)]
pub(crate) struct SlotRows(Vec<RowHint>);

impl SlotRows {
    /// The hint for `slot`'s entity ([`RowHint::UNKNOWN`] if none was kept).
    #[inline]
    pub(crate) fn get(&self, slot: u32) -> RowHint {
        self.0
            .get(slot as usize)
            .copied()
            .unwrap_or(RowHint::UNKNOWN)
    }

    /// Asks for the cache line of `slot`'s hint.
    #[inline]
    pub(crate) fn prefetch(&self, slot: u32) {
        prefetch_entry(&self.0, slot);
    }

    /// Keeps the hints of `found`.
    pub(crate) fn remember(&mut self, found: &[FoundEntity]) {
        for item in found {
            let i = item.slot as usize;
            if self.0.len() <= i {
                self.0.resize(i + 1, RowHint::UNKNOWN);
            }
            self.0[i] = item.hint;
        }
    }
}

/// Per-table values found by `TableId`: the tables a query matches, in its order.
struct ByTable<T> {
    tables: Vec<T>,
    /// Index into `tables` by `TableId`; `u32::MAX` for tables the query does not match.
    position_by_table: Vec<u32>,
}

impl<T> ByTable<T> {
    fn new() -> Self {
        Self {
            tables: Vec::new(),
            position_by_table: Vec::new(),
        }
    }

    /// Adds the values of the table holding `first`, its first entity (a table the entity
    /// records do not place is skipped).
    fn push(&mut self, first: Option<&Entity>, entities: &Entities, values: T) {
        let Some(location) = first.and_then(|e| entities.get(*e).ok().flatten()) else {
            return;
        };
        let table = location.table_id.as_usize();
        if self.position_by_table.len() <= table {
            self.position_by_table.resize(table + 1, u32::MAX);
        }
        self.position_by_table[table] = self.tables.len() as u32;
        self.tables.push(values);
    }

    #[inline]
    fn at(&self, hint: RowHint) -> Option<&T> {
        let position = *self.position_by_table.get(hint.table as usize)?;
        self.tables.get(position as usize)
    }
}

/// One table's columns of what a decision reads and writes.
struct TableColumns<'q> {
    entities: &'q [Entity],
    inherited: &'q [InheritedVisibility],
    class: Option<&'q [VisibilityClass]>,
    layers: Option<&'q [RenderLayers]>,
    has_range: bool,
    /// `ViewVisibility` and its ticks: written only at rows of the entities being decided.
    visibility: *mut ViewVisibility,
    added: *mut Tick,
    changed: *mut Tick,
    changed_by: MaybeLocation<*mut &'static Location<'static>>,
}

/// The deciding query's tables, as columns, for one view's decisions.
///
/// Created from the query borrowed mutably for `'q`, so no other use of it overlaps. Shared
/// between threads that decide disjoint lists of entities: each row of `ViewVisibility` is
/// written by the thread deciding the one entity that row holds.
pub(crate) struct DecideColumns<'q> {
    tables: ByTable<TableColumns<'q>>,
    /// Whether the view sees entities without `RenderLayers` (those on layer 0).
    default_layers_seen: bool,
    last_run: Tick,
    this_run: Tick,
    _query: PhantomData<&'q mut ()>,
}

// SAFETY: the raw column pointers are written only through `decide`, at the row of the entity
// being decided; callers decide each entity on one thread (the lists handed to threads are
// disjoint, and an entity has one row), so no row is written from two threads.
unsafe impl Sync for DecideColumns<'_> {}

impl<'q> DecideColumns<'q> {
    /// The query's tables as columns, for deciding entities for `filter`'s view; `None` if
    /// the query cannot be read contiguously (it always can: every component it names is
    /// stored in tables).
    pub(crate) fn gather(
        query: &'q mut Query<DecideItem, DecideFilter>,
        entities: &Entities,
        filter: ViewFilter<'_>,
    ) -> Option<Self> {
        let mut tables = ByTable::new();
        let (mut last_run, mut this_run) = (Tick::new(0), Tick::new(0));
        for (ids, inherited, visibility, class, layers, has_range) in
            query.contiguous_iter_mut().ok()?
        {
            last_run = visibility.last_run_tick();
            this_run = visibility.this_run_tick();
            // Not `split`, which marks the whole column changed: `set_visible` below writes
            // the ticks of the rows it changes, as Bevy's own `Mut` does.
            let (values, mut ticks) = ContiguousMut::bypass_change_detection_split(visibility);
            let columns = TableColumns {
                entities: ids,
                inherited,
                class,
                layers,
                has_range,
                visibility: values.as_mut_ptr(),
                added: ticks.added_mut().as_mut_ptr(),
                changed: ticks.changed_mut().as_mut_ptr(),
                changed_by: ticks.changed_by_mut().map(<[_]>::as_mut_ptr),
            };
            tables.push(ids.first(), entities, columns);
        }
        Some(Self {
            tables,
            default_layers_seen: filter.in_layers(None),
            last_run,
            this_run,
            _query: PhantomData,
        })
    }

    #[inline]
    fn table_at(&self, hint: RowHint) -> Option<&TableColumns<'q>> {
        self.tables.at(hint)
    }

    /// Asks for the cache lines that deciding the entity at `hint` will read.
    #[inline]
    pub(crate) fn prefetch_row(&self, hint: RowHint) {
        let Some(table) = self.table_at(hint) else {
            return;
        };
        let row = hint.row as usize;
        let Some(id) = table.entities.get(row) else {
            return;
        };
        prefetch(id);
        prefetch(&table.inherited[row]);
        prefetch_ptr(table.visibility.wrapping_add(row));
        if let Some(class) = table.class {
            prefetch(&class[row]);
        }
    }

    /// The table and row holding `item`'s entity: its hint if the hint still holds, else
    /// looked up (and the hint replaced; `refreshed` counts replacements). `None` if the entity
    /// is gone or the query does not match it. An entity the query does not match keeps the
    /// hint of its real row, so that it is looked up each time but not counted each time (a
    /// count makes the caller store every hint of the list again).
    #[inline]
    fn locate(
        &self,
        item: &mut FoundEntity,
        entities: &Entities,
        refreshed: &mut usize,
    ) -> Option<(&TableColumns<'q>, usize)> {
        if let Some(table) = self.table_at(item.hint)
            && table.entities.get(item.hint.row as usize) == Some(&item.entity)
        {
            return Some((table, item.hint.row as usize));
        }
        let location = entities.get(item.entity).ok().flatten()?;
        let hint = RowHint {
            table: location.table_id.as_u32(),
            row: location.table_row.index_u32(),
        };
        if hint != item.hint {
            item.hint = hint;
            *refreshed += 1;
        }
        let table = self.table_at(item.hint)?;
        (table.entities.get(item.hint.row as usize) == Some(&item.entity))
            .then_some((table, item.hint.row as usize))
    }

    /// Decides `item`'s entity as Bevy's culling does: its hierarchy visibility, layers and
    /// range, then, if the item is `exact`, Bevy's frustum test on its bounds. If visible,
    /// sets its `ViewVisibility` through Bevy's `set_visible` and pushes it into `lists`.
    #[inline]
    pub(crate) fn decide(
        &self,
        item: &mut FoundEntity,
        filter: ViewFilter<'_>,
        exact: ExactTest<'_, '_>,
        entities: &Entities,
        lists: &mut ClassLists,
        tally: &mut DecideTally,
    ) {
        let Some((table, row)) = self.locate(item, entities, &mut tally.refreshed) else {
            return;
        };
        let entity = item.entity;
        if !table.inherited[row].get() {
            return;
        }
        let in_layers = match table.layers {
            Some(layers) => filter.in_layers(Some(&layers[row])),
            None => self.default_layers_seen,
        };
        if !filter.admits_in_layers(entity, in_layers, table.has_range) {
            return;
        }
        if item.exact {
            // The bounds query matches every table the deciding one does (it filters less);
            // were it not to, Bevy's query would skip the entity too.
            let Some(bounds) = exact.bounds.table_at(item.hint) else {
                return;
            };
            tally.tested += 1;
            let aabb = bounds.aabb.map(|aabb| &aabb[row]);
            let sphere = bounds.sphere.map(|sphere| &sphere[row]);
            if !bevy_frustum_test(exact.frustum, aabb, sphere, &bounds.transform[row]) {
                return;
            }
        }
        // SAFETY: `row` is in range (its entity column entry was just read), the columns are
        // the query's own, borrowed mutably for `'q`, and no other thread decides this entity
        // (see the `Sync` impl), so these are the only references to this row's value and ticks.
        let mut visibility = unsafe {
            Mut::new(
                &mut *table.visibility.add(row),
                &mut *table.added.add(row),
                &mut *table.changed.add(row),
                self.last_run,
                self.this_run,
                table.changed_by.map(|by| &mut *by.add(row)),
            )
        };
        visibility.set_visible();
        tally.visible += 1;
        tally.accepted += usize::from(!item.exact);
        if let Some(class) = table.class {
            lists.push(&class[row], entity);
        }
    }
}

/// What deciding a list of entities did.
#[derive(Clone, Copy, Default)]
pub(crate) struct DecideTally {
    /// Entities found visible.
    pub(crate) visible: usize,
    /// Of those, entities a tree proved inside (no frustum test).
    pub(crate) accepted: usize,
    /// Entities given Bevy's frustum test.
    pub(crate) tested: usize,
    /// Row hints that no longer held and were looked up again.
    pub(crate) refreshed: usize,
}

impl DecideTally {
    /// Both tallies added.
    pub(crate) fn add(self, other: Self) -> Self {
        Self {
            visible: self.visible + other.visible,
            accepted: self.accepted + other.accepted,
            tested: self.tested + other.tested,
            refreshed: self.refreshed + other.refreshed,
        }
    }
}

/// Bevy's frustum test for entities whose leaf crosses a plane of the view.
#[derive(Clone, Copy)]
pub(crate) struct ExactTest<'a, 'q> {
    pub(crate) frustum: &'a Frustum,
    pub(crate) bounds: &'a BoundsColumns<'q>,
}

/// One table's columns of what Bevy's frustum test reads.
struct BoundsTable<'q> {
    aabb: Option<&'q [Aabb]>,
    sphere: Option<&'q [Sphere]>,
    transform: &'q [GlobalTransform],
}

/// The bounds query's tables, as columns, found by the same row hints as [`DecideColumns`]
/// (a row is a row of the whole table, whichever query reads it).
pub(crate) struct BoundsColumns<'q>(ByTable<BoundsTable<'q>>);

impl<'q> BoundsColumns<'q> {
    /// The query's tables as columns; `None` if the query cannot be read contiguously (it
    /// always can: every component it names is stored in tables).
    pub(crate) fn gather(
        query: &'q Query<BoundsItem, Without<NoCpuCulling>>,
        entities: &Entities,
    ) -> Option<Self> {
        let mut tables = ByTable::new();
        for (ids, aabb, sphere, transform) in query.contiguous_iter().ok()? {
            let columns = BoundsTable {
                aabb,
                sphere,
                transform,
            };
            tables.push(ids.first(), entities, columns);
        }
        Some(Self(tables))
    }

    #[inline]
    fn table_at(&self, hint: RowHint) -> Option<&BoundsTable<'q>> {
        self.0.at(hint)
    }

    /// Asks for the cache lines of the bounds at `hint`.
    #[inline]
    pub(crate) fn prefetch_row(&self, hint: RowHint) {
        if let Some(table) = self.table_at(hint)
            && let Some(transform) = table.transform.get(hint.row as usize)
        {
            prefetch(transform);
            if let Some(aabb) = table.aabb {
                prefetch(&aabb[hint.row as usize]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::view_pass::{BoundsItem, DecideFilter, DecideItem};
    use super::{DecideColumns, DecideTally, ExactTest, FoundEntity, RowHint};
    use crate::culling::bevy_rules::ViewFilter;
    use crate::culling::class_lists::ClassLists;
    use bevy::camera::primitives::Frustum;
    use bevy::camera::visibility::{NoCpuCulling, NoFrustumCulling, RenderLayers};
    use bevy::ecs::entity::Entities;
    use bevy::ecs::system::SystemState;
    use bevy::prelude::*;

    #[derive(Component)]
    struct Moved;

    type Params = (
        Query<'static, 'static, DecideItem, DecideFilter>,
        Query<'static, 'static, BoundsItem, Without<NoCpuCulling>>,
        &'static Entities,
    );

    /// Decides every item once; returns the tally and which entities were visible.
    fn decide_all(world: &mut World, items: &mut [FoundEntity]) -> (DecideTally, Vec<Entity>) {
        let mut state = SystemState::<Params>::new(world);
        let (mut deciding, bounds, entities) = state.get_mut(world).unwrap();
        let mask = RenderLayers::default();
        let filter = ViewFilter {
            view: None,
            mask: &mask,
            ranges: None,
        };
        let bounds = super::BoundsColumns::gather(&bounds, entities).unwrap();
        let frustum = Frustum::default();
        let columns = DecideColumns::gather(&mut deciding, entities, filter).unwrap();
        let exact = ExactTest {
            frustum: &frustum,
            bounds: &bounds,
        };
        let (mut lists, mut tally) = (ClassLists::default(), DecideTally::default());
        for item in items.iter_mut() {
            columns.decide(item, filter, exact, entities, &mut lists, &mut tally);
        }
        drop(columns);
        let mut visible: Vec<Entity> = deciding
            .iter()
            .filter(|(_, _, v, ..)| v.get())
            .map(|(e, ..)| e)
            .collect();
        visible.sort();
        (tally, visible)
    }

    /// Rows are found again after entities change tables; an entity the query does not match
    /// is never decided and does not count as a replaced hint once its hint is its real row.
    #[test]
    fn hints_follow_moved_rows_and_settle_for_unmatched_entities() {
        let mut world = World::new();
        let spawned: Vec<Entity> = (0..6)
            .map(|_| {
                world
                    .spawn((
                        InheritedVisibility::VISIBLE,
                        ViewVisibility::HIDDEN,
                        GlobalTransform::default(),
                    ))
                    .id()
            })
            .collect();
        world.entity_mut(spawned[5]).insert(NoFrustumCulling);
        let mut expected = spawned[..5].to_vec();
        expected.sort();
        let mut items: Vec<FoundEntity> = spawned
            .iter()
            .enumerate()
            .map(|(slot, &entity)| FoundEntity {
                entity,
                slot: slot as u32,
                hint: RowHint::UNKNOWN,
                exact: false,
            })
            .collect();
        let (tally, visible) = decide_all(&mut world, &mut items);
        assert_eq!((tally.visible, tally.refreshed), (5, 6));
        assert_eq!(visible, expected);
        // Moving entity 1 to another table moves the last row of its table into its place.
        world.entity_mut(spawned[1]).insert(Moved);
        for &entity in &spawned {
            world.entity_mut(entity).insert(ViewVisibility::HIDDEN);
        }
        let (tally, visible) = decide_all(&mut world, &mut items);
        assert_eq!(tally.visible, 5);
        assert_eq!(visible, expected);
        // Entity 1 and the one moved into its row (entity 4) are looked up again.
        assert_eq!(tally.refreshed, 2);
        let (tally, _) = decide_all(&mut world, &mut items);
        assert_eq!((tally.visible, tally.refreshed), (5, 0));
    }
}
