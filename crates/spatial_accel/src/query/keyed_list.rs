//! A flat list of boxes found by the caller's own dense keys: the home of objects that move
//! every frame.
//!
//! Why a list and not a tree: a tree pays for each move (a leaf, its parents, a refit), and
//! for objects that move every frame that upkeep costs more than the queries it saves. A
//! list entry costs one box write per move, and a query tests every entry, one box test
//! each. Why keys and not handles: the caller then finds an entry through one small array
//! indexed by its own number (an entity's index), with no record of its own to read first;
//! every other lookup is a cache miss per move.

use super::dynamic_index::IndexError;
use super::flat_loops;
use super::keyed_chunks::{CHUNK_LEN, ChunkBounds};
use super::views::{ViewClassification, ViewMasks};
use super::{RayWalk, SpatialQuery};
use crate::{Aabb, Containment, Frustum, Ray, Sphere};
use core::ops::ControlFlow;
use glam::Vec3A;

/// One entry of a [`KeyedList`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KeyedEntry {
    /// The entry's box.
    pub bounds: Aabb,
    /// The id queries report.
    pub id: u32,
    /// The caller's key, by which it finds the entry.
    pub key: u32,
    /// A number the caller gives with the key and must give again to find the entry (an
    /// entity's generation, so that a reused key does not find a dead object's entry).
    pub tag: u32,
    /// The caller's time of the last move (a frame number), for finding the quiet ones.
    pub stamp: u32,
}

/// No entry at this key.
const ABSENT: u32 = u32::MAX;

/// Boxes in a flat list, each found by the caller's key, every query a test of each box
/// (the loops of [`BruteForceIndex`](super::BruteForceIndex), so the answers are the same),
/// save the runs of [`CHUNK_LEN`] entries a query can skip whole by their bounds (see
/// [`KeyedChunk`]; call [`tighten_chunk_bounds`](Self::tighten_chunk_bounds) once the
/// frame's moves are written).
///
/// Keys should be small and dense (the list keeps a 4-byte position per key up to the
/// largest); ids are what queries report and need not be unique to the list.
///
/// ```
/// use spatial_accel::query::KeyedList;
/// use spatial_accel::{Aabb, Ray, SpatialQuery};
/// use glam::Vec3A;
/// let mut movers = KeyedList::new();
/// let crate_box = Aabb::new(Vec3A::new(3.0, -1.0, -1.0), Vec3A::new(4.0, 1.0, 1.0));
/// movers.insert(7, 0, 42, crate_box, 1).unwrap();
/// // The next frame it moved: found by its key, one box write.
/// let moved = Aabb::new(Vec3A::new(5.0, -1.0, -1.0), Vec3A::new(6.0, 1.0, 1.0));
/// let at = movers.position(7, 0).unwrap();
/// assert!(movers.set_bounds(at, moved, 2));
/// let hit = movers.cast_ray(&Ray::new(Vec3A::ZERO, Vec3A::X), |_, r| r.intersect_aabb(&moved));
/// assert_eq!(hit.unwrap().primitive, 42);
/// ```
#[derive(Clone, Debug, Default)]
pub struct KeyedList {
    position_by_key: Vec<u32>,
    entries: Vec<KeyedEntry>,
    chunks: ChunkBounds,
}

/// A run of [`CHUNK_LEN`] consecutive entries of a [`KeyedList`] (fewer at the end), with
/// bounds containing every one of their boxes while they are current.
///
/// A query may skip the run when its bounds fail the query's test, provided the test can
/// only fail for a box inside a box that fails it (true of the slab, frustum, box and sphere
/// tests: each is monotone in the box, in floating point too).
#[derive(Clone, Copy, Debug)]
pub struct KeyedChunk<'a> {
    /// Bounds of every entry of the run, or `None` while stale: an entry moved out of them
    /// since they were computed, and each entry must be tested.
    pub bounds: Option<&'a Aabb>,
    /// The run's entries.
    pub entries: &'a [KeyedEntry],
}

impl KeyedList {
    /// An empty list.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of entries.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// True when the list holds nothing.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// The entries, in storage order.
    pub fn entries(&self) -> &[KeyedEntry] {
        &self.entries
    }

    /// Where the entry of `key` sits in [`entries`](Self::entries), if it has one with `tag`.
    #[inline]
    pub fn position(&self, key: u32, tag: u32) -> Option<usize> {
        let p = *self.position_by_key.get(key as usize)?;
        if p == ABSENT {
            return None;
        }
        let entry = &self.entries[p as usize];
        (entry.tag == tag).then_some(p as usize)
    }

    /// The entry of `key`, if it has one with `tag`.
    #[inline]
    pub fn get(&self, key: u32, tag: u32) -> Option<&KeyedEntry> {
        self.position(key, tag).map(|p| &self.entries[p])
    }

    /// Adds an entry under `key`, which must have none. Refuses a box that is not valid and
    /// finite, as every index of the crate does.
    pub fn insert(
        &mut self,
        key: u32,
        tag: u32,
        id: u32,
        bounds: Aabb,
        stamp: u32,
    ) -> Result<(), IndexError> {
        if !(bounds.is_valid() && bounds.is_finite()) {
            return Err(IndexError::InvalidBounds);
        }
        if self.entries.len() >= ABSENT as usize {
            return Err(IndexError::CapacityExceeded);
        }
        let k = key as usize;
        if self.position_by_key.len() <= k {
            self.position_by_key.resize(k + 1, ABSENT);
        }
        if self.position_by_key[k] != ABSENT {
            // A second entry under one key would leave the first unreachable forever.
            return Err(IndexError::StaleHandle);
        }
        self.position_by_key[k] = self.entries.len() as u32;
        self.chunks.pushed(self.entries.len(), &bounds);
        self.entries.push(KeyedEntry {
            bounds,
            id,
            key,
            tag,
            stamp,
        });
        Ok(())
    }

    /// Gives the entry at `position` a new box and stamp; true when the box changed (the
    /// stamp is written only then, so an object whose box held still ages). The box must be
    /// valid and finite: the caller checked it, as a tree's update would.
    #[inline]
    pub fn set_bounds(&mut self, position: usize, bounds: Aabb, stamp: u32) -> bool {
        debug_assert!(bounds.is_valid() && bounds.is_finite());
        let entry = &mut self.entries[position];
        if entry.bounds == bounds {
            return false;
        }
        entry.bounds = bounds;
        entry.stamp = stamp;
        self.chunks.moved(position, &bounds);
        true
    }

    /// A view through which several threads give entries new boxes at once (see
    /// [`ConcurrentMoves`]); the list is borrowed, so no entry is added or taken out
    /// meanwhile.
    pub fn concurrent_moves(&mut self) -> ConcurrentMoves<'_> {
        ConcurrentMoves {
            position_by_key: &self.position_by_key,
            entries: self.entries.as_mut_ptr(),
            len: self.entries.len(),
            chunks: &self.chunks,
            _list: core::marker::PhantomData,
        }
    }

    /// Takes out the entry of `key` with `tag`, moving the last entry into its place.
    pub fn remove(&mut self, key: u32, tag: u32) -> Option<KeyedEntry> {
        let p = self.position(key, tag)?;
        Some(self.remove_at(p))
    }

    /// Takes out the entry at `position`, moving the last entry into its place.
    pub fn remove_at(&mut self, position: usize) -> KeyedEntry {
        let entry = self.entries.swap_remove(position);
        self.position_by_key[entry.key as usize] = ABSENT;
        if let Some(moved) = self.entries.get(position) {
            self.position_by_key[moved.key as usize] = position as u32;
            self.chunks.moved(position, &moved.bounds);
        }
        self.chunks.truncated(self.entries.len());
        entry
    }

    /// Number of [`KeyedChunk`]s: the entries' count over [`CHUNK_LEN`], rounded up.
    pub fn chunk_count(&self) -> usize {
        self.chunks.len()
    }

    /// The run of entries number `c` (below [`chunk_count`](Self::chunk_count)) and its
    /// bounds.
    #[inline]
    pub fn chunk(&self, c: usize) -> KeyedChunk<'_> {
        let from = c * CHUNK_LEN;
        KeyedChunk {
            bounds: self.chunks.current(c),
            entries: &self.entries[from..(from + CHUNK_LEN).min(self.entries.len())],
        }
    }

    /// The runs of entries, in storage order.
    pub fn chunks(&self) -> impl Iterator<Item = KeyedChunk<'_>> {
        (0..self.chunks.len()).map(|c| self.chunk(c))
    }

    /// Chunks whose bounds are stale: an entry moved out of them.
    pub fn stale_chunk_count(&self) -> usize {
        self.chunks.stale_count()
    }

    /// Computes the bounds of every stale chunk again (a pass over its entries), with a
    /// margin of its largest entry so that entries moving about stay inside; returns how
    /// many it recomputed. Call it after a frame's moves, before the frame's queries: until
    /// then, a query tests each entry of a stale chunk.
    pub fn tighten_chunk_bounds(&mut self) -> usize {
        self.chunks.tighten_stale(&self.entries)
    }

    /// Asks for the position of `key`, which [`position`](Self::position) reads first. A hint
    /// only.
    #[inline]
    pub fn prefetch_key(&self, key: u32) {
        if let Some(p) = self.position_by_key.get(key as usize) {
            crate::prefetch::prefetch_node(p);
        }
    }

    /// Asks for the entry of `key`, once its position has arrived (see
    /// [`prefetch_key`](Self::prefetch_key)); true when the key has an entry, whatever its
    /// tag. A hint only: the entry itself is not read, so that asking costs no wait on it.
    #[inline]
    pub fn prefetch_entry(&self, key: u32) -> bool {
        match self.position_by_key.get(key as usize) {
            Some(&p) if p != ABSENT => {
                if let Some(entry) = self.entries.get(p as usize) {
                    crate::prefetch::prefetch_all(entry);
                }
                true
            }
            _ => false,
        }
    }

    /// The union of the boxes: a pass over the list.
    pub fn bounds(&self) -> Aabb {
        self.entries
            .iter()
            .fold(Aabb::EMPTY, |acc, e| acc.union(&e.bounds))
    }

    /// Bytes held, capacity included.
    pub fn memory_bytes(&self) -> usize {
        self.position_by_key.capacity() * 4
            + self.entries.capacity() * size_of::<KeyedEntry>()
            + self.chunks.memory_bytes()
    }

    /// Checks that every entry is found through its key and every key finds its entry.
    pub fn validate(&self) -> Result<(), String> {
        for (p, e) in self.entries.iter().enumerate() {
            if self.position_by_key.get(e.key as usize) != Some(&(p as u32)) {
                return Err(format!("entry {p} (key {}) is not found by its key", e.key));
            }
        }
        let keyed = self
            .position_by_key
            .iter()
            .filter(|&&p| p != ABSENT)
            .count();
        if keyed != self.entries.len() {
            return Err(format!(
                "{keyed} keys hold a position for {} entries",
                self.entries.len()
            ));
        }
        self.chunks.validate(&self.entries)
    }

    /// The `(id, box)` of every entry, save those of chunks whose current bounds fail
    /// `keep`, in storage order.
    fn boxes_kept_by(
        &self,
        mut keep: impl FnMut(&Aabb) -> bool,
    ) -> impl Iterator<Item = (u32, &Aabb)> {
        self.chunks()
            .filter(move |c| c.bounds.is_none_or(&mut keep))
            .flat_map(|c| c.entries.iter().map(|e| (e.id, &e.bounds)))
    }
}

/// [`KeyedList::set_bounds`] for many objects at once, from several threads: each thread
/// finds and writes the entries of its own keys.
///
/// Why: a frame's moves of the objects in the list are independent writes of separate
/// entries, and a caller that reads the objects' new boxes in parallel (an ECS's parallel
/// query) should not have to gather them for one thread to write. Each call reads the key's
/// position and writes only that key's entry, so calls for distinct keys touch distinct
/// memory; the caller promises the keys are distinct (an entity's index is, within one pass
/// over the entities).
pub struct ConcurrentMoves<'a> {
    position_by_key: &'a [u32],
    entries: *mut KeyedEntry,
    len: usize,
    chunks: &'a ChunkBounds,
    _list: core::marker::PhantomData<&'a mut [KeyedEntry]>,
}

// SAFETY: the view holds the list's exclusive borrow; shared between threads it allows only
// `set_bounds`, whose contract keeps any two concurrent calls on distinct entries (the chunk
// bounds they share are only read, their stale flags written atomically).
unsafe impl Send for ConcurrentMoves<'_> {}
// SAFETY: as for `Send`.
unsafe impl Sync for ConcurrentMoves<'_> {}

impl ConcurrentMoves<'_> {
    /// Gives the entry of `key`, if it has one with `tag`, a new box and stamp, as
    /// [`KeyedList::set_bounds`] does: `Some(true)` when the box changed, `Some(false)` when
    /// it held still, `None` when the key has no entry with that tag. The box must be valid
    /// and finite.
    ///
    /// # Safety
    /// While this view lives, no two calls (on any threads) may name the same `key`.
    #[inline]
    pub unsafe fn set_bounds(&self, key: u32, tag: u32, bounds: Aabb, stamp: u32) -> Option<bool> {
        debug_assert!(bounds.is_valid() && bounds.is_finite());
        let p = *self.position_by_key.get(key as usize)?;
        if p == ABSENT {
            return None;
        }
        let p = p as usize;
        assert!(p < self.len, "a key's position lies in the list");
        // SAFETY: `p` is in bounds (checked above) of the entries the view borrows
        // exclusively, and no position is shared between keys (the list's invariant), so
        // with the caller's promise of distinct keys no other call reads or writes this
        // entry while this one runs.
        let entry = unsafe { &mut *self.entries.add(p) };
        if entry.tag != tag {
            return None;
        }
        if entry.bounds == bounds {
            return Some(false);
        }
        entry.bounds = bounds;
        entry.stamp = stamp;
        self.chunks.moved(p, &bounds);
        Some(true)
    }
}

impl RayWalk for KeyedList {
    /// Every entry whose box the ray enters within its current range, in storage order.
    fn walk_ray<V>(&self, ray: &mut Ray, visit: V)
    where
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        let mut visit = visit;
        for chunk in self.chunks() {
            // The chunk is tested at the ray's current range: a closest-hit search that
            // shrank it skips the chunks wholly beyond its best hit.
            if chunk.bounds.is_some_and(|b| !ray.hits_aabb(b)) {
                continue;
            }
            let boxes = chunk.entries.iter().map(|e| (e.id, &e.bounds));
            if flat_loops::walk_ray(boxes, ray, &mut visit).is_break() {
                return;
            }
        }
    }
}

impl SpatialQuery for KeyedList {
    fn for_each_overlapping_aabb<F>(&self, aabb: &Aabb, visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        flat_loops::overlapping_aabb(self.boxes_kept_by(|b| b.intersects_aabb(aabb)), aabb, visit);
    }

    fn for_each_overlapping_sphere<F>(&self, sphere: &Sphere, visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        flat_loops::overlapping_sphere(
            self.boxes_kept_by(|b| sphere.intersects_aabb(b)),
            sphere,
            visit,
        );
    }

    fn for_each_containing_point<F>(&self, point: Vec3A, visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        flat_loops::containing_point(
            self.boxes_kept_by(|b| b.contains_point(point)),
            point,
            visit,
        );
    }

    fn for_each_in_frustum<F>(&self, frustum: &Frustum, visit: F)
    where
        F: FnMut(u32, Containment),
    {
        let kept = self.boxes_kept_by(|b| frustum.classify_aabb(b) != Containment::Outside);
        flat_loops::in_frustum(kept, frustum, visit);
    }

    fn for_each_in_views<C, F>(&self, views: u32, classify: C, visit: F)
    where
        C: FnMut(&Aabb, u32) -> ViewClassification,
        F: FnMut(u32, ViewMasks),
    {
        if views == 0 {
            return;
        }
        let (mut classify, mut visit) = (classify, visit);
        for chunk in self.chunks() {
            // A chunk every view drops holds only boxes every view drops (`classify` is
            // monotone, as the trees' walks require of it at their nodes).
            if chunk
                .bounds
                .is_some_and(|b| classify(b, views).outside & views == views)
            {
                continue;
            }
            let boxes = chunk.entries.iter().map(|e| (e.id, &e.bounds));
            flat_loops::in_views(boxes, views, &mut classify, &mut visit);
        }
    }

    fn nearest_k<F>(&self, _point: Vec3A, k: usize, distance_squared: F) -> Vec<(u32, f32)>
    where
        F: FnMut(u32) -> f32,
    {
        flat_loops::nearest_k(self.entries.iter().map(|e| e.id), k, distance_squared)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_at(x: f32) -> Aabb {
        Aabb::new(Vec3A::new(x, 0.0, 0.0), Vec3A::new(x + 1.0, 1.0, 1.0))
    }

    #[test]
    fn keys_find_their_entries_through_removals() {
        let mut list = KeyedList::new();
        for key in 0..10 {
            list.insert(key * 3, key, 100 + key, unit_at(key as f32), 0)
                .unwrap();
        }
        assert_eq!(
            list.insert(3, 9, 1, unit_at(0.0), 0),
            Err(IndexError::StaleHandle)
        );
        assert_eq!(
            list.insert(99, 0, 1, Aabb::EMPTY, 0),
            Err(IndexError::InvalidBounds)
        );
        // The wrong tag finds nothing: a reused key.
        assert!(list.get(3, 0).is_none());
        assert_eq!(list.remove(0, 0).unwrap().id, 100);
        assert_eq!(list.remove(27, 9).unwrap().id, 109);
        list.validate().unwrap();
        for key in 1..9 {
            let e = list.get(key * 3, key).unwrap();
            assert_eq!((e.id, e.key), (100 + key, key * 3));
        }
        let at = list.position(12, 4).unwrap();
        assert!(!list.set_bounds(at, unit_at(4.0), 5));
        assert_eq!(list.entries()[at].stamp, 0);
        assert!(list.set_bounds(at, unit_at(40.0), 5));
        assert_eq!(list.entries()[at].stamp, 5);
        assert_eq!(list.len(), 8);
    }

    #[test]
    fn concurrent_moves_write_each_key_once_from_several_threads() {
        let mut list = KeyedList::new();
        for key in 0..1000u32 {
            list.insert(key, key % 7, key + 5, unit_at(0.0), 0).unwrap();
        }
        list.remove(500, 500 % 7).unwrap();
        let mut serial = list.clone();
        let moves = list.concurrent_moves();
        let results: Vec<Vec<Option<bool>>> = std::thread::scope(|scope| {
            let handles: Vec<_> = (0..4u32)
                .map(|t| {
                    let moves = &moves;
                    scope.spawn(move || {
                        (t * 250..(t + 1) * 250)
                            .map(|key| {
                                // Every third key keeps its box; key 500 has no entry, and
                                // the wrong tag finds none.
                                let x = if key % 3 == 0 { 0.0 } else { key as f32 };
                                let tag = if key == 999 { 0 } else { key % 7 };
                                // SAFETY: each thread names its own range of keys, once each.
                                unsafe { moves.set_bounds(key, tag, unit_at(x), 9) }
                            })
                            .collect()
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        let results: Vec<Option<bool>> = results.into_iter().flatten().collect();
        for (key, got) in (0..1000u32).zip(results) {
            let tag = if key == 999 { 0 } else { key % 7 };
            let want = serial.position(key, tag).map(|at| {
                let x = if key % 3 == 0 { 0.0 } else { key as f32 };
                serial.set_bounds(at, unit_at(x), 9)
            });
            assert_eq!(got, want, "key {key}");
        }
        assert_eq!(list.entries(), serial.entries());
        list.validate().unwrap();
    }
}
