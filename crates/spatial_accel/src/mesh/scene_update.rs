//! Changing a two-level scene in place: instances that move or change meshes, with the top
//! level refit along their paths, and rebuilt when refits have made it loose.

use super::scene::{PlacedInstance, top_level_over};
use super::{Instance, InstancedScene};
use crate::Aabb;
use crate::bvh::wide::{Bvh8, RefitPaths};
use core::fmt;

/// Why [`InstancedScene::update_instances`] refused an update.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneUpdateError {
    /// No instance has this index. Nothing was changed.
    NoSuchInstance {
        /// The index given.
        instance: u32,
        /// The number of instances in the scene.
        instance_count: usize,
    },
}

impl fmt::Display for SceneUpdateError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NoSuchInstance {
                instance,
                instance_count,
            } => write!(
                f,
                "instance {instance} does not exist (the scene has {instance_count})"
            ),
        }
    }
}

impl std::error::Error for SceneUpdateError {}

/// What [`InstancedScene::update_instances`] keeps between updates to refit the top level
/// and decide when to rebuild it.
#[derive(Clone, Debug)]
pub(super) struct TopLevelUpkeep {
    /// The refit links, made at the first refit after a build (a scene that never changes
    /// never pays for them).
    paths: Option<TopLevelPaths>,
    /// The top level's [`slot_area_cost`](crate::bvh::wide::WideBvh::slot_area_cost) when it
    /// was built, which refits are measured against.
    built_cost: f64,
    /// The top level's [`slot_area_sum`](crate::bvh::wide::WideBvh::slot_area_sum), kept
    /// through refits.
    slot_area: f64,
    /// See [`InstancedScene::set_rebuild_threshold`].
    threshold: f32,
    /// No refit since the last build.
    fresh: bool,
    /// Set when one refit loosened a fresh top level past the threshold: the number of
    /// instances that update changed. Updates that change as many rebuild without refitting
    /// first (see `update_instances`).
    refits_fail_from: Option<usize>,
    /// Rebuilds made without a refit since `refits_fail_from` was set.
    direct_rebuilds: u32,
    /// The indices an update changed: kept between updates, as `pending` is, so that an
    /// update that refits allocates nothing once the first refit has made the paths.
    changed: Vec<u32>,
    /// An update's instances, gathered so that every index is checked before any is
    /// applied (an update is refused whole).
    pending: Vec<(u32, Instance)>,
}

/// After one refit fails to keep a fresh top level, every this many updates that change as
/// many instances try a refit again, in case motion has slowed.
const RETRY_REFIT_EVERY: u32 = 8;

impl TopLevelUpkeep {
    pub(super) fn new(top: &Bvh8) -> Self {
        let mut upkeep = Self {
            paths: None,
            built_cost: 0.0,
            slot_area: 0.0,
            threshold: InstancedScene::DEFAULT_REBUILD_THRESHOLD,
            fresh: true,
            refits_fail_from: None,
            direct_rebuilds: 0,
            changed: Vec::new(),
            pending: Vec::new(),
        };
        upkeep.restart(top);
        upkeep
    }

    /// Starts over on a newly built top level: what was kept of the old tree (its refit
    /// links and cost) goes; the threshold, the record of failed refits and the kept lists
    /// stay.
    fn restart(&mut self, top: &Bvh8) {
        self.paths = None;
        self.built_cost = f64::from(top.slot_area_cost());
        self.slot_area = top.slot_area_sum();
        self.fresh = true;
    }

    /// Whether an update that changes `changed` instances should rebuild straight away.
    fn skip_refit(&mut self, changed: usize) -> bool {
        match self.refits_fail_from {
            Some(from) if changed >= from => {
                self.direct_rebuilds += 1;
                !self.direct_rebuilds.is_multiple_of(RETRY_REFIT_EVERY)
            }
            _ => false,
        }
    }
}

/// The refit links of one top level: valid until it is rebuilt.
#[derive(Clone, Debug)]
struct TopLevelPaths {
    refit: RefitPaths,
    /// The instance at each position of the top level's leaf order.
    instance_at: Vec<u32>,
    /// Each instance's position in that order ([`u32::MAX`]: not in the top level).
    position_of: Vec<u32>,
}

impl TopLevelPaths {
    fn of(top: &Bvh8, instance_count: usize) -> Self {
        let instance_at = top.primitive_indices().to_vec();
        let mut position_of = vec![u32::MAX; instance_count];
        for (position, &instance) in instance_at.iter().enumerate() {
            position_of[instance as usize] = position as u32;
        }
        Self {
            refit: RefitPaths::of(top),
            instance_at,
            position_of,
        }
    }
}

impl InstancedScene {
    /// The default of [`set_rebuild_threshold`](Self::set_rebuild_threshold): refits may
    /// leave the top level 10% looser than when it was built.
    ///
    /// Why 10%: with many instances moving every frame, rays through the updated top level
    /// stay close to a fresh one's at a fraction of a new scene's cost a frame; looser
    /// thresholds save little time for clearly slower rays, and never rebuilding lets rays
    /// fall far behind (BENCHMARKS.md, Mesh builds and instanced scenes).
    pub const DEFAULT_REBUILD_THRESHOLD: f32 = 1.1;

    /// Sets how much looser than when it was built refits may leave the top level before
    /// [`update_instances`](Self::update_instances) rebuilds it, as a ratio of
    /// [`slot_area_cost`](crate::bvh::wide::WideBvh::slot_area_cost)s (the expected slot
    /// boxes a ray enters): [`DEFAULT_REBUILD_THRESHOLD`](Self::DEFAULT_REBUILD_THRESHOLD)
    /// unless set. Higher suits scenes that move much and trace few rays (picking);
    /// [`f32::INFINITY`] never rebuilds on its own. The cost is followed through refits
    /// from the areas they change, with no pass over the tree.
    pub fn set_rebuild_threshold(&mut self, cost_growth: f32) {
        self.upkeep.threshold = cost_growth;
    }

    /// Replaces instances, each given as `(index, new instance)`: a new transform, a new mesh
    /// (a skinned mesh refit into a new [`MeshBvh`](super::MeshBvh)), or both; then brings
    /// the top level up to date. For moving instances, every frame: the updates are gathered
    /// into a list the scene keeps, so an update that refits allocates nothing (pass the
    /// iterator that makes them, e.g. over a query, rather than a `Vec` built for the call).
    ///
    /// Where every changed instance is accepted before and after, the top level is refit
    /// along the changed instances' paths only: a few boxes per instance, where a rebuild
    /// sorts them all. An instance whose new transform is not invertible or not finite is
    /// left out, as [`InstancedScene::new`] does (see
    /// [`rejected_instances`](Self::rejected_instances)), and one left out comes back with
    /// a valid transform; either change rebuilds the top level, so that it always holds the
    /// accepted instances exactly. A refit keeps every answer exact, but the tree's quality
    /// is that of the placement it was built for, so once refits have made it looser than a
    /// threshold ([`set_rebuild_threshold`](Self::set_rebuild_threshold)) it is rebuilt.
    /// Where a single update already loosens a fresh top level that far (instances moving
    /// their own size each frame), later updates that change as many instances rebuild
    /// without refitting first, trying a refit again every eighth time.
    ///
    /// # Errors
    ///
    /// [`SceneUpdateError::NoSuchInstance`] for an index past the last instance; nothing is
    /// changed then. An index given twice takes its last instance.
    ///
    /// ```
    /// use spatial_accel::{Backfaces, Ray};
    /// use spatial_accel::mesh::{Instance, InstancedScene, MeshBvh};
    /// use glam::{Affine3A, Vec3, Vec3A};
    /// use std::sync::Arc;
    /// let quad = Arc::new(MeshBvh::new(
    ///     &[Vec3::new(-1., -1., 0.), Vec3::new(1., -1., 0.), Vec3::new(1., 1., 0.), Vec3::new(-1., 1., 0.)],
    ///     &[0, 1, 2, 0, 2, 3],
    /// ).unwrap());
    /// let at = |z: f32| Instance { mesh: quad.clone(), world_from_local: Affine3A::from_translation(Vec3::new(0., 0., z)) };
    /// let mut scene = InstancedScene::new(vec![at(-10.0), at(-5.0)]);
    /// let ray = Ray::new(Vec3A::ZERO, Vec3A::NEG_Z);
    /// assert_eq!(scene.cast_ray(&ray, Backfaces::Include).unwrap().instance, 1);
    /// // Instance 1 moves behind instance 0.
    /// scene.update_instances([(1, at(-20.0))]).unwrap();
    /// let hit = scene.cast_ray(&ray, Backfaces::Include).unwrap();
    /// assert_eq!((hit.instance, hit.hit.t), (0, 10.0));
    /// assert!(scene.update_instances([(2, at(0.0))]).is_err());
    /// ```
    pub fn update_instances(
        &mut self,
        updates: impl IntoIterator<Item = (u32, Instance)>,
    ) -> Result<(), SceneUpdateError> {
        let mut pending = core::mem::take(&mut self.upkeep.pending);
        pending.extend(updates);
        let instance_count = self.instances.len();
        if let Some(&(instance, _)) = pending.iter().find(|(i, _)| *i as usize >= instance_count) {
            pending.clear();
            self.upkeep.pending = pending;
            return Err(SceneUpdateError::NoSuchInstance {
                instance,
                instance_count,
            });
        }
        let mut membership_changed = false;
        let mut changed = core::mem::take(&mut self.upkeep.changed);
        changed.clear();
        for (i, instance) in pending.drain(..) {
            let at = i as usize;
            let placed = PlacedInstance::place(instance);
            membership_changed |= self.instances[at].is_some() != placed.is_some();
            self.boxes[at] = placed.as_ref().map_or(Aabb::EMPTY, |(_, b)| *b);
            self.instances[at] = placed.map(|(p, _)| p);
            changed.push(i);
        }
        self.upkeep.pending = pending;
        let changed_count = changed.len();
        if membership_changed {
            self.rejected = (0..)
                .zip(&self.instances)
                .filter_map(|(i, p)| p.is_none().then_some(i))
                .collect();
        }
        if membership_changed || self.upkeep.skip_refit(changed_count) {
            self.rebuild_top_level();
            self.upkeep.changed = changed;
            return Ok(());
        }
        let Self {
            top, boxes, upkeep, ..
        } = self;
        let paths = upkeep
            .paths
            .get_or_insert_with(|| TopLevelPaths::of(top, instance_count));
        // Rejected instances (before and after, or membership would have changed) are not in
        // the top level.
        let moved = changed
            .iter()
            .map(|&i| paths.position_of[i as usize])
            .filter(|&position| position != u32::MAX);
        let instance_at = &paths.instance_at;
        upkeep.slot_area += top
            .refit_moved_area_change(&mut paths.refit, moved, |k| boxes[instance_at[k] as usize]);
        // The cost divides by the root's area, so a scene that only grows or shrinks as a
        // whole (every instance scaled about one point) does not count as looser.
        let root = f64::from(top.bounds().half_area());
        let loose =
            root > 0.0 && upkeep.slot_area / root > upkeep.built_cost * f64::from(upkeep.threshold);
        upkeep.changed = changed;
        if !loose {
            upkeep.fresh = false;
            upkeep.refits_fail_from = None;
            return Ok(());
        }
        // Why: where one update's motion loosens a fresh tree past the threshold (instances
        // moving their own size every frame), the refit is wasted work before the rebuild:
        // with many instances all moving it makes a frame markedly dearer than the rebuild
        // alone (BENCHMARKS.md, Mesh builds and instanced scenes).
        if upkeep.fresh {
            upkeep.refits_fail_from = Some(changed_count);
            upkeep.direct_rebuilds = 0;
        }
        self.rebuild_top_level();
        Ok(())
    }

    /// Rebuilds the top level over the instances' current boxes, as
    /// [`update_instances`](Self::update_instances) does once refits have left it loose.
    pub fn rebuild_top_level(&mut self) {
        self.top = top_level_over(&self.boxes);
        self.upkeep.restart(&self.top);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::MeshBvh;
    use glam::{Affine3A, Vec3};
    use std::sync::Arc;

    fn scattered(mesh: &Arc<MeshBvh>, count: usize, seed: u64) -> Vec<(u32, Instance)> {
        let mut next = crate::test_floats(seed);
        (0..count as u32)
            .map(|i| {
                let at = Vec3::new(next(), next(), next()) * 100.0;
                let instance = Instance {
                    mesh: mesh.clone(),
                    world_from_local: Affine3A::from_translation(at),
                };
                (i, instance)
            })
            .collect()
    }

    /// An update that scatters every instance loosens the fresh top level past the
    /// threshold at once: it is noted, and later updates as large skip the refit, all but
    /// every eighth; smaller ones, and any refit that holds, go back to refitting.
    #[test]
    fn refits_that_cannot_hold_are_skipped() {
        let quad = Arc::new(MeshBvh::new(&[Vec3::ZERO, Vec3::X, Vec3::Y], &[0, 1, 2]).unwrap());
        let count = 300;
        let mut scene = InstancedScene::new(
            scattered(&quad, count, 1)
                .into_iter()
                .map(|(_, i)| i)
                .collect(),
        );
        assert_eq!(scene.upkeep.refits_fail_from, None);
        let moves = scattered(&quad, count, 2);
        let mut nudged = moves[0].1.clone();
        scene.update_instances(moves).unwrap();
        assert_eq!(scene.upkeep.refits_fail_from, Some(count));
        let skipped: Vec<bool> = (0..RETRY_REFIT_EVERY)
            .map(|_| scene.upkeep.skip_refit(count))
            .collect();
        let mut expected = vec![true; RETRY_REFIT_EVERY as usize - 1];
        expected.push(false);
        assert_eq!(skipped, expected);
        assert!(!scene.upkeep.skip_refit(count - 1));
        // A small move holds: refitting resumes for every size.
        scene.rebuild_top_level();
        nudged.world_from_local =
            Affine3A::from_translation(Vec3::splat(0.01)) * nudged.world_from_local;
        scene.update_instances([(0, nudged)]).unwrap();
        assert_eq!(scene.upkeep.refits_fail_from, None);
    }
}
