//! The trees' word on a light view's caster tests.
//!
//! Bevy tests every shadow caster against every light view: a point light's sphere test and
//! then six oriented-box tests, one per cube face; a spot light's sphere and frustum; a sun's
//! cascades, one frustum each. One walk of the trees over all of a view's lists at once
//! ([`spatial_accel::SpatialQuery::for_each_in_views`]) settles most of these tests: a caster whose
//! tree box lies wholly inside a list's frustum (and the light's range) goes into that list
//! with no test, one whose tree box lies outside it is not tested for it, and only the lists
//! whose boundary crosses its leaf get Bevy's test.
//!
//! Both light passes use it. The tree path keeps the masks with each candidate the walk
//! found ([`super::walks::LightCandidates`]); a view decided by the flat loop over every
//! caster (it reaches most of the world) keeps them per tree slot ([`LightVerdicts`]), and a
//! caster no list reached is then dropped after one read, as in the camera flat pass
//! (`TreeVerdicts`, in `camera/flat_pass`).

use super::views::CasterTest;
use super::walks::{ViewKey, light_sphere_may_reach, walk_shape};
use crate::culling::bevy_rounding::grown_past_rounding;
use crate::trees::AccelTrees;
use bevy::camera::primitives::{Aabb, Sphere};
use bevy::math::Vec4;
use bevy::prelude::*;
use spatial_accel::SpatialQuery;
use spatial_accel::query::views::{ViewClassification, ViewMasks};
use spatial_accel::{Aabb as AccelAabb, Containment, Frustum as AccelFrustum, FrustumLanes};
use std::collections::HashMap;

/// Most lists a light view may have for the trees to settle its tests: a point light has six
/// cube faces, a directional light four cascades by default. A view with more is tested
/// caster by caster.
pub(super) const MAX_SETTLED_LISTS: usize = 8;

/// Per tree slot, the lists (bit i = list i) whose tree walk held the slot's tree box wholly
/// (low byte) and those whose boundary crossed its leaf (high byte). Zero: no list reached it.
///
/// Why by slot, not by entity: the walk emits slots in tree order, which is random in the
/// entity index, and an entity lookup per slot (one random read each, a million per walk of
/// a far-reaching light) cost more than the masks themselves; the flat loop meets entities
/// in table order and reads their slot anyway, to know whether the trees hold them.
#[derive(Default)]
pub(super) struct ListMasks(Vec<u16>);

impl ListMasks {
    fn clear(&mut self) {
        self.0.fill(0);
    }

    #[inline]
    fn set(&mut self, slot: u32, masks: ViewMasks) {
        let i = slot as usize;
        if self.0.len() <= i {
            self.0.resize(i + 1, 0);
        }
        self.0[i] = pack(masks);
    }

    /// `(inside, crossing)` for `slot`.
    #[inline]
    fn get(&self, slot: u32) -> (u32, u32) {
        unpack(self.0.get(slot as usize).copied().unwrap_or(0))
    }
}

/// A walk's masks in 16 bits: the lists holding the box (low byte), those crossing its leaf
/// (high byte). Both fit a byte: masks are kept only for views of at most
/// [`MAX_SETTLED_LISTS`] lists.
pub(super) fn pack(masks: ViewMasks) -> u16 {
    (masks.inside as u16 & 0xff) | ((masks.crossing as u16 & 0xff) << 8)
}

/// `(inside, crossing)` from [`pack`]'s form.
#[inline]
pub(super) fn unpack(m: u16) -> (u32, u32) {
    (u32::from(m & 0xff), u32::from(m >> 8))
}

/// Walks the trees once over all of a light view's `lists`, calling `visit(slot, masks)` for
/// each slot some list reaches. `walk_frusta` is scratch. At most 32 lists (one bit each).
pub(super) fn walk_lists(
    trees: &AccelTrees,
    lists: &LightLists,
    walk_frusta: &mut Vec<FrustumLanes>,
    visit: impl FnMut(u32, ViewMasks),
) {
    debug_assert!(lists.planes.len() <= 32);
    // Built once per walk: a frustum normalises its planes.
    walk_frusta.clear();
    walk_frusta.extend(
        lists
            .planes
            .iter()
            .map(|p| FrustumLanes::new(&AccelFrustum::from_planes(*p))),
    );
    let all = match lists.planes.len() {
        0 => 0,
        n => u32::MAX >> (32 - n),
    };
    trees.index().for_each_in_views(
        all,
        |b, undecided| classify_for_lists(lists, walk_frusta, b, undecided),
        visit,
    );
}

/// A light view's lists as the walk classifies boxes: the light's range (point and spot
/// lights) and one frustum per list.
pub(super) struct LightLists<'a> {
    /// The light's range (point and spot lights; `None` for cascades).
    pub(super) sphere: Option<&'a Sphere>,
    /// Each list's frustum, as the trees test it ([`super::walks::light_planes`]: a
    /// half-space Bevy's test cannot reject by holds all space, so a box inside every plane
    /// passes Bevy's test).
    pub(super) planes: &'a [[Vec4; 6]],
    /// The lists together cover every direction around the light (a point light's cube
    /// faces), so where the range is undecided they prune nothing (see
    /// [`classify_for_lists`]).
    pub(super) cover_every_direction: bool,
}

/// How the tree box `b` stands with the lists of `undecided` (`walk_frusta`: the frusta of
/// `lists`, within its range when it has one). The box is grown past rounding first, as for
/// camera walks (see `bevy_rounding`).
fn classify_for_lists(
    lists: &LightLists,
    walk_frusta: &[FrustumLanes],
    b: &AccelAabb,
    undecided: u32,
) -> ViewClassification {
    let mut c = ViewClassification::default();
    if let Some(sphere) = lists.sphere
        && !light_sphere_may_reach(sphere, b)
    {
        c.outside = undecided;
        return c;
    }
    let grown = grown_past_rounding(b);
    let in_range = lists.sphere.is_none_or(|s| surely_within_range(s, &grown));
    if !in_range && lists.cover_every_direction {
        // Across the range's boundary a cube's six faces prune no subtree and cannot hold a
        // box (that needs the range), yet classifying them costs six frustum tests per node,
        // a cost moving point lights would pay at every node. They are classified once in
        // range; boxes that never get there keep every face undecided and get Bevy's full
        // tests. (A spot light's frustum does prune, so it is classified everywhere.)
        return c;
    }
    let mut todo = undecided;
    while todo != 0 {
        let i = todo.trailing_zeros() as usize;
        todo &= todo - 1;
        let bit = 1 << i;
        match walk_frusta[i].classify_aabb(&grown) {
            Containment::Outside => c.outside |= bit,
            Containment::Inside if in_range => c.inside |= bit,
            Containment::Inside | Containment::Intersecting => {}
        }
    }
    c
}

/// Whether Bevy's light-sphere test (`Sphere::intersects_obb`) passes for every entity whose
/// box lies in `b`: it passes when the box's center is within the range, and the center lies
/// in `b`, so `b`'s farthest corner within the range (less a relative allowance for the
/// test's rounding) suffices.
fn surely_within_range(sphere: &Sphere, b: &AccelAabb) -> bool {
    let reach = sphere.radius * (1.0 - 1e-3);
    let far = (b.min - sphere.center)
        .abs()
        .max((b.max - sphere.center).abs());
    reach > 0.0 && far.length_squared() <= reach * reach
}

/// A walk's masks, kept while neither the trees nor the view change (as light walks are).
struct KeptMasks {
    /// What the walk was of, bit for bit.
    shape: Vec<u32>,
    masks: ListMasks,
    used: u32,
}

/// The flat light views' walks, one per view.
#[derive(Default)]
pub(super) struct LightVerdicts {
    kept: HashMap<ViewKey, KeptMasks>,
    frame: u32,
    /// The shape of the view being walked (scratch).
    shape: Vec<u32>,
    /// Its lists' frusta as the walk tests them (scratch).
    walk_frusta: Vec<FrustumLanes>,
}

impl LightVerdicts {
    /// Starts a frame: the trees changed, so no kept walk holds.
    pub(super) fn start_frame(&mut self, trees_changed: bool, frame: u32) {
        if trees_changed {
            self.kept.values_mut().for_each(|k| k.shape.clear());
        }
        self.frame = frame;
    }

    /// Drops the walks of views not seen this frame.
    pub(super) fn end_frame(&mut self) {
        let frame = self.frame;
        self.kept.retain(|_, k| k.used == frame);
    }

    /// Walks view `view`'s `lists` over the trees into masks ([`Self::masks`]), unless the
    /// walk of the same lists (sphere and planes, bit for bit) is kept. Returns whether it was
    /// kept.
    pub(super) fn walk(&mut self, view: ViewKey, trees: &AccelTrees, lists: &LightLists) -> bool {
        walk_shape(lists.sphere, lists.planes, &mut self.shape);
        let frame = self.frame;
        let kept = self.kept.entry(view).or_insert_with(|| KeptMasks {
            shape: Vec::new(),
            masks: ListMasks::default(),
            used: frame,
        });
        kept.used = frame;
        if !kept.shape.is_empty() && kept.shape == self.shape {
            return true;
        }
        kept.shape.clone_from(&self.shape);
        kept.masks.clear();
        let masks = &mut kept.masks;
        walk_lists(trees, lists, &mut self.walk_frusta, |slot, m| {
            masks.set(slot, m)
        });
        false
    }

    /// The masks of view `view`'s last walk this frame.
    pub(super) fn masks(&self, view: ViewKey) -> Option<&ListMasks> {
        self.kept
            .get(&view)
            .filter(|k| k.used == self.frame && !k.shape.is_empty())
            .map(|k| &k.masks)
    }
}

/// What the trees settled for one flat light view: the walk's masks, and which entities the
/// trees hold (the rest get Bevy's tests).
#[derive(Clone, Copy)]
pub(super) struct CasterVerdicts<'a> {
    pub(super) masks: &'a ListMasks,
    pub(super) trees: &'a AccelTrees,
}

impl CasterVerdicts<'_> {
    /// `(inside, crossing)` lists of a caster, or `None` where the trees cannot speak for it:
    /// not in the trees, `NoFrustumCulling` (placed everywhere), or without the bounds Bevy
    /// tests (a caster with no `Aabb` is placed everywhere too).
    #[inline]
    pub(super) fn lists(&self, entity: Entity, nfc: bool, has_bounds: bool) -> Option<(u32, u32)> {
        if !has_bounds || nfc {
            return None;
        }
        let (slot, _) = self.trees.tracked_location(entity)?;
        Some(self.masks.get(slot))
    }
}

impl CasterTest<'_> {
    /// [`CasterTest::place`] with the trees' verdicts for a caster they hold: lists in
    /// `inside` take it untested (the light's range passed too), lists in `crossing` get
    /// Bevy's tests, other lists lie outside it. Returns whether any list took it.
    pub(super) fn place_settled(
        &self,
        entity: Entity,
        aabb: &Aabb,
        transform: &GlobalTransform,
        (inside, crossing): (u32, u32),
        lists: &mut [Vec<Entity>],
    ) -> bool {
        // Only the lists named in a mask are visited (a caster is in one or two of a cube's
        // six faces): a loop over every list cost more than the decisions themselves.
        let mut held = inside;
        while held != 0 {
            lists[held.trailing_zeros() as usize].push(entity);
            held &= held - 1;
        }
        let mut visible = inside != 0;
        if crossing == 0 {
            return visible;
        }
        let model = transform.affine();
        // A list holding the caster wholly holds it within the light's range; else the range
        // test comes first, and failing it places nothing, as in Bevy.
        if inside == 0 && self.sphere.is_some_and(|s| !s.intersects_obb(aabb, &model)) {
            return false;
        }
        let mut crossed = crossing;
        while crossed != 0 {
            let i = crossed.trailing_zeros() as usize;
            crossed &= crossed - 1;
            if self.frusta[i].intersects_obb(aabb, &model, self.near, true) {
                lists[i].push(entity);
                visible = true;
            }
        }
        visible
    }
}
