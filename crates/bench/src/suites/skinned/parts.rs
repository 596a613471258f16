//! Where a pick's time goes, on one character outside Bevy: the core crate's steps behind a
//! pick of ours (the pose's box, skinning, the posed tree's refit or rebuild, its walk)
//! beside the peers' (Bevy's brute force over the bind pose, baking a posed `Mesh`), at
//! random phases of the walk, as the suite's random pointer reaches a character at a random
//! moment of its walk.

use super::scene::{bevy_mesh, cast_over_mesh, skin_mesh};
use crate::timing::{median, per_item};
use accel_testkit::Rng;
use accel_testkit::skinned::{SkinnedCharacter, globals, walk_pose};
use bevy::math::{Affine3A, Ray3d};
use bevy::prelude::{Dir3, Vec3};
use spatial_accel::mesh::{
    PosedMeshBvh, SkinBounds, SkinnedVertices, joint_matrices, skin_positions,
};
use spatial_accel::{Backfaces, Ray};
use std::hint::black_box;
use std::sync::Arc;
use std::time::Instant;

/// Microseconds of one call of `f`.
fn us<R>(f: impl FnOnce() -> R) -> f64 {
    let start = Instant::now();
    black_box(f());
    start.elapsed().as_secs_f64() * 1e6
}

/// One note: the steps' medians over `poses` random poses of `c`.
pub fn note(name: &str, c: &SkinnedCharacter, poses: usize) -> String {
    let mut rng = Rng::new(0x9a27);
    let poses: Vec<Vec<bevy::math::Mat4>> = (0..poses.max(1))
        .map(|_| {
            let mut m = Vec::new();
            joint_matrices(&globals(&walk_pose(rng.f32())), &c.inverse_bind, &mut m);
            m
        })
        .collect();
    let vertices = SkinnedVertices {
        positions: &c.positions,
        joint_indices: &c.joints,
        joint_weights: &c.weights,
    };
    let bounds = SkinBounds::new(&vertices, &[], 0).expect("the character's skin is valid");
    let bound_us = 1e6 * per_item(5, poses.len(), |i| bounds.bound(&poses[i], &[]).ok());
    let mut out = Vec::new();
    let skin_us = median(
        poses
            .iter()
            .map(|m| us(|| skin_positions(&vertices, m, None, &mut out)))
            .collect(),
    );
    let topology: Arc<[u32]> = Arc::from(c.indices.as_slice());
    let mut posed = Vec::new();
    skin_positions(&vertices, &poses[0], None, &mut posed).expect("the pose skins");
    let build_us = median(
        (0..5)
            .map(|_| us(|| PosedMeshBvh::new(topology.clone(), posed.clone())))
            .collect(),
    );
    let mut bvh = PosedMeshBvh::new(topology, posed).expect("the character has triangles");
    // Through the torso, from the front.
    let origin = Vec3::new(0.0, 1.15, 5.0);
    let ray = Ray::new(origin, Vec3::NEG_Z);
    let (mut refit, mut walk) = (Vec::new(), Vec::new());
    for m in &poses {
        refit.push(us(|| bvh.skin(&vertices, m, None)));
        walk.push(us(|| bvh.cast_ray(&ray, Backfaces::Cull)));
    }
    let mesh = bevy_mesh(c);
    let bevy_ray = Ray3d::new(origin, Dir3::NEG_Z);
    let brute_us = median(
        (0..poses.len())
            .map(|_| us(|| cast_over_mesh(&mesh, &Affine3A::IDENTITY, bevy_ray)))
            .collect(),
    );
    let (mut bake, mut bake_cast) = (Vec::new(), Vec::new());
    for m in &poses {
        let affines: Vec<Affine3A> = m.iter().map(|m| Affine3A::from_mat4(*m)).collect();
        let mut baked = None;
        bake.push(us(|| baked = skin_mesh(&mesh, &affines)));
        let baked = baked.expect("the character bakes");
        bake_cast.push(us(|| cast_over_mesh(&baked, &Affine3A::IDENTITY, bevy_ray)));
    }
    format!(
        "{name}, one character alone (medians over {} random walk phases, us): ours: the \
         pose's box {bound_us:.2}, skin_positions {skin_us:.1}, PosedMeshBvh::skin (skin and \
         refit) {:.1} ({} of {} poses rebuilt the tree), a build {build_us:.0}, the walk \
         {:.2}; Bevy's ray_mesh_intersection over every triangle {brute_us:.1}; baking: the \
         posed Mesh {:.1}, then the same brute force {:.1}",
        poses.len(),
        median(refit),
        bvh.rebuild_count(),
        bvh.refit_count(),
        median(walk),
        median(bake),
        median(bake_cast),
    )
}
