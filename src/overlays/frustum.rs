//! The culling view's frustum, to see from another camera what it keeps.

use super::budget::LineBudget;
use super::{AccelGizmos, AccelOverlaySettings, culling_view};
use crate::AccelTrees;
use bevy::camera::primitives::Frustum;
use bevy::prelude::*;
use spatial_accel::Frustum as AccelFrustum;

const FRUSTUM: Color = Color::srgb(1.0, 0.85, 0.1);

/// Draws the culling view's frustum: its near and far faces and the four edges between. A far
/// plane at infinity (Bevy's perspective) is drawn at the far side of everything the trees
/// hold, which is as far as culling can matter.
pub(crate) fn draw_culling_frustum(
    settings: Res<AccelOverlaySettings>,
    trees: Res<AccelTrees>,
    cameras: Query<(Entity, &Camera, &GlobalTransform, &Frustum)>,
    mut budget: ResMut<LineBudget>,
    mut gizmos: Gizmos<AccelGizmos>,
) {
    let Some(view) = culling_view(&settings, cameras.iter().map(|(e, c, ..)| (e, c))) else {
        return;
    };
    let Ok((_, _, transform, frustum)) = cameras.get(view) else {
        return;
    };
    let world = trees.query().bounds();
    let reach = if world.is_valid() {
        let eye = transform.translation_vec3a();
        // The farthest corner of the world box bounds every distance to it.
        (world.max - eye)
            .abs()
            .max((world.min - eye).abs())
            .length()
    } else {
        100.0
    };
    let planes = frustum.half_spaces.map(|h| h.normal_d());
    let Some(corners) = AccelFrustum::from_planes(planes).corners(reach) else {
        return;
    };
    if !budget.take(12) {
        return;
    }
    let c = corners.map(Vec3::from);
    for i in 0..4 {
        let j = (i + 1) % 4;
        gizmos.line(c[i], c[j], FRUSTUM);
        gizmos.line(c[4 + i], c[4 + j], FRUSTUM);
        gizmos.line(c[i], c[4 + i], FRUSTUM);
    }
}
