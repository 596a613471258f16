//! The moving frames the octree and grid benches play on the dynamic workload: a tenth of
//! the boxes moved per frame by a random step of up to a unit per axis.

use accel::Aabb;
use accel_testkit::Rng;
use glam::Vec3A;

/// Distinct frames of moves; played forward, then backward with the steps negated, so the
/// boxes oscillate about where they started instead of drifting.
pub const FRAMES: usize = 8;

/// Boxes in the workload the frames move.
const N: usize = 100_000;

/// The moves of each frame: a tenth of the boxes, each with its step.
pub fn frames() -> Vec<Vec<(usize, Vec3A)>> {
    let mut rng = Rng::new(2);
    (0..FRAMES)
        .map(|_| {
            (0..N / 10)
                .map(|_| (rng.below(N), rng.vec3a(-1.0, 1.0)))
                .collect()
        })
        .collect()
}

/// Plays frame `i` of `frames` on `boxes`, calling `update` for each moved box.
pub fn play(
    frames: &[Vec<(usize, Vec3A)>],
    i: usize,
    boxes: &mut [Aabb],
    mut update: impl FnMut(usize, Aabb),
) {
    let sign = if (i / FRAMES).is_multiple_of(2) {
        1.0
    } else {
        -1.0
    };
    for &(b, step) in &frames[i % FRAMES] {
        let d = step * sign;
        boxes[b] = Aabb::new(boxes[b].min + d, boxes[b].max + d);
        update(b, boxes[b]);
    }
}
