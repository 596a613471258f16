//! The slots a view's tree walk found, handed back in slot order.

#[cfg(feature = "light_culling")]
use bevy::prelude::Entity;
use spatial_accel::prefetch::prefetch;

/// How many keys ahead of its lookup a slot's entries are prefetched: enough lookups to cover
/// a memory latency.
pub(crate) const LOOKUP_AHEAD: usize = 64;

/// Slots found by a frustum walk, each with whether it still needs the exact test, returned in
/// ascending slot order.
///
/// Why slot order: slots are handed out as the sync system meets entities, which is the order
/// of Bevy's tables, so deciding entities by slot makes their component reads nearly sequential
/// where the walk's spatial order makes each one a cache miss. Why not a comparison sort: in
/// a large world a view's tens of thousands of finds take longer to sort than to walk
/// (BENCHMARKS.md, Culling). When the finds are dense in the slot range a bitset over the
/// slots orders them in linear time instead.
#[derive(Default)]
pub(crate) struct FoundSlots {
    /// In walk order until sorted.
    keys: Vec<SlotKey>,
    /// One bit per key value; all zero between uses (draining clears what it reads).
    bits: Vec<u64>,
    /// Per slot, the flags pushed with it by [`Self::push_with_flags`]. Only the entries of
    /// slots pushed since the last drain are read, so it is never cleared.
    #[cfg(feature = "light_culling")]
    flags_by_slot: Vec<u16>,
}

/// A slot found by a walk and whether its entity still needs the exact test, packed as
/// `slot << 1 | exact` so that keys order by slot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) struct SlotKey(u64);

impl SlotKey {
    /// The tree slot.
    #[inline]
    pub(crate) fn slot(self) -> u32 {
        (self.0 >> 1) as u32
    }

    /// Whether the slot's entity still needs the exact test.
    #[inline]
    pub(crate) fn exact(self) -> bool {
        self.0 & 1 == 1
    }
}

impl FoundSlots {
    /// Forgets the previous view's finds.
    pub(crate) fn clear(&mut self) {
        self.keys.clear();
    }

    /// Records a slot the walk found; `exact` means its entity still needs the exact test.
    #[inline]
    pub(crate) fn push(&mut self, slot: u32, exact: bool) {
        self.keys
            .push(SlotKey((u64::from(slot) << 1) | u64::from(exact)));
    }

    #[cfg(feature = "light_culling")]
    /// Records a slot the walk found with flags of the caller's (its entity still needs the
    /// exact test); a slot is pushed this way at most once between drains.
    #[inline]
    pub(crate) fn push_with_flags(&mut self, slot: u32, flags: u16) {
        self.push(slot, true);
        let i = slot as usize;
        if self.flags_by_slot.len() <= i {
            self.flags_by_slot.resize(i + 1, 0);
        }
        self.flags_by_slot[i] = flags;
    }

    #[cfg(feature = "light_culling")]
    /// The entities of the slots found with [`Self::push_with_flags`], each with its flags, in
    /// slot order into `out`; then forgets them.
    pub(crate) fn drain_entities_with_flags(
        &mut self,
        slot_entities: &[Option<Entity>],
        out: &mut Vec<(Entity, u16)>,
    ) {
        self.sort_in_slot_order(slot_entities.len());
        let flags_by_slot = &self.flags_by_slot;
        let ahead = |slot: u32| {
            prefetch_entry(slot_entities, slot);
            prefetch_entry(flags_by_slot, slot);
        };
        for (slot, _) in Self::sorted_keys_prefetching(&self.keys, ahead) {
            if let Some(Some(entity)) = slot_entities.get(slot as usize) {
                out.push((
                    *entity,
                    self.flags_by_slot.get(slot as usize).copied().unwrap_or(0),
                ));
            }
        }
        self.keys.clear();
    }

    /// Puts the keys in ascending order, that is the slots in ascending order, each with its
    /// flag, and each slot once (a slot pushed twice keeps one key, exact if either was).
    /// `slot_capacity` bounds the slots pushed (one past the largest). Why each slot once:
    /// the entities of the keys are decided on several threads, each writing its entity's
    /// row, so a slot found twice (which a walk never does) must not become two writers.
    fn sort_in_slot_order(&mut self, slot_capacity: usize) {
        let key_words = (slot_capacity * 2).div_ceil(64);
        // The bitset costs a pass over `key_words` words; a sort costs ~log2(n) per key.
        // Pick whichever is fewer steps (a key larger than the capacity, which a caller
        // should never push, falls back to the sort rather than indexing out of range).
        let dense = self.keys.len() * 16 >= key_words
            && self.keys.iter().all(|k| ((k.0 >> 6) as usize) < key_words);
        if dense {
            if self.bits.len() < key_words {
                self.bits.resize(key_words, 0);
            }
            for key in &self.keys {
                self.bits[(key.0 >> 6) as usize] |= 1 << (key.0 & 63);
            }
            self.keys.clear();
            for (w, word) in self.bits[..key_words].iter_mut().enumerate() {
                let mut b = core::mem::take(word);
                // Bit 2s is slot s inside, bit 2s + 1 slot s exact: exact wins.
                b &= !((b & 0xAAAA_AAAA_AAAA_AAAA) >> 1);
                while b != 0 {
                    self.keys
                        .push(SlotKey(((w as u64) << 6) | u64::from(b.trailing_zeros())));
                    b &= b - 1;
                }
            }
        } else {
            self.keys.sort_unstable();
            self.keys.dedup_by(|later, kept| {
                let same = later.slot() == kept.slot();
                if same {
                    kept.0 |= later.0 & 1;
                }
                same
            });
        }
    }

    /// The sorted keys, each with the entry of `by_slot` for its slot prefetched
    /// [`LOOKUP_AHEAD`] keys earlier. Why: ascending slots are still scattered through a
    /// large world's slot arrays (a view's slab of a grid is a few slots of every row), too far
    /// apart for the hardware prefetcher; without the hints, a lookup per key waits on memory.
    #[cfg(feature = "light_culling")]
    fn sorted_keys_prefetching<'a>(
        keys: &'a [SlotKey],
        ahead: impl Fn(u32) + 'a,
    ) -> impl Iterator<Item = (u32, bool)> + 'a {
        keys.iter().enumerate().map(move |(i, &key)| {
            if let Some(k) = keys.get(i + LOOKUP_AHEAD) {
                ahead(k.slot());
            }
            (key.slot(), key.exact())
        })
    }

    /// The keys found, in ascending slot order (each slot once); the next [`Self::clear`]
    /// forgets them. `slot_capacity` bounds the slots pushed (one past the largest).
    pub(crate) fn sorted_keys(&mut self, slot_capacity: usize) -> &[SlotKey] {
        self.sort_in_slot_order(slot_capacity);
        &self.keys
    }
}

/// Two runs of keys in slot order, read as one list: a view's finds in the static tree and
/// the dynamic index, then its finds among the busy movers. Why two runs, not one sorted
/// list: the trees' run is kept across frames in which only busy movers moved, and only the
/// busy movers' run is made again (see `ViewWalk`); the runs hold disjoint slots.
#[derive(Clone, Copy, Default)]
pub(crate) struct KeyRuns<'a> {
    pub(crate) first: &'a [SlotKey],
    pub(crate) second: &'a [SlotKey],
}

impl<'a> KeyRuns<'a> {
    /// Keys in both runs.
    #[inline]
    pub(crate) fn len(&self) -> usize {
        self.first.len() + self.second.len()
    }

    /// The `i`th key of the runs read as one list.
    #[inline]
    pub(crate) fn get(&self, i: usize) -> Option<SlotKey> {
        match self.first.get(i) {
            Some(key) => Some(*key),
            None => self.second.get(i - self.first.len()).copied(),
        }
    }

    /// The keys `range` of the runs read as one list.
    pub(crate) fn slice(&self, range: core::ops::Range<usize>) -> KeyRuns<'a> {
        let split = self.first.len();
        let first = &self.first[range.start.min(split)..range.end.min(split)];
        let second = &self.second[range.start.max(split) - split..range.end.max(split) - split];
        KeyRuns { first, second }
    }

    /// The keys in order.
    pub(crate) fn iter(&self) -> impl Iterator<Item = SlotKey> + 'a {
        self.first.iter().chain(self.second).copied()
    }
}

/// Prefetches `by_slot[slot]`, if there is one.
#[inline(always)]
pub(crate) fn prefetch_entry<T>(by_slot: &[T], slot: u32) {
    if let Some(entry) = by_slot.get(slot as usize) {
        prefetch(entry);
    }
}

#[cfg(test)]
mod tests {
    use super::{FoundSlots, KeyRuns};
    use bevy::prelude::Entity;

    /// The slots found as `(slot, exact)`, in ascending slot order; then forgets them.
    fn drain_in_slot_order(found: &mut FoundSlots, capacity: usize) -> Vec<(u32, bool)> {
        let slots = found
            .sorted_keys(capacity)
            .iter()
            .map(|key| (key.slot(), key.exact()))
            .collect();
        found.clear();
        slots
    }

    /// Both orderings (bitset when dense, sort when sparse) give every slot once, ascending,
    /// with its flag.
    #[test]
    fn drains_ascending_with_flags_dense_and_sparse() {
        for (capacity, step) in [(10_000usize, 3u32), (10_000, 997), (1 << 16, 1)] {
            let mut found = FoundSlots::default();
            let mut expected = Vec::new();
            // A scrambled order, as a tree walk produces.
            let mut slots: Vec<u32> = (0..capacity as u32).step_by(step as usize).collect();
            slots.reverse();
            let middle = slots.len() / 2;
            slots.swap(0, middle);
            for &slot in &slots {
                let exact = slot % 5 == 0;
                found.push(slot, exact);
                expected.push((slot, exact));
            }
            expected.sort_unstable();
            for _ in 0..2 {
                let got = drain_in_slot_order(&mut found, capacity);
                assert_eq!(got, expected, "capacity {capacity}, step {step}");
                assert_eq!(drain_in_slot_order(&mut found, capacity).len(), 0);
                for &(slot, exact) in &expected {
                    found.push(slot, exact);
                }
            }
        }
    }

    /// Two runs read as one list, whole and in every slice.
    #[test]
    fn key_runs_read_as_one_list() {
        let mut trees = FoundSlots::default();
        let mut busy = FoundSlots::default();
        for slot in [40u32, 3, 17] {
            trees.push(slot, slot == 3);
        }
        for slot in [9u32, 2] {
            busy.push(slot, false);
        }
        let runs = KeyRuns {
            first: trees.sorted_keys(64),
            second: busy.sorted_keys(64),
        };
        let all: Vec<u32> = runs.iter().map(|k| k.slot()).collect();
        assert_eq!(all, [3, 17, 40, 2, 9]);
        assert_eq!(runs.len(), 5);
        for start in 0..=5 {
            for end in start..=5 {
                let part = runs.slice(start..end);
                let got: Vec<u32> = part.iter().map(|k| k.slot()).collect();
                assert_eq!(got, all[start..end], "{start}..{end}");
                assert_eq!(part.len(), end - start);
                for i in 0..part.len() {
                    assert_eq!(part.get(i).map(|k| k.slot()), Some(all[start + i]));
                }
                assert_eq!(part.get(part.len()), None);
            }
        }
    }

    /// A slot pushed more than once comes out once, exact if any push was, in both orderings.
    #[test]
    fn duplicate_slots_come_out_once_exact_winning() {
        for capacity in [64usize, 1 << 20] {
            let mut found = FoundSlots::default();
            for (slot, exact) in [(9u32, false), (3, true), (9, true), (3, false), (5, false)] {
                found.push(slot, exact);
            }
            found.push(5, false);
            let got = drain_in_slot_order(&mut found, capacity);
            assert_eq!(
                got,
                [(3, true), (5, false), (9, true)],
                "capacity {capacity}"
            );
        }
    }

    /// Flags come out with their slots' entities, in slot order, free slots skipped.
    #[cfg(feature = "light_culling")]
    #[test]
    fn drains_entities_with_their_flags() {
        let slot_entities: Vec<Option<Entity>> = (0..3_000u32)
            .map(|i| (i % 5 != 1).then(|| Entity::from_raw_u32(i + 7).unwrap()))
            .collect();
        let mut found = FoundSlots::default();
        for round in 0..2u16 {
            for slot in (0..3_000u32).rev().filter(|s| s % 3 == 0) {
                found.push_with_flags(slot, slot as u16 ^ round);
            }
            let mut got = Vec::new();
            found.drain_entities_with_flags(&slot_entities, &mut got);
            let want: Vec<(Entity, u16)> = (0..3_000u32)
                .filter(|s| s % 3 == 0)
                .filter_map(|s| slot_entities[s as usize].map(|e| (e, s as u16 ^ round)))
                .collect();
            assert_eq!(got, want, "round {round}");
        }
    }
}
