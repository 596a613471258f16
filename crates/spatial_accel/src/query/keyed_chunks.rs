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
//! move about a place (units wobbling, idling) stay inside for many frames.

use super::KeyedEntry;
use crate::Aabb;
use core::sync::atomic::{AtomicBool, Ordering};
use glam::Vec3A;

/// Entries a chunk covers: a chunk's entries fill about three kilobytes, so a skipped chunk
/// saves that much reading for one box test.
pub const CHUNK_LEN: usize = 64;

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

    /// The entry at `position` now has box `b` (written through an exclusive borrow).
    #[inline]
    pub(crate) fn moved(&mut self, position: usize, b: &Aabb) {
        self.moved_shared(position, b);
    }

    /// The entry at `position` now has box `b`, written from one of several threads: at
    /// most a flag store, which any number of threads may make at once.
    #[inline]
    pub(crate) fn moved_shared(&self, position: usize, b: &Aabb) {
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
    /// margin of the chunk's largest entry; returns how many chunks it recomputed.
    pub(crate) fn tighten_stale(&mut self, entries: &[KeyedEntry]) -> usize {
        let mut tightened = 0;
        for (c, stale) in self.stale.iter_mut().enumerate() {
            if !*stale.get_mut() {
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
