//! The least any upkeep of movers can cost: the sync suite's peer.
//!
//! Bevy keeps no trees, so the plugin's upkeep has no peer to stand beside. What every design
//! pays, whatever its structure, is finding the movers (Bevy's `Changed` scan), reading their
//! `GlobalTransform` and `Aabb` rows, taking their world boxes, and storing each box where a
//! query can reach it. This app does exactly that and nothing more: one 32-byte box stored at
//! the entity's index, in the frame and place the plugin's sync runs. The gap between it and
//! the plugin's sync is what the plugin's own records and structures cost per mover.

use bevy::camera::primitives::Aabb;
use bevy::prelude::*;
use std::time::{Duration, Instant};

/// Each entity's last world box, by entity index: the least a query needs of a mover.
#[derive(Resource, Default)]
pub struct FloorBoxes {
    boxes: Vec<spatial_accel::Aabb>,
    /// The time the last frame's pass took.
    pub elapsed: Duration,
    /// Movers the last frame's pass stored.
    pub moved: usize,
}

/// The bare pass: the plugin's own placement maths (`spatial_accel::Aabb::transformed`), its finite
/// check, and one store.
fn store_moved_boxes(
    moved: Query<(Entity, &Aabb, &GlobalTransform), Changed<GlobalTransform>>,
    mut floor: ResMut<FloorBoxes>,
) {
    let start = Instant::now();
    let floor = &mut *floor;
    let mut count = 0;
    moved.iter().for_each(|(entity, aabb, transform)| {
        let local = spatial_accel::Aabb::from_center_half_extents(aabb.center, aabb.half_extents);
        let world = local.transformed(&transform.affine());
        if !world.is_finite() {
            return;
        }
        let index = entity.index_u32() as usize;
        if floor.boxes.len() <= index {
            floor.boxes.resize(index + 1, spatial_accel::Aabb::EMPTY);
        }
        floor.boxes[index] = world;
        count += 1;
    });
    floor.moved = count;
    floor.elapsed = start.elapsed();
}

/// Adds the bare pass where the plugin's sync would run (after transform propagation).
pub fn add_floor(app: &mut App) {
    app.init_resource::<FloorBoxes>().add_systems(
        PostUpdate,
        store_moved_boxes.after(TransformSystems::Propagate),
    );
}
