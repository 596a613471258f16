//! A view's last tree walk, kept for the next frame.

use super::table_rows::FoundEntity;
use bevy::math::Vec4;

/// What a view's walk of the trees found, with the frustum it walked.
///
/// Why keep it: the walk and the slot ordering after it are a large part of the tree path
/// (BENCHMARKS.md, Culling), and when neither the view's
/// frustum nor the trees changed since the last frame they would find the same entities in
/// the same order. Only the walk is kept: every entity is still decided each frame (its
/// visibility, layers and range can change without the trees changing), as Bevy requires
/// `ViewVisibility` to be set again every frame. When only busy movers moved (the index held
/// still), the finds in the static tree and the dynamic index still hold, and only the busy
/// movers are tested again: a still camera over a world of a few busy movers would otherwise
/// walk and sort its whole view each frame.
#[derive(Default)]
pub(crate) struct ViewWalk {
    /// The planes walked, compared bit for bit.
    planes: Option<[Vec4; 6]>,
    /// The form the finds were kept in.
    form: WalkForm,
    /// The entities found, with their row hints and whether their leaf crosses a plane
    /// ([`WalkForm::Lists`]): the first [`Self::found_in_trees`] from the static tree and
    /// the dynamic index, then the busy movers', each run in slot order.
    pub(crate) found: Vec<FoundEntity>,
    /// How many of `found` the static tree and the dynamic index gave.
    pub(crate) found_in_trees: usize,
    /// Whether the busy movers' finds are of their current boxes ([`WalkForm::Lists`]; a
    /// walk in bit form never holds busy movers).
    busy_movers_current: bool,
    /// Tree slots a tree proved inside ([`WalkForm::Bits`]).
    pub(crate) inside_bits: SlotBits,
    /// Tree slots whose leaf crosses a plane ([`WalkForm::Bits`]).
    pub(crate) crossing_bits: SlotBits,
}

/// How a walk's finds are kept: as lists for the tree path, which decides exactly those
/// entities, or as sets for the flat pass, which meets every entity in table order and asks
/// of each whether a tree already settled its frustum test.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) enum WalkForm {
    #[default]
    Lists,
    Bits,
}

/// What of a view's last walk still holds for a frustum.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum WalkStill {
    /// All of it: the same planes in the same form, and nothing it found changed since.
    Holds,
    /// The finds in the static tree and the dynamic index, not the busy movers' (they
    /// moved; the index did not).
    HoldsInTrees,
    /// Nothing: another frustum or form, or the index changed. Walk afresh.
    Stale,
}

impl ViewWalk {
    /// Whether this walk was of exactly these planes, kept in this form (and has not been
    /// forgotten), and with what of it still holds.
    pub(crate) fn still(&self, planes: &[Vec4; 6], form: WalkForm) -> WalkStill {
        let same = self.form == form
            && self.planes.is_some_and(|p| {
                p.iter()
                    .zip(planes)
                    .all(|(a, b)| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits))
            });
        match (same, self.busy_movers_current) {
            (false, _) => WalkStill::Stale,
            (true, true) => WalkStill::Holds,
            (true, false) => WalkStill::HoldsInTrees,
        }
    }

    /// Starts a new walk of `planes`, kept in `form`: forgets what the last one found.
    /// (`found` is not emptied: a walk in list form rewrites it in place, see
    /// `decide_found`, and one in bit form never reads it.)
    pub(crate) fn restart(&mut self, planes: [Vec4; 6], form: WalkForm) {
        self.planes = Some(planes);
        self.form = form;
        self.found_in_trees = 0;
        self.busy_movers_current = true;
        self.inside_bits.clear();
        self.crossing_bits.clear();
    }

    /// Notes that the busy movers' finds were made again, for their current boxes.
    pub(crate) fn busy_movers_walked(&mut self) {
        self.busy_movers_current = true;
    }

    /// Forgets the walk (the index changed).
    pub(crate) fn forget(&mut self) {
        self.planes = None;
    }

    /// Forgets the busy movers' finds: for a frame in which only the busy movers changed.
    /// The finds in the index hold, since it did not change. A walk in bit form holds none
    /// (the flat pass asks no verdict of busy movers, see `TreeVerdicts`).
    pub(crate) fn forget_busy_movers(&mut self) {
        if self.form == WalkForm::Lists {
            self.busy_movers_current = false;
        }
    }
}

/// A set of tree slots, one bit each. Why slots, not entities: the walk emits slots in tree
/// order, random in the entity index, and an entity lookup per slot cost a random read each
/// (a million per walk of a view over 1M entities); the flat pass meets entities in table
/// order and reads their slot anyway, to know whether the trees hold them. A walk is kept
/// only while the trees do not change, and with them the slots.
#[derive(Default)]
pub(crate) struct SlotBits(Vec<u64>);

impl SlotBits {
    /// Empties the set, keeping its memory.
    pub(crate) fn clear(&mut self) {
        self.0.fill(0);
    }

    /// Adds `slot`.
    #[inline]
    pub(crate) fn insert(&mut self, slot: u32) {
        let i = slot as usize;
        if self.0.len() <= i / 64 {
            self.0.resize(i / 64 + 1, 0);
        }
        self.0[i / 64] |= 1 << (i % 64);
    }

    /// Whether `slot` is in the set.
    #[inline]
    pub(crate) fn contains(&self, slot: u32) -> bool {
        let i = slot as usize;
        self.0.get(i / 64).is_some_and(|w| w >> (i % 64) & 1 != 0)
    }
}

#[cfg(test)]
mod tests {
    use super::{SlotBits, ViewWalk, WalkForm, WalkStill};
    use bevy::math::Vec4;

    #[test]
    fn matches_only_the_same_planes_and_form_until_forgotten() {
        let planes = [Vec4::new(1.0, 0.0, 0.0, 2.0); 6];
        let mut walk = ViewWalk::default();
        assert_eq!(walk.still(&planes, WalkForm::Lists), WalkStill::Stale);
        walk.restart(planes, WalkForm::Lists);
        assert_eq!(walk.still(&planes, WalkForm::Lists), WalkStill::Holds);
        assert_eq!(walk.still(&planes, WalkForm::Bits), WalkStill::Stale);
        let mut moved = planes;
        moved[3].w = f32::from_bits(2.0f32.to_bits() + 1);
        assert_eq!(walk.still(&moved, WalkForm::Lists), WalkStill::Stale);
        // -0.0 == 0.0, but a frustum built from other numbers is another walk.
        let mut signed = planes;
        signed[0].y = -0.0;
        assert_eq!(walk.still(&signed, WalkForm::Lists), WalkStill::Stale);
        walk.forget();
        assert_eq!(walk.still(&planes, WalkForm::Lists), WalkStill::Stale);
    }

    #[test]
    fn busy_movers_are_forgotten_alone_and_only_in_list_form() {
        let planes = [Vec4::new(0.0, 1.0, 0.0, 3.0); 6];
        let mut walk = ViewWalk::default();
        walk.restart(planes, WalkForm::Lists);
        walk.forget_busy_movers();
        assert_eq!(
            walk.still(&planes, WalkForm::Lists),
            WalkStill::HoldsInTrees
        );
        walk.busy_movers_walked();
        assert_eq!(walk.still(&planes, WalkForm::Lists), WalkStill::Holds);
        walk.forget_busy_movers();
        walk.restart(planes, WalkForm::Bits);
        walk.forget_busy_movers();
        assert_eq!(walk.still(&planes, WalkForm::Bits), WalkStill::Holds);
        walk.forget();
        assert_eq!(walk.still(&planes, WalkForm::Bits), WalkStill::Stale);
    }

    #[test]
    fn slot_bits_hold_exactly_what_was_inserted_until_cleared() {
        let mut bits = SlotBits::default();
        let ids = [0u32, 1, 63, 64, 65, 1000, 123_456];
        for &i in &ids {
            bits.insert(i);
        }
        for i in 0..130_000u32 {
            assert_eq!(bits.contains(i), ids.contains(&i), "slot {i}");
        }
        bits.clear();
        assert!(ids.iter().all(|&i| !bits.contains(i)));
    }
}
