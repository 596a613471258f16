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

/// Sorts a view's list of visible entities, as Bevy's diff of `VisibleEntities` needs. Why not
/// `sort_unstable` alone: the lists come out of the culling as a few sorted runs (the tree's
/// finds in slot order, which follows Bevy's tables; then the entities outside the trees), and
/// the unstable sort is linear only on a single run; on two it sorts from scratch, several
/// times slower than the stable sort, which merges runs. On many runs the unstable sort is
/// the faster, so the runs are counted first (one pass).
pub(crate) fn sort_visible(list: &mut [Entity]) {
    /// Up to this many runs, merging them beats sorting from scratch.
    const MERGE_UP_TO_RUNS: usize = 8;
    let mut runs = 1;
    let mut rising: Option<bool> = None;
    for pair in list.windows(2) {
        let up = pair[0] <= pair[1];
        match rising {
            None => rising = Some(up),
            Some(r) if r != up => {
                // A run ends here; the next one's direction is set by its first pair.
                runs += 1;
                rising = None;
                if runs > MERGE_UP_TO_RUNS {
                    list.sort_unstable();
                    return;
                }
            }
            Some(_) => {}
        }
    }
    list.sort();
}

#[cfg(test)]
mod tests {
    use super::sort_visible;
    use bevy::prelude::Entity;

    fn entities(indices: impl IntoIterator<Item = u32>) -> Vec<Entity> {
        indices
            .into_iter()
            .map(|i| Entity::from_raw_u32(i).unwrap())
            .collect()
    }

    /// Every shape of input comes out sorted: one run either way, a few runs, many runs.
    #[test]
    fn sorts_runs_and_scrambles_alike() {
        let shapes: Vec<Vec<Entity>> = vec![
            entities(0..1000),
            entities((0..1000).rev()),
            entities((0..900).chain(950..1000).chain(900..950)),
            entities((0..1000).map(|i| (i * 7919) % 1000)),
            entities([]),
            entities([5]),
        ];
        for mut list in shapes {
            let mut want = list.clone();
            want.sort_unstable();
            sort_visible(&mut list);
            assert_eq!(list, want);
        }
    }
}
