//! Every [`DynamicIndex`] through a long run of random edits, mirrored in a plain map and
//! compared with the brute-force oracle.

use crate::spatial::check_queries;
use accel_testkit::Rng;
use glam::Vec3A;
use spatial_accel::Aabb;
use spatial_accel::query::{DynamicIndex, IndexError};
use std::collections::HashMap;
use std::time::Duration;

/// Half the side of the cube the boxes move in.
const EXTENT: f32 = 50.0;

/// Runs `rounds` rounds of inserts, moves (small and far), removals and refused edits on
/// `index`, maintaining and checking every query after each round.
pub fn check_edits<I: DynamicIndex>(name: &str, mut index: I, rounds: usize, seed: u64) {
    let mut rng = Rng::new(seed);
    let mut model: HashMap<u32, (I::Handle, Aabb)> = HashMap::new();
    let mut removed: Vec<I::Handle> = Vec::new();
    let mut next_id = 0u32;
    for round in 0..rounds {
        for _ in 0..rng.below(40) + 1 {
            match rng.below(10) {
                0..=3 => {
                    let b = random_box(&mut rng);
                    let h = index.insert(next_id, b).expect("valid insert");
                    model.insert(next_id, (h, b));
                    next_id += 1;
                }
                4..=7 if !model.is_empty() => {
                    let id = *model.keys().nth(rng.below(model.len())).unwrap();
                    let (h, old) = model[&id];
                    let b = if rng.chance(0.8) {
                        // A small step, which a fat leaf or a loose cell absorbs.
                        let step = rng.vec3a(-0.3, 0.3);
                        Aabb::new(old.min + step, old.max + step)
                    } else {
                        random_box(&mut rng)
                    };
                    index.update(h, b).expect("valid update");
                    model.insert(id, (h, b));
                }
                8 if !model.is_empty() => {
                    let id = *model.keys().nth(rng.below(model.len())).unwrap();
                    let (h, _) = model.remove(&id).unwrap();
                    assert_eq!(index.remove(h), Ok(id), "{name}: remove returns the id");
                    removed.push(h);
                }
                _ => check_refusals(name, &mut index, &model, &removed),
            }
        }
        index.maintain(Duration::from_micros(50));
        assert_eq!(
            index.len(),
            model.len(),
            "{name}: round {round} entry count"
        );
        for (&id, &(h, b)) in &model {
            assert_eq!(index.id(h), Some(id), "{name}: id of a live handle");
            assert_eq!(
                index.bounds_of(h),
                Some(b),
                "{name}: bounds of a live handle"
            );
        }
        let stats = index.index_stats();
        assert_eq!(stats.entries, model.len(), "{name}: stats entry count");
        if round % 4 == 3 || round + 1 == rounds {
            let entries: Vec<(u32, Aabb)> = model.iter().map(|(&id, &(_, b))| (id, b)).collect();
            check_queries(name, &index, &entries, seed ^ round as u64);
        }
    }
    index.clear();
    index.maintain(Duration::ZERO);
    assert!(index.is_empty(), "{name}: cleared");
    for (_, (h, _)) in model {
        assert_eq!(index.id(h), None, "{name}: a handle outlives clear");
    }
}

/// Edits the index must refuse, leaving it unchanged: bad boxes, stale handles.
fn check_refusals<I: DynamicIndex>(
    name: &str,
    index: &mut I,
    model: &HashMap<u32, (I::Handle, Aabb)>,
    removed: &[I::Handle],
) {
    let len = index.len();
    let nan = Aabb::new(Vec3A::splat(f32::NAN), Vec3A::ONE);
    let inverted = Aabb::new(Vec3A::ONE, Vec3A::ZERO);
    let infinite = Aabb::new(Vec3A::ZERO, Vec3A::splat(f32::INFINITY));
    for bad in [nan, inverted, infinite] {
        assert_eq!(
            index.insert(1 << 30, bad).err(),
            Some(IndexError::InvalidBounds),
            "{name}"
        );
        if let Some(&(h, b)) = model.values().next() {
            assert_eq!(
                index.update(h, bad),
                Err(IndexError::InvalidBounds),
                "{name}"
            );
            assert_eq!(
                index.bounds_of(h),
                Some(b),
                "{name}: a refused update changed the box"
            );
        }
    }
    for &h in removed.iter().rev().take(3) {
        assert_eq!(
            index.update(h, Aabb::from_point(Vec3A::ZERO)),
            Err(IndexError::StaleHandle)
        );
        assert_eq!(
            index.remove(h),
            Err(IndexError::StaleHandle),
            "{name}: stale remove"
        );
        assert_eq!(index.id(h), None, "{name}: stale id");
    }
    assert_eq!(
        index.len(),
        len,
        "{name}: a refused edit changed the entry count"
    );
}

fn random_box(rng: &mut Rng) -> Aabb {
    accel_testkit::random_box(rng, EXTENT, 0.05..3.0)
}
