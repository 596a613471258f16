//! The tree walks of light views, and the candidates they give: what each light view's
//! decisions run on.
//!
//! A walk drops a subtree only where Bevy's own tests would drop every entity in it. For a
//! frustum: the subtree's box lies wholly behind one of the view's planes; the tree's box holds
//! each entity's oriented box, which is then behind that plane too, and Bevy's test (one plane
//! at a time) rejects it as well. For a light's range: see [`light_sphere_may_reach`].

use super::verdicts::{LightLists, LightVerdicts, pack, walk_lists};
use crate::culling::bevy_rounding::tree_plane;
use crate::culling::slot_order::FoundSlots;
use crate::culling::untracked::UntrackedEntities;
use crate::trees::AccelTrees;
use bevy::camera::primitives::{Frustum, Sphere};
use bevy::math::Vec4;
use bevy::prelude::*;
use spatial_accel::Frustum as AccelFrustum;
use std::collections::HashMap;

/// The planes of a light view as the trees test them. Point and spot lights test all six;
/// directional cascades skip the near plane (a caster may stand before it), so it becomes a
/// half-space holding all space.
pub(super) fn light_planes(frustum: &Frustum, near: bool) -> [Vec4; 6] {
    let mut planes = frustum.half_spaces.map(|h| tree_plane(h.normal_d()));
    if !near {
        planes[AccelFrustum::NEAR] = Vec4::new(0.0, 0.0, 0.0, 1.0);
    }
    planes
}

/// Whether Bevy's light-sphere test (`Sphere::intersects_obb`) can pass for an entity whose
/// box lies in `b`. That test projects the entity's oriented box on one axis only, the line from
/// the light to the box's center, so it passes for long boxes whose every point is out of
/// range: a plain sphere-box overlap would drop entities Bevy keeps. What does hold: the test
/// passes only if the box's center lies within the range plus the box's largest half-extent
/// along that axis, which is at most the half-diagonal of any box holding the entity. Both
/// the center and that box lie in `b`, so `b` can be dropped when it is farther from the light
/// than the range plus its own half-diagonal (with a little slack for rounding).
pub(super) fn light_sphere_may_reach(sphere: &Sphere, b: &spatial_accel::Aabb) -> bool {
    let reach = (sphere.radius + b.half_extents().length()) * (1.0 + 1e-3);
    b.distance_squared_to_point(sphere.center) <= reach * reach
}

/// Above this fraction of the tracked entities found by a light view's walk, the view is
/// decided by a flat parallel pass instead: a candidate's cost on the tree path (one thread,
/// one lookup each) against a caster's in Bevy's loop (the compute pool), both taking the
/// walk's masks (`verdicts`). A directional view finding most of the world costs about the
/// same on either path and one finding a few percent is faster on the tree path, so the
/// crossover lies between (`accel-bench lights`; BENCHMARKS.md, Light culling).
const FLAT_LIGHT_VIEW_ABOVE: f32 = 1.0 / 3.0;

/// A light view's last walk, kept for the next frame. Why: in a still scene a light's walk
/// finds the same entities every frame, and the walk is a large part of a light's pass. Only
/// the walk is kept; the entities are decided again each frame, as
/// visibility, layers and ranges change without the trees.
struct KeptWalk {
    /// What the walk was of, bit for bit (sphere, planes).
    shape: Vec<u32>,
    walked: Vec<(Entity, u16)>,
    /// The frame the entry was last used, so that walks of lights gone are dropped.
    used: u32,
}

/// Which light view a walk was of: the light, and the camera for a directional light's
/// cascades (the light again for point and spot lights).
pub(super) type ViewKey = (Entity, Entity);

/// The entities one light view decides, each once.
#[derive(Default)]
pub(super) struct LightCandidates {
    kept: HashMap<ViewKey, KeptWalk>,
    frame: u32,
    /// Light views this frame whose walk was kept from the last one.
    pub(super) reused: usize,
    found: FoundSlots,
    /// Found by the walk, in slot order, each with the view's lists that hold it and those
    /// that cross its leaf ([`super::verdicts::pack`]'s form). `NoFrustumCulling` ones
    /// among them are skipped: they come again in `others`.
    walked: Vec<(Entity, u16)>,
    /// The view's lists' frusta as the walk tests them (scratch).
    walk_frusta: Vec<spatial_accel::FrustumLanes>,
    /// The shape of the view being gathered (scratch).
    shape: Vec<u32>,
    /// Everything a walk cannot find (see [`UntrackedEntities`]).
    others: Vec<Entity>,
    /// The trees were not current at the last gathering, or its view had more lists than
    /// one walk can tell apart (32).
    stale: bool,
    /// The last gathering skipped the walk: the view took the flat pass last frame and saw
    /// most of the world.
    skipped: bool,
    /// Per view, the fraction of the tracked entities it found (walked, or placed by the flat
    /// pass) last frame, and the frame it was recorded. Kept across tree changes: it decides
    /// whether a walk is worth making at all.
    fractions: HashMap<ViewKey, (f32, u32)>,
    /// The walks of the views decided by the flat pass, kept as masks of their lists.
    pub(super) verdicts: LightVerdicts,
}

impl LightCandidates {
    /// Starts a frame: forgets every kept walk if the trees changed since the last one.
    pub(super) fn start_frame(&mut self, trees_changed: bool) {
        if trees_changed {
            self.kept.clear();
        }
        self.frame = self.frame.wrapping_add(1);
        self.reused = 0;
        self.verdicts.start_frame(trees_changed, self.frame);
    }

    /// Ends a frame: drops the walks of views not seen in it.
    pub(super) fn end_frame(&mut self) {
        let frame = self.frame;
        self.kept.retain(|_, k| k.used == frame);
        self.fractions.retain(|_, (_, used)| *used == frame);
        self.verdicts.end_frame();
    }

    /// Whether the trees were current at the last gathering (they follow the entities).
    pub(super) fn trees_current(&self) -> bool {
        !self.stale
    }

    /// Records what view `view` found this frame: `found` of the `tracked` entities.
    pub(super) fn record(&mut self, view: ViewKey, found: usize, tracked: usize) {
        let fraction = found as f32 / tracked.max(1) as f32;
        self.fractions.insert(view, (fraction, self.frame));
    }

    /// Gathers the candidates of light view `view`: the walk kept from the last frame if it
    /// was of the same `lists` (bit for bit), else what one walk of the trees over all of them
    /// finds. Gathers nothing when the trees are not current: [`Self::flat`] then says so.
    pub(super) fn gather(
        &mut self,
        view: ViewKey,
        lists: &LightLists,
        trees: &AccelTrees,
        untracked: &UntrackedEntities,
    ) {
        self.walked.clear();
        self.others.clear();
        self.stale = !untracked.trees_current() || lists.planes.len() > 32;
        if self.stale {
            self.kept.clear();
            return;
        }
        // A view that saw most of the world last frame takes the flat pass again without
        // walking: a walk of nearly every node would be thrown away.
        self.skipped = self
            .fractions
            .get(&view)
            .is_some_and(|(f, _)| *f > FLAT_LIGHT_VIEW_ABOVE);
        // The walk, and the flat pass's verdicts (`super::verdicts`), read the busy movers:
        // while their boxes are out of date the view tests every caster, and the next sync
        // writes them (see `trees::unread_movers`).
        trees.unread_movers.note_light_read();
        if trees.unread_movers.is_stale() {
            self.stale = true;
            self.kept.clear();
            return;
        }
        if self.skipped {
            return;
        }
        self.others.extend(untracked.iter());
        walk_shape(lists.sphere, lists.planes, &mut self.shape);
        if let Some(kept) = self.kept.get_mut(&view).filter(|k| k.shape == self.shape) {
            kept.used = self.frame;
            self.walked.extend_from_slice(&kept.walked);
            self.reused += 1;
            return;
        }
        let found = &mut self.found;
        found.clear();
        walk_lists(trees, lists, &mut self.walk_frusta, |slot, masks| {
            found.push_with_flags(slot, pack(masks));
        });
        // Slot order is table order, so the decisions read the rows nearly in sequence.
        found.drain_entities_with_flags(trees.slot_entities(), &mut self.walked);
        let kept = self.kept.entry(view).or_insert_with(|| KeptWalk {
            shape: Vec::new(),
            walked: Vec::new(),
            used: 0,
        });
        kept.shape.clone_from(&self.shape);
        kept.walked.clone_from(&self.walked);
        kept.used = self.frame;
    }

    /// Each candidate with, if a walk found it, the masks of its lists (in
    /// [`super::verdicts::pack`]'s form).
    pub(super) fn iter(&self) -> impl Iterator<Item = (Entity, Option<u16>)> + '_ {
        let walked = self.walked.iter().map(|&(e, m)| (e, Some(m)));
        walked.chain(self.others.iter().map(|&e| (e, None)))
    }

    pub(super) fn len(&self) -> usize {
        self.walked.len() + self.others.len()
    }

    /// Whether the view should be decided by the flat loop over every caster: the trees are
    /// stale, or the walk (or last frame's pass) found more than [`FLAT_LIGHT_VIEW_ABOVE`] of
    /// the `tracked` entities, where one lookup per candidate on one thread costs more than a
    /// sequential scan spread over the task pool.
    pub(super) fn flat(&self, tracked: usize) -> bool {
        self.stale
            || self.skipped
            || self.walked.len() as f32 > FLAT_LIGHT_VIEW_ABOVE * tracked as f32
    }

    /// How many entities the last walk found.
    pub(super) fn walked_len(&self) -> usize {
        self.walked.len()
    }
}

/// The bits of a walk's sphere and planes, the key under which it is kept.
pub(super) fn walk_shape(sphere: Option<&Sphere>, planes: &[[Vec4; 6]], out: &mut Vec<u32>) {
    out.clear();
    if let Some(s) = sphere {
        out.extend(s.center.to_array().map(f32::to_bits));
        out.push(s.radius.to_bits());
    }
    for p in planes.iter().flatten() {
        out.extend(p.to_array().map(f32::to_bits));
    }
}
