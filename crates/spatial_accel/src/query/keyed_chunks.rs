//! Bounds over runs of a [`KeyedList`](super::KeyedList)'s entries, so that a query skips
//! whole runs it cannot touch instead of testing every entry.
//!
//! Why: a list of fast movers is tested entry by entry, so a query that sees a small part of
//! the world still reads every entry (a frustum over a field of a quarter million movers
//! reads all of them to keep a few thousand). Entries sit in the order they joined, which for
//! objects spawned together is usually spatial order, so a run of neighbouring entries
//! covers a small region, and one box test of the run stands for all of them. The bounds
//! must hold every entry of their run, or a query would lose entries: a move that leaves its
//! run's bounds marks the run stale (one flag store, safe from several threads), and a stale
//! run is tested entry by entry until [`ChunkBounds::tighten_stale`] computes its bounds
//! again. Freshly computed bounds leave a margin of the run's largest entry, so objects that
//! move about a place (units wobbling, idling) stay inside for many frames; and each call
//! also recomputes a sixteenth of the runs, going round, so bounds left loose by an object
//! that wandered off and came back tighten again.

use super::KeyedEntry;
use crate::Aabb;
use core::sync::atomic::{AtomicBool, Ordering};
use glam::Vec3A;

/// Entries a chunk covers: a chunk's entries fill about three kilobytes, so a skipped chunk
/// saves that much reading for one box test.
pub const CHUNK_LEN: usize = 64;

/// Each call of [`ChunkBounds::tighten_stale`] also recomputes this share of the chunks,
/// stale or not: a loose chunk is tight again within this many calls.
const SWEEP_SHARE: usize = 16;

/// The chunk an entry at `position` belongs to.
#[inline]
pub(crate) fn chunk_of(position: usize) -> usize {
    position / CHUNK_LEN
}

/// The bounds of each chunk of [`CHUNK_LEN`] entries, and whether each is stale.
///
/// Invariant: a chunk that is not stale has bounds containing the box of every entry in it.
#[derive(Debug, Default)]
pub(crate) struct ChunkBounds {
    bounds: Vec<Aabb>,
    stale: Vec<AtomicBool>,
    /// The next chunk the sweep of [`Self::tighten_stale`] recomputes.
    sweep_from: usize,
}

impl Clone for ChunkBounds {
    fn clone(&self) -> Self {
        Self {
            bounds: self.bounds.clone(),
            stale: self
                .stale
                .iter()
                .map(|s| AtomicBool::new(s.load(Ordering::Relaxed)))
                .collect(),
            sweep_from: self.sweep_from,
        }
    }
}

impl ChunkBounds {
    /// Number of chunks.
    #[inline]
    pub(crate) fn len(&self) -> usize {
        self.bounds.len()
    }

    /// The bounds of chunk `c`, or `None` while it is stale (its entries must each be
    /// tested).
    #[inline]
    pub(crate) fn current(&self, c: usize) -> Option<&Aabb> {
        (!self.stale[c].load(Ordering::Relaxed)).then(|| &self.bounds[c])
    }

    /// Chunks whose bounds are stale.
    pub(crate) fn stale_count(&self) -> usize {
        self.stale
            .iter()
            .filter(|s| s.load(Ordering::Relaxed))
            .count()
    }

    /// Bytes held, capacity included.
    pub(crate) fn memory_bytes(&self) -> usize {
        self.bounds.capacity() * size_of::<Aabb>() + self.stale.capacity()
    }

    /// An entry was pushed at `position` with box `b`.
    pub(crate) fn pushed(&mut self, position: usize, b: &Aabb) {
        let c = chunk_of(position);
        if c == self.bounds.len() {
            self.bounds.push(*b);
            self.stale.push(AtomicBool::new(false));
        } else {
            // Widening keeps the chunk current without a pass over its entries; the next
            // tightening gives it its margin.
            self.bounds[c] = self.bounds[c].union(b);
        }
    }

    /// The entry at `position` now has box `b`: at most a flag store, which any number of
    /// threads may make at once (the list's concurrent moves call it from each).
    #[inline]
    pub(crate) fn moved(&self, position: usize, b: &Aabb) {
        let c = chunk_of(position);
        // Read before writing: a store, even of the same value, takes the flag's cache line
        // from the other threads writing flags nearby.
        if !self.bounds[c].contains_aabb(b) && !self.stale[c].load(Ordering::Relaxed) {
            self.stale[c].store(true, Ordering::Relaxed);
        }
    }

    /// The list now holds `len` entries (after a removal moved its last entry elsewhere,
    /// which [`Self::moved`] reported): chunks past the end go.
    pub(crate) fn truncated(&mut self, len: usize) {
        let chunks = len.div_ceil(CHUNK_LEN);
        self.bounds.truncate(chunks);
        self.stale.truncate(chunks);
    }

    /// Computes the bounds of every stale chunk again from `entries` (the list's), with a
    /// margin of the chunk's largest entry, and those of the next [`SWEEP_SHARE`]th of the
    /// chunks, going round; returns how many chunks it recomputed.
    ///
    /// Why the sweep: a chunk only goes stale when an entry leaves its bounds, never when
    /// they grew loose (an entry that wandered far and came back, one that left the list),
    /// and a loose chunk is one a query can no longer skip.
    pub(crate) fn tighten_stale(&mut self, entries: &[KeyedEntry]) -> usize {
        let chunks = self.bounds.len();
        if chunks == 0 {
            return 0;
        }
        let sweep = chunks.div_ceil(SWEEP_SHARE);
        let from = if self.sweep_from < chunks {
            self.sweep_from
        } else {
            0
        };
        self.sweep_from = from + sweep;
        let swept = from..from + sweep;
        let mut tightened = 0;
        for (c, stale) in self.stale.iter_mut().enumerate() {
            if !*stale.get_mut() && !swept.contains(&c) {
                continue;
            }
            let run = &entries[c * CHUNK_LEN..((c + 1) * CHUNK_LEN).min(entries.len())];
            self.bounds[c] = with_margin(run);
            *stale.get_mut() = false;
            tightened += 1;
        }
        tightened
    }

    /// Checks the invariant against the list's `entries`.
    pub(crate) fn validate(&self, entries: &[KeyedEntry]) -> Result<(), String> {
        if self.bounds.len() != entries.len().div_ceil(CHUNK_LEN)
            || self.stale.len() != self.bounds.len()
        {
            return Err(format!(
                "{} chunk bounds ({} flags) for {} entries",
                self.bounds.len(),
                self.stale.len(),
                entries.len()
            ));
        }
        for (p, e) in entries.iter().enumerate() {
            let c = chunk_of(p);
            if let Some(b) = self.current(c)
                && !b.contains_aabb(&e.bounds)
            {
                return Err(format!("entry {p} lies outside its current chunk {c}"));
            }
        }
        Ok(())
    }
}

/// The union of a run's boxes pushed out by its largest box's longest side, and by a little
/// more than rounding at its coordinates (so that the margin is never lost to rounding).
fn with_margin(run: &[KeyedEntry]) -> Aabb {
    let (union, largest) = run.iter().fold((Aabb::EMPTY, 0.0f32), |(u, l), e| {
        (u.union(&e.bounds), l.max(e.bounds.extent().max_element()))
    });
    let magnitude = union.min.abs().max(union.max.abs()).max_element();
    let margin = largest + magnitude * 4e-6 + 1e-6;
    let grown = union.expanded(Vec3A::splat(margin));
    // A margin too large for `f32` would make the bounds infinite, which every test still
    // reads as containing; a finite union is kept finite for the validator's sake.
    if grown.is_finite() { grown } else { union }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry(key: u32, x: f32) -> KeyedEntry {
        KeyedEntry {
            bounds: Aabb::new(Vec3A::new(x, 0.0, 0.0), Vec3A::new(x + 1.0, 1.0, 1.0)),
            id: key,
            key,
            tag: 0,
            stamp: 0,
        }
    }

    /// An entry that leaves its chunk's bounds and comes back leaves the chunk loose, never
    /// stale: the sweep makes it tight again within [`SWEEP_SHARE`] calls.
    #[test]
    fn a_loose_chunk_is_swept_tight_again() {
        let at = 3 * CHUNK_LEN + 5;
        let mut entries: Vec<KeyedEntry> = (0..40 * CHUNK_LEN as u32)
            .map(|k| entry(k, k as f32 * 2.0))
            .collect();
        let mut chunks = ChunkBounds::default();
        for (p, e) in entries.iter().enumerate() {
            chunks.pushed(p, &e.bounds);
        }
        chunks.tighten_stale(&entries);
        let narrow = chunks.current(3).unwrap().extent().x;
        assert!(narrow < 200.0, "{narrow}");
        // Away, far along x: the chunk goes stale, and is recomputed around it.
        entries[at] = entry(at as u32, 1e6);
        chunks.moved(at, &entries[at].bounds);
        assert!(chunks.current(3).is_none());
        chunks.tighten_stale(&entries);
        assert!(chunks.current(3).unwrap().extent().x > 1e5);
        // Back home: inside the loose bounds, so nothing marks the chunk.
        entries[at] = entry(at as u32, at as f32 * 2.0);
        chunks.moved(at, &entries[at].bounds);
        assert!(chunks.current(3).is_some());
        for _ in 0..SWEEP_SHARE {
            chunks.tighten_stale(&entries);
            chunks.validate(&entries).unwrap();
        }
        let after = chunks.current(3).unwrap().extent().x;
        assert!(after < 200.0, "still {after} wide");
    }
}
