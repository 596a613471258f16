//! Tests of [`AccelTrees`](super::AccelTrees)' slot bookkeeping.

use super::{AccelTrees, LocalFrame, Placed};
use bevy::math::Vec3;
use bevy::prelude::Entity;
use spatial_accel::Aabb;

/// Bevy hands a despawned entity's index to a new entity. When the newcomer is placed
/// before the dead entity's removal is processed, the dead one must leave the trees then,
/// and its late removal must not take the newcomer out.
#[test]
fn a_reused_index_evicts_the_dead_entity_and_keeps_the_new_one() {
    for is_static in [false, true] {
        let mut trees = AccelTrees::default();
        let dead = Entity::from_raw_u32(5).unwrap();
        let newcomer =
            Entity::from_index_and_generation(dead.index(), dead.generation().after_versions(1));
        let other = Entity::from_raw_u32(9).unwrap();
        let bounds = Aabb::new(Vec3::ZERO, Vec3::ONE);
        let frame = LocalFrame::NONE;
        assert_eq!(
            trees.place(other, bounds, frame, is_static),
            Placed::Inserted
        );
        assert_eq!(
            trees.place(dead, bounds, frame, is_static),
            Placed::Inserted
        );
        assert_eq!(
            trees.place(newcomer, bounds, frame, is_static),
            Placed::Inserted
        );
        assert!(!trees.contains(dead) && trees.contains(newcomer));
        assert!(!trees.remove(dead), "the dead entity was already evicted");
        assert!(trees.contains(newcomer) && trees.contains(other));
        assert_eq!(trees.len(), 2);
        trees.advance_static(usize::MAX, crate::StaticTreeBuild::default());
        let held = trees.query().dynamic_len() + trees.static_len();
        assert_eq!(held, 2, "each entity in exactly one tree, once");
        let mut listed: Vec<Entity> = trees.iter().map(|(e, _)| e).collect();
        listed.sort();
        let mut expected = vec![newcomer, other];
        expected.sort();
        assert_eq!(listed, expected);
        assert!(trees.remove(newcomer) && trees.remove(other));
        assert!(trees.is_empty() && trees.iter().next().is_none());
    }
}

/// The entity a ray reads from a slot's record is the one the packed array (culling's)
/// names, through placements in both trees, moves, moves between the trees, removals and
/// slots handed to new entities.
#[test]
fn slot_records_and_the_packed_array_name_the_same_entity() {
    let mut trees = AccelTrees::default();
    let entity = |i: u32| Entity::from_raw_u32(i).unwrap();
    let frame = LocalFrame::NONE;
    let at = |x: f32| Aabb::new(Vec3::splat(x), Vec3::splat(x + 1.0));
    let agree = |trees: &AccelTrees, step: &str| {
        for (slot, packed) in trees.slot_entities().iter().enumerate() {
            assert_eq!(trees.entity(slot as u32), *packed, "{step}, slot {slot}");
        }
    };
    for i in 0..40 {
        trees.place(entity(i), at(i as f32), frame, i % 3 == 0);
    }
    agree(&trees, "placed");
    for i in 0..40 {
        trees.place(entity(i), at(i as f32 + 0.5), frame, i % 3 == 0);
    }
    agree(&trees, "moved");
    for i in (0..40).step_by(4) {
        trees.place(entity(i), at(i as f32), frame, i % 3 != 0);
    }
    agree(&trees, "moved between trees");
    for i in (0..40).step_by(5) {
        assert!(trees.remove(entity(i)));
    }
    agree(&trees, "removed");
    for i in 100..110 {
        trees.place(entity(i), at(i as f32), frame, i % 2 == 0);
    }
    agree(&trees, "slots reused");
    trees.advance_static(usize::MAX, crate::StaticTreeBuild::default());
    agree(&trees, "static tree rebuilt");
}
