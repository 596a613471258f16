//! The queries that decide a view's entities, and deciding one entity through them: Bevy's
//! per-entity rules, with its frustum test.

use crate::culling::bevy_rules::{ViewFilter, bevy_frustum_test};
use crate::culling::class_lists::ClassLists;
use crate::culling::stats::CullingStats;
use bevy::camera::primitives::{Aabb, Frustum, Sphere};
use bevy::camera::visibility::{
    NoCpuCulling, NoFrustumCulling, RenderLayers, SetViewVisibility, VisibilityClass,
    VisibilityRange,
};
use bevy::prelude::*;

/// What deciding an entity reads and writes, bounds aside.
pub(crate) type DecideItem = (
    Entity,
    &'static InheritedVisibility,
    &'static mut ViewVisibility,
    Option<&'static VisibilityClass>,
    Option<&'static RenderLayers>,
    Has<VisibilityRange>,
);

/// The entities a tree walk decides: those the flat pass's query holds (`GlobalTransform`
/// included, which Bevy's own query requires), less `NoFrustumCulling` ones, which are decided
/// with the entities the trees do not hold (a walk would miss them outside the view).
pub(crate) type DecideFilter = (
    Without<NoCpuCulling>,
    With<GlobalTransform>,
    Without<NoFrustumCulling>,
);

/// What Bevy's exact frustum test reads.
pub(crate) type BoundsItem = (
    Entity,
    Option<&'static Aabb>,
    Option<&'static Sphere>,
    &'static GlobalTransform,
);

/// One view's decisions: Bevy's rules for each entity, its frustum test where asked.
pub(crate) struct ViewPass<'a, 'w, 's> {
    pub(crate) filter: ViewFilter<'a>,
    pub(crate) frustum: &'a Frustum,
    pub(crate) no_cpu_culling_view: bool,
    pub(crate) deciding: &'a mut Query<'w, 's, DecideItem, DecideFilter>,
    pub(crate) bounds: &'a Query<'w, 's, BoundsItem, Without<NoCpuCulling>>,
    pub(crate) lists: &'a mut ClassLists,
    pub(crate) stats: &'a mut CullingStats,
}

impl ViewPass<'_, '_, '_> {
    /// Decides one entity as Bevy's `check_visibility_cpu_culling` does, frustum test
    /// included.
    pub(crate) fn decide_exact(&mut self, entity: Entity) {
        let Ok((entity, inherited, mut view_visibility, class, layers, has_range)) =
            self.deciding.get_mut(entity)
        else {
            return;
        };
        if !self.filter.admits(entity, inherited, layers, has_range) {
            return;
        }
        let Ok((_, aabb, sphere, transform)) = self.bounds.get(entity) else {
            return;
        };
        if !self.no_cpu_culling_view {
            self.stats.tested += 1;
            if !bevy_frustum_test(self.frustum, aabb, sphere, transform) {
                return;
            }
        }
        self.stats.visible += 1;
        view_visibility.set_visible();
        if let Some(class) = class {
            self.lists.push(class, entity);
        }
    }
}
