//! Visible entities gathered per visibility class, before they go into `VisibleEntities`.

use bevy::camera::visibility::{VisibilityClass, VisibleEntities};
use bevy::prelude::*;
use core::any::TypeId;

/// Visible entities per visibility class for one view, before they go into its
/// `VisibleEntities`. Why not push into `VisibleEntities` directly: that is a hash lookup per
/// entity and class, where a world has a handful of classes.
#[derive(Default)]
pub(crate) struct ClassLists(Vec<(TypeId, Vec<Entity>)>);

impl ClassLists {
    #[inline]
    pub(crate) fn push(&mut self, class: &VisibilityClass, entity: Entity) {
        for id in class.iter() {
            match self.0.iter_mut().find(|(c, _)| c == id) {
                Some((_, list)) => list.push(entity),
                None => self.0.push((*id, vec![entity])),
            }
        }
    }

    /// Appends `other`'s lists after this one's, class by class, emptying `other`.
    pub(crate) fn append_from(&mut self, other: &mut ClassLists) {
        for (class, list) in &mut other.0 {
            match self.0.iter_mut().find(|(c, _)| c == class) {
                Some((_, mine)) => mine.append(list),
                None => self.0.push((*class, core::mem::take(list))),
            }
        }
    }

    /// Moves the lists into the view's `VisibleEntities`, keeping their allocations here.
    pub(crate) fn flush_into(&mut self, visible_entities: &mut VisibleEntities) {
        for (class, list) in &mut self.0 {
            if !list.is_empty() {
                visible_entities.get_mut(*class).append(list);
            }
        }
    }
}
