//! [`Selected`]: the mark of a selected entity, and the event a change of selection triggers.

use bevy::prelude::*;

/// Marks a selected entity. The selection plugin inserts and removes it; code may too.
/// Observe its lifecycle to react to each entity: `On<Add, Selected>` when an entity is
/// selected, `On<Remove, Selected>` when it is deselected (or despawned while selected).
///
/// Stored in a sparse set, as Bevy advises for a marker added and removed often: a drag
/// selects or deselects tens of thousands of entities at once, and in a table each insert or
/// removal would move the entity's every component to another table.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq, Reflect)]
#[component(storage = "SparseSet")]
#[reflect(Component, Default, Debug)]
pub struct Selected;

/// Triggered (a global observer event) after each change the mouse or the keys made to the
/// selection, once per change, however many entities it touched.
#[derive(Event, Clone, Copy, Debug, PartialEq, Eq)]
pub struct SelectionChanged {
    /// Entities newly selected.
    pub added: usize,
    /// Entities deselected.
    pub removed: usize,
    /// The camera through which the change was made (`None` for the clear key).
    pub camera: Option<Entity>,
}
