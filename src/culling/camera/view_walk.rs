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
/// `ViewVisibility` to be set again every frame.
#[derive(Default)]
pub(crate) struct ViewWalk {
    /// The planes walked, compared bit for bit.
    planes: Option<[Vec4; 6]>,
    /// The form the finds were kept in.
    form: WalkForm,
    /// The entities found, in slot order, with their row hints and whether their leaf
    /// crosses a plane ([`WalkForm::Lists`]).
    pub(crate) found: Vec<FoundEntity>,
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

impl ViewWalk {
    /// Whether this walk was of exactly these planes, kept in this form (and has not been
    /// forgotten).
    pub(crate) fn walked(&self, planes: &[Vec4; 6], form: WalkForm) -> bool {
        self.form == form
            && self.planes.is_some_and(|p| {
                p.iter()
                    .zip(planes)
                    .all(|(a, b)| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits))
            })
    }

    /// Starts a new walk of `planes`, kept in `form`: forgets what the last one found.
    /// (`found` is not emptied: a walk in list form rewrites it in place, see
    /// `decide_found`, and one in bit form never reads it.)
    pub(crate) fn restart(&mut self, planes: [Vec4; 6], form: WalkForm) {
        self.planes = Some(planes);
        self.form = form;
        self.inside_bits.clear();
        self.crossing_bits.clear();
    }

    /// Forgets the walk (the trees changed).
    pub(crate) fn forget(&mut self) {
        self.planes = None;
    }

    /// Forgets the walk unless it is kept as sets for the flat pass: for a frame in which
    /// only the busy movers changed. The sets' verdicts hold for every entity the index
    /// holds, since the index did not change, and the flat pass asks none of busy movers
    /// (see `TreeVerdicts`).
    pub(crate) fn forget_unless_bits(&mut self) {
        if self.form != WalkForm::Bits {
            self.forget();
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
    use super::{SlotBits, ViewWalk, WalkForm};
    use bevy::math::Vec4;

    #[test]
    fn matches_only_the_same_planes_and_form_until_forgotten() {
        let planes = [Vec4::new(1.0, 0.0, 0.0, 2.0); 6];
        let mut walk = ViewWalk::default();
        assert!(!walk.walked(&planes, WalkForm::Lists));
        walk.restart(planes, WalkForm::Lists);
        assert!(walk.walked(&planes, WalkForm::Lists));
        assert!(!walk.walked(&planes, WalkForm::Bits));
        let mut moved = planes;
        moved[3].w = f32::from_bits(2.0f32.to_bits() + 1);
        assert!(!walk.walked(&moved, WalkForm::Lists));
        // -0.0 == 0.0, but a frustum built from other numbers is another walk.
        let mut signed = planes;
        signed[0].y = -0.0;
        assert!(!walk.walked(&signed, WalkForm::Lists));
        walk.forget();
        assert!(!walk.walked(&planes, WalkForm::Lists));
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
