//! Random box scenes for the trees: uniform, clustered, degenerate (the adversarial case), and
//! the benchmarks' mixed cloud of entity boxes.

use crate::Rng;
use core::ops::Range;
use glam::Vec3A;
use spatial_accel::Aabb;

/// A random box: centre uniform in `[-extent, extent)^3`, each half extent uniform in `half`.
pub fn random_box(rng: &mut Rng, extent: f32, half: Range<f32>) -> Aabb {
    let center = rng.vec3a(-extent, extent);
    Aabb::from_center_half_extents(center, rng.vec3a(half.start, half.end))
}

/// `n` boxes made by [`random_box`].
pub fn uniform_boxes(rng: &mut Rng, n: usize, extent: f32, half: Range<f32>) -> Vec<Aabb> {
    (0..n)
        .map(|_| random_box(rng, extent, half.clone()))
        .collect()
}

/// `n` small boxes (half extents 0.01 to 0.5) in 8 dense clusters (within 5 of a centre) spread
/// over `[-1000, 1000)^3`: the case where midpoint splits do badly.
pub fn clustered_boxes(rng: &mut Rng, n: usize) -> Vec<Aabb> {
    let centers: Vec<Vec3A> = (0..8).map(|_| rng.vec3a(-1000.0, 1000.0)).collect();
    (0..n)
        .map(|_| {
            let c = centers[rng.below(8)] + rng.vec3a(-5.0, 5.0);
            Aabb::from_center_half_extents(c, rng.vec3a(0.01, 0.5))
        })
        .collect()
}

/// `n` boxes that break naive splitting: in turn a point at (1, 1, 1), a flat square at
/// z = 1, the box `[0, 2]^3` (so many exact duplicates) and a random point in `[0, 2)^3`.
pub fn degenerate_boxes(rng: &mut Rng, n: usize) -> Vec<Aabb> {
    (0..n)
        .map(|i| match i % 4 {
            0 => Aabb::from_point(Vec3A::splat(1.0)),
            1 => Aabb::new(Vec3A::new(0.0, 0.0, 1.0), Vec3A::new(2.0, 2.0, 1.0)),
            2 => Aabb::new(Vec3A::ZERO, Vec3A::splat(2.0)),
            _ => Aabb::from_point(rng.vec3a(0.0, 2.0)),
        })
        .collect()
}

/// The kinds of box scene the tree oracles run on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BoxScene {
    /// Boxes of varied size (half extents 0.01 to 2) spread uniformly over `[-100, 100)^3`.
    Uniform,
    /// Dense clusters far apart ([`clustered_boxes`]).
    Clustered,
    /// Everything at one point, zero-size and flat boxes, duplicates ([`degenerate_boxes`]).
    Degenerate,
}

/// `n` boxes of the `kind` of scene, from `seed`.
pub fn box_scene(kind: BoxScene, n: usize, seed: u64) -> Vec<Aabb> {
    let mut rng = Rng::new(seed);
    match kind {
        BoxScene::Uniform => uniform_boxes(&mut rng, n, 100.0, 0.01..2.0),
        BoxScene::Clustered => clustered_boxes(&mut rng, n),
        BoxScene::Degenerate => degenerate_boxes(&mut rng, n),
    }
}

/// Half the side of the cube the [`entity_boxes`] live in.
pub const ENTITY_EXTENT: f32 = 500.0;

/// `n` entity boxes, as a game world has them: 80% spread uniformly, 20% in 32 dense clusters
/// (crowds, forests), half extents from 0.1 to 2 units.
pub fn entity_boxes(n: usize, seed: u64) -> Vec<Aabb> {
    let mut rng = Rng::new(seed);
    let clusters: Vec<Vec3A> = (0..32)
        .map(|_| rng.vec3a(-ENTITY_EXTENT * 0.9, ENTITY_EXTENT * 0.9))
        .collect();
    (0..n)
        .map(|i| {
            let c = if i % 5 == 4 {
                clusters[rng.below(32)] + rng.vec3a(-20.0, 20.0)
            } else {
                rng.vec3a(-ENTITY_EXTENT, ENTITY_EXTENT)
            };
            Aabb::from_center_half_extents(c, rng.vec3a(0.1, 2.0))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scenes_are_reproducible_and_valid() {
        for kind in [BoxScene::Uniform, BoxScene::Clustered, BoxScene::Degenerate] {
            let a = box_scene(kind, 100, 3);
            assert_eq!(a, box_scene(kind, 100, 3));
            assert!(a.iter().all(|b| b.min.cmple(b.max).all()));
        }
        let e = entity_boxes(1000, 1);
        assert!(
            e.iter()
                .all(|b| b.center().abs().max_element() <= ENTITY_EXTENT)
        );
    }
}
