//! The busy movers: entities that move frame after frame, kept in a flat list outside the
//! dynamic index.
//!
//! Why: a mover in a tree costs its sync a tracked record, a slot record of two lines and
//! the index's entry, each a cache miss at a million entities, and the tree its refit; the
//! least any upkeep of a mover can cost (the `Changed` scan, its rows, its world box and one
//! store) is well under that (BENCHMARKS.md, Plugin sync). A busy mover's sync reads a 4-byte
//! position by entity index and writes one list entry, in the order the sync visits movers;
//! queries test the list flat, one box test an entry. Entities that stay still for
//! [`BusyMoverSettings::quiet_frames`] go back into
//! the dynamic index, where queries pay nothing for them.

use super::{AccelTrees, LocalFrame, Placed, SlotEntry, TreeSlot};
use bevy::prelude::*;
use spatial_accel::Aabb;
use spatial_accel::query::{AnyHandle, ConcurrentMoves};

/// Whether movers may become busy movers (see [`BusyMoverSettings`]).
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[reflect(Default)]
pub enum BusyMovers {
    /// Every mover stays in the dynamic index.
    Off,
    /// Every dynamic entity that moves joins the list (and leaves it once quiet).
    On,
    /// The list is used while many entities move and few rays are cast (the thresholds of
    /// [`BusyMoverSettings`]): the whole-frame figures behind it are in BENCHMARKS.md,
    /// Whole frame.
    #[default]
    Automatic,
}

/// The busy movers: dynamic entities that moved in the last frames, held in a flat list
/// outside the dynamic index ([`EntityIndex::busy_movers`](crate::index::EntityIndex::busy_movers)).
///
/// A mover in a tree costs its sync several cache misses and the tree a refit; in the list
/// it costs one entry write, and every query tests it flat (one box test an entry for a
/// frustum or a ray). So the list pays where many entities move and queries are few
/// (culling, one pointer ray), and loses where many rays are cast (the preview, ray-heavy
/// gameplay). Queries, culling and picking see the same entities either way.
#[derive(Reflect, Clone, Debug, PartialEq)]
#[reflect(Default)]
pub struct BusyMoverSettings {
    /// When the list is used.
    pub mode: BusyMovers,
    /// Frames without a move after which a busy mover goes back into the dynamic index.
    pub quiet_frames: u32,
    /// Entities that may join or leave the list in one frame: each is an edit of the
    /// dynamic index, so a crowd starting or stopping is spread over frames.
    pub transfers_per_frame: usize,
    /// Busy movers checked for quiet each frame, at least (the sweep goes round the list,
    /// an eighth of it a frame when it is longer).
    pub checks_per_frame: usize,
    /// [`BusyMovers::Automatic`] uses the list from this many movers a frame, and stops
    /// below half of it.
    pub min_movers: usize,
    /// [`BusyMovers::Automatic`] uses the list while at most this many rays a frame are
    /// cast through the trees ([`AccelStats::rays_per_frame`](crate::AccelStats)), and
    /// stops above twice it.
    pub max_rays: f32,
}

impl Default for BusyMoverSettings {
    fn default() -> Self {
        Self {
            mode: BusyMovers::default(),
            quiet_frames: 30,
            transfers_per_frame: 32_768,
            checks_per_frame: 4_096,
            min_movers: 16,
            max_rays: 16.0,
        }
    }
}

impl BusyMoverSettings {
    /// Whether movers may join the list this frame, from the last frame's `movers` and
    /// averaged `rays`, and whether they could last frame (`was_on`, for the hysteresis).
    ///
    /// ```
    /// use bevy_accel::{BusyMoverSettings, BusyMovers};
    /// let auto = BusyMoverSettings::default();
    /// assert!(auto.wanted(false, 50_000, 1.0));
    /// assert!(!auto.wanted(false, 50_000, 5_000.0));
    /// // Between the thresholds, the last answer holds.
    /// assert!(auto.wanted(true, auto.min_movers * 3 / 4, 1.0));
    /// assert!(!auto.wanted(false, auto.min_movers * 3 / 4, 1.0));
    /// let off = BusyMoverSettings { mode: BusyMovers::Off, ..auto };
    /// assert!(!off.wanted(true, 50_000, 1.0));
    /// ```
    pub fn wanted(&self, was_on: bool, movers: usize, rays: f32) -> bool {
        match self.mode {
            BusyMovers::Off => false,
            BusyMovers::On => true,
            BusyMovers::Automatic if was_on => {
                movers >= self.min_movers / 2 && rays <= self.max_rays * 2.0
            }
            BusyMovers::Automatic => movers >= self.min_movers && rays <= self.max_rays,
        }
    }

    /// Busy movers to check for quiet this frame, out of `len`.
    pub fn checks(&self, len: usize) -> usize {
        self.checks_per_frame.max(len / 8)
    }
}

/// The busy movers' tag of an entity, kept with its entry: the list's key is the entity's
/// index, which Bevy reuses.
#[inline]
pub(super) fn busy_tag(entity: Entity) -> u32 {
    entity.generation().to_bits()
}

/// What the sync asks of the busy movers this frame (see [`AccelTrees::begin_busy_frame`]).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct BusyFrame {
    /// Whether movers may join the list.
    pub(super) enabled: bool,
    /// The frame's number, stamped on each busy move.
    pub(super) stamp: u32,
    /// Entities that may still join or leave the list this frame.
    pub(super) transfers_left: usize,
    /// Entities that joined the list this frame.
    pub(super) joined: usize,
    /// Where the next search for quiet entries starts.
    pub(super) sweep_from: usize,
}

impl AccelTrees {
    /// Starts a frame of the busy movers: whether movers may join, and how many entities may
    /// join or leave (each costs an edit of the dynamic index, so a switch of a million
    /// movers is spread over frames rather than stalling one).
    pub(crate) fn begin_busy_frame(&mut self, enabled: bool, transfers: usize) {
        self.busy.enabled = enabled;
        self.busy.stamp = self.busy.stamp.wrapping_add(1);
        self.busy.transfers_left = transfers;
        self.busy.joined = 0;
    }

    /// Entities that joined the busy movers this frame: each a move the sync counted, made
    /// by taking the entity out of the dynamic index.
    pub(crate) fn busy_joined(&self) -> usize {
        self.busy.joined
    }

    /// Whether the list took (or gave back) as many entities this frame as a frame may
    /// move: movers that still wait to join moved through the index meanwhile.
    pub(crate) fn busy_transfers_spent(&self) -> bool {
        self.busy.enabled && self.busy.transfers_left == 0
    }

    /// Whether movers may join the busy movers this frame.
    pub(crate) fn busy_enabled(&self) -> bool {
        self.busy.enabled
    }

    /// Number of busy movers.
    pub fn busy_len(&self) -> usize {
        self.index.busy_movers().len()
    }

    /// Gives a busy mover its new box: one entry write. `None` when the entity is not a
    /// busy mover (the caller places it in the trees).
    #[inline]
    pub(crate) fn move_busy(&mut self, entity: Entity, bounds: Aabb) -> Option<Placed> {
        let stamp = self.busy.stamp;
        let busy = self.index.busy_movers_mut();
        let at = busy.position(entity.index_u32(), busy_tag(entity))?;
        Some(if busy.set_bounds(at, bounds, stamp) {
            Placed::Moved
        } else {
            Placed::Same
        })
    }

    /// Whether `entity` is a busy mover: one 4-byte read by its index (and its entry's tag).
    #[inline]
    pub(crate) fn is_busy_mover(&self, entity: Entity) -> bool {
        self.index
            .busy_movers()
            .position(entity.index_u32(), busy_tag(entity))
            .is_some()
    }

    /// Gives every busy mover its current box, after frames whose moves were left unwritten
    /// (see `unread_movers`). `now` gives an entity's current world box, or why it has none
    /// (its transform is no longer valid): it is then taken out of the trees and pushed to
    /// `dropped` with the reason, for the caller to report. Returns how many boxes changed.
    pub(crate) fn refresh_busy_movers(
        &mut self,
        mut now: impl FnMut(Entity) -> Result<Aabb, &'static str>,
        dropped: &mut Vec<(Entity, &'static str)>,
    ) -> usize {
        let stamp = self.busy.stamp;
        let movers: Vec<Entity> = self
            .index
            .busy_movers()
            .entries()
            .iter()
            .filter_map(|entry| self.entities_by_slot[entry.id as usize])
            .collect();
        let mut changed = 0;
        for entity in movers {
            match now(entity) {
                Ok(bounds) => {
                    let busy = self.index.busy_movers_mut();
                    if let Some(at) = busy.position(entity.index_u32(), busy_tag(entity)) {
                        changed += usize::from(busy.set_bounds(at, bounds, stamp));
                    }
                }
                Err(why) => {
                    self.remove(entity);
                    dropped.push((entity, why));
                }
            }
        }
        changed
    }

    /// The busy movers open to moves from several threads at once (see [`BusyMoves`]).
    pub(crate) fn concurrent_busy_moves(&mut self) -> BusyMoves<'_> {
        BusyMoves {
            stamp: self.busy.stamp,
            moves: self.index.busy_movers_mut().concurrent_moves(),
        }
    }

    /// Moves a dynamic entity out of the dynamic index into the busy movers, with its new
    /// box. `None` when the list refused it (the caller updates it in the index instead).
    pub(super) fn make_busy(
        &mut self,
        entity: Entity,
        slot: u32,
        handle: AnyHandle,
        bounds: Aabb,
    ) -> Option<Placed> {
        let stamp = self.busy.stamp;
        self.index
            .busy_movers_mut()
            .insert(entity.index_u32(), busy_tag(entity), slot, bounds, stamp)
            .ok()?;
        if let Err(e) = self.index.remove(handle) {
            error!("bevy_accel: moving {entity} out of the dynamic index failed: {e}");
        }
        self.slots[slot as usize] = SlotEntry::busy(entity);
        if let Some(Some(record)) = self.tracked_by_index.get_mut(entity.index_u32() as usize) {
            record.tree = TreeSlot::Busy;
        }
        self.busy.joined += 1;
        Some(Placed::Moved)
    }

    /// Busy movers that have not moved for `quiet_frames` frames (all of them when movers
    /// may not be busy this frame), found among the next `check_up_to` entries of a sweep
    /// that goes round the list over the frames, and at most as many as may leave this
    /// frame. Each goes back with [`Self::settle_busy`].
    fn quiet_busy_movers(&mut self, quiet_frames: u32, check_up_to: usize, out: &mut Vec<Entity>) {
        out.clear();
        let entries = self.index.busy_movers().entries();
        if entries.is_empty() {
            return;
        }
        let from = if self.busy.sweep_from < entries.len() {
            self.busy.sweep_from
        } else {
            0
        };
        let to = (from + check_up_to).min(entries.len());
        let stamp = self.busy.stamp;
        let everyone = !self.busy.enabled;
        for entry in &entries[from..to] {
            if out.len() >= self.busy.transfers_left {
                break;
            }
            if everyone || stamp.wrapping_sub(entry.stamp) > quiet_frames {
                out.extend(self.entities_by_slot[entry.id as usize]);
            }
        }
        self.busy.sweep_from = to;
        self.busy.transfers_left -= out.len();
    }

    /// Puts a busy mover back into the dynamic index with its current box and own space.
    /// Returns false when the index refused it: it is then out of the trees, and the caller
    /// reports it.
    fn settle_busy(&mut self, entity: Entity, bounds: Aabb, frame: LocalFrame) -> bool {
        let Some(t) = self.tracked(entity).filter(|t| t.tree == TreeSlot::Busy) else {
            return true;
        };
        self.index
            .busy_movers_mut()
            .remove(entity.index_u32(), busy_tag(entity));
        self.pending_upkeep = true;
        self.slots[t.slot as usize] = SlotEntry::new(entity, bounds, frame);
        let tree = match self.index.insert(t.slot, bounds) {
            Ok(handle) => TreeSlot::Dynamic(handle),
            Err(_) => {
                self.tracked_by_index[entity.index_u32() as usize] = None;
                self.tracked_count -= 1;
                self.release_slot(t.slot);
                return false;
            }
        };
        if let Some(Some(record)) = self.tracked_by_index.get_mut(entity.index_u32() as usize) {
            record.tree = tree;
        }
        true
    }

    /// Computes again the bounds of the busy movers' chunks that a move left (see
    /// [`KeyedList::tighten_chunk_bounds`](spatial_accel::query::KeyedList)), once the
    /// frame's moves are written: until then queries test each entry of those chunks.
    pub(crate) fn tighten_busy_chunk_bounds(&mut self) -> usize {
        self.index.busy_movers_mut().tighten_chunk_bounds()
    }

    /// Puts the busy movers that stopped moving back into the dynamic index, a sweep's worth
    /// a frame (all of them, over frames, once movers may not be busy). `now` gives an
    /// entity's current world box and own space, or `None` when it is gone or its transform
    /// is no longer valid: it is then taken out of the trees. Returns how many went back;
    /// those taken out instead (or refused by the index) are pushed to `dropped`, for the
    /// caller to report.
    pub(crate) fn settle_quiet_busy_movers(
        &mut self,
        settings: &BusyMoverSettings,
        mut now: impl FnMut(Entity) -> Option<(Aabb, LocalFrame)>,
        dropped: &mut Vec<Entity>,
    ) -> usize {
        let mut quiet = Vec::new();
        self.quiet_busy_movers(
            settings.quiet_frames,
            settings.checks(self.busy_len()),
            &mut quiet,
        );
        let mut settled = 0;
        for entity in quiet {
            let back = match now(entity) {
                Some((bounds, frame)) => self.settle_busy(entity, bounds, frame),
                // Gone or invalid since its last move: its membership check or its next
                // move says so too; out it goes.
                None => {
                    self.remove(entity);
                    false
                }
            };
            if back {
                settled += 1;
            } else {
                dropped.push(entity);
            }
        }
        settled
    }
}

/// [`AccelTrees::move_busy`] from several threads at once: the sync's moves of busy movers,
/// spread over the compute pool, each thread writing the entries of the entities it met.
pub(crate) struct BusyMoves<'a> {
    moves: ConcurrentMoves<'a>,
    stamp: u32,
}

impl BusyMoves<'_> {
    /// Gives a busy mover its new box, as [`AccelTrees::move_busy`] does; `None` when the
    /// entity is not a busy mover (the caller places it in the trees afterwards).
    ///
    /// # Safety
    /// While this view lives, no two calls (on any threads) may name the same entity.
    #[inline]
    pub(crate) unsafe fn move_busy(&self, entity: Entity, bounds: Aabb) -> Option<Placed> {
        // SAFETY: entities of one index are one entity (a live index has one generation), so
        // the caller's distinct entities are distinct keys.
        let moved = unsafe {
            self.moves
                .set_bounds(entity.index_u32(), busy_tag(entity), bounds, self.stamp)
        }?;
        Some(if moved { Placed::Moved } else { Placed::Same })
    }
}
