//! Bevy's own per-entity culling rules: which entities a view admits ([`ViewFilter`]) and
//! Bevy's frustum test ([`bevy_frustum_test`]), asked by every culling path.

use bevy::camera::primitives::{Aabb, Frustum, Sphere};
use bevy::camera::visibility::{RenderLayers, VisibleEntityRanges};
use bevy::prelude::*;

/// The per-entity rules Bevy applies before any frustum test: the entity is visible in the
/// hierarchy, shares a render layer with the view, and is within its visibility range. Every
/// culling path (flat, tree, light views) asks it, so they cannot drift apart.
#[derive(Clone, Copy)]
pub(crate) struct ViewFilter<'a> {
    /// The view whose distance decides visibility ranges. `None` hides every entity that has
    /// a range, as Bevy's point and spot light pass does when no view can be the shadow LOD
    /// origin.
    pub(crate) view: Option<Entity>,
    pub(crate) mask: &'a RenderLayers,
    pub(crate) ranges: Option<&'a VisibleEntityRanges>,
}

impl ViewFilter<'_> {
    #[inline]
    pub(crate) fn admits(
        &self,
        entity: Entity,
        inherited: &InheritedVisibility,
        layers: Option<&RenderLayers>,
        has_range: bool,
    ) -> bool {
        inherited.get() && self.admits_in_layers(entity, self.in_layers(layers), has_range)
    }

    /// Whether the view sees `layers` (an entity without `RenderLayers` is on layer 0).
    #[inline]
    pub(crate) fn in_layers(&self, layers: Option<&RenderLayers>) -> bool {
        self.mask.intersects(layers.unwrap_or_default())
    }

    /// [`Self::admits`] for an entity visible in the hierarchy, with [`Self::in_layers`]
    /// already answered (it is the same for every entity of a table without `RenderLayers`).
    #[inline]
    pub(crate) fn admits_in_layers(
        &self,
        entity: Entity,
        in_layers: bool,
        has_range: bool,
    ) -> bool {
        in_layers
            && !(has_range
                && self.ranges.is_some_and(|r| {
                    self.view
                        .is_none_or(|view| !r.entity_is_in_range_of_view(entity, view))
                }))
    }
}

/// Bevy's own per-entity test: a bounding sphere first, then the oriented box, near plane
/// included and far plane excluded; entities with neither `Aabb` nor `Sphere` pass.
pub(crate) fn bevy_frustum_test(
    frustum: &Frustum,
    aabb: Option<&Aabb>,
    sphere: Option<&Sphere>,
    transform: &GlobalTransform,
) -> bool {
    if let Some(aabb) = aabb {
        let world_from_local = transform.affine();
        let model_sphere = Sphere {
            center: world_from_local.transform_point3a(aabb.center),
            radius: transform.radius_vec3a(aabb.half_extents),
        };
        frustum.intersects_sphere(&model_sphere, false)
            && frustum.intersects_obb(aabb, &world_from_local, true, false)
    } else if let Some(sphere) = sphere {
        frustum.intersects_sphere(sphere, false)
    } else {
        true
    }
}
