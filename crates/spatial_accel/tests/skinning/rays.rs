//! The posed tree against brute force over the posed triangles, through refits and rebuilds.

use super::{Rig, Shape, random_weights};
use accel_testkit::Rng;
use accel_testkit::shapes::uv_sphere;
use glam::{Mat4, Quat, Vec3, Vec3A};
use spatial_accel::mesh::{
    MeshBvh, MeshError, PosedMeshBvh, SkinnedVertices, SkinningError, SkinningInput, joint_matrices,
};
use spatial_accel::query::{BruteForceMesh, TriangleQuery};
use spatial_accel::{Backfaces, Ray};
use std::sync::Arc;

/// An open tube along `+y` of `rings` rings of `segments` vertices, `length` long.
fn tube(rings: usize, segments: usize, length: f32) -> (Vec<Vec3>, Vec<u32>) {
    let mut positions = Vec::new();
    for r in 0..rings {
        let y = length * r as f32 / (rings - 1) as f32;
        for s in 0..segments {
            let a = core::f32::consts::TAU * s as f32 / segments as f32;
            positions.push(Vec3::new(a.cos(), y, a.sin()) * Vec3::new(0.6, 1.0, 0.4));
        }
    }
    let mut indices = Vec::new();
    for r in 0..rings as u32 - 1 {
        for s in 0..segments as u32 {
            let (a, b) = (
                r * segments as u32 + s,
                r * segments as u32 + (s + 1) % segments as u32,
            );
            let (c, d) = (a + segments as u32, b + segments as u32);
            indices.extend([a, c, b, b, c, d]);
        }
    }
    (positions, indices)
}

/// A ray from a random point near the mesh towards a random point of a random triangle.
fn ray_at_surface(
    rng: &mut Rng,
    positions: &[Vec3],
    indices: &[u32],
    around: (Vec3A, Vec3A),
) -> Ray {
    let t = rng.below(indices.len() / 3);
    let [a, b, c] = [0, 1, 2].map(|k| Vec3A::from(positions[indices[3 * t + k] as usize]));
    let (mut u, mut v) = (rng.f32(), rng.f32());
    if u + v > 1.0 {
        (u, v) = (1.0 - u, 1.0 - v);
    }
    let target = a + (b - a) * u + (c - a) * v;
    let origin = Vec3A::new(
        rng.range(around.0.x, around.1.x),
        rng.range(around.0.y, around.1.y),
        rng.range(around.0.z, around.1.z),
    );
    Ray::new(origin, target - origin)
}

/// What one check of a pose found.
#[derive(Default)]
struct Tally {
    rays: usize,
    /// Rays the bind-pose tree answers differently from the posed mesh.
    bind_pose_wrong: usize,
}

/// Casts rays at the posed surface and checks the posed tree against brute force over the
/// posed triangles: the same closest distance, a triangle hit there, the same any-hit
/// answer and the same list of every hit. Counts how often the bind-pose tree disagrees.
fn check_pose(rng: &mut Rng, posed: &PosedMeshBvh, bind: &MeshBvh, tally: &mut Tally) {
    let (positions, indices) = (posed.positions(), &posed.topology()[..]);
    let brute = BruteForceMesh::new(positions, indices).unwrap();
    let bounds = posed.bounds();
    assert_eq!(bounds, brute.bounds());
    posed.mesh_bvh().validate().unwrap();
    let around = (bounds.min - 2.0, bounds.max + 2.0);
    let (mut got_all, mut want_all) = (Vec::new(), Vec::new());
    for _ in 0..60 {
        let ray = ray_at_surface(rng, positions, indices, around);
        for bf in [Backfaces::Include, Backfaces::Cull] {
            let want = brute.cast_ray(&ray, bf);
            let got = posed.cast_ray(&ray, bf);
            assert_eq!(got.map(|h| h.t), want.map(|h| h.t), "{ray:?} {bf:?}");
            want_all.clear();
            brute.cast_ray_all(&ray, bf, &mut want_all);
            if let Some(h) = got {
                assert!(
                    want_all
                        .iter()
                        .any(|w| w.t == h.t && w.triangle == h.triangle)
                );
            }
            got_all.clear();
            posed.cast_ray_all(&ray, bf, &mut got_all);
            let key = |v: &[spatial_accel::mesh::MeshHit]| -> Vec<(f32, u32)> {
                v.iter().map(|h| (h.t, h.triangle)).collect()
            };
            assert_eq!(key(&got_all), key(&want_all));
            assert_eq!(posed.cast_ray_any(&ray, bf), want.is_some());
            tally.rays += 1;
            if bind.cast_ray(&ray, bf).map(|h| h.t) != want.map(|h| h.t) {
                tally.bind_pose_wrong += 1;
            }
        }
    }
}

/// A tube of `rings` rings of `segments` vertices on a chain of `joint_count` joints one
/// unit apart along `+y`, two joints blended per vertex (weights off one by up to a fifth):
/// its positions, triangles, joint indices and weights, and the joints' inverse bindposes.
type TubeRig = (Vec<Vec3>, Vec<u32>, Vec<[u16; 4]>, Vec<[f32; 4]>, Vec<Mat4>);

fn tube_rig(rng: &mut Rng, joint_count: usize, rings: usize, segments: usize) -> TubeRig {
    let (positions, indices) = tube(rings, segments, (joint_count - 1) as f32);
    let (mut joint_indices, mut joint_weights) = (Vec::new(), Vec::new());
    for p in &positions {
        let u = p.y.clamp(0.0, (joint_count - 1) as f32);
        let k = (u as usize).min(joint_count - 2);
        let f = u - k as f32;
        let scale = rng.range(0.8, 1.2);
        joint_indices.push([k as u16, k as u16 + 1, 0, 0]);
        joint_weights.push([(1.0 - f) * scale, f * scale, 0.0, 0.0]);
    }
    let inverse_bindposes = (0..joint_count)
        .map(|k| Mat4::from_translation(Vec3::Y * -(k as f32)))
        .collect();
    (
        positions,
        indices,
        joint_indices,
        joint_weights,
        inverse_bindposes,
    )
}

/// A tube skinned on a chain of joints, two joints blended per vertex (weights off one by
/// up to a fifth), animated through bends that grow to folds: every pose's rays answer as
/// brute force over the posed triangles, through refits and the rebuilds the folds cause,
/// and the bind-pose tree answers most of them wrongly.
#[test]
fn a_bending_tube_answers_as_its_posed_triangles() {
    let mut rng = Rng::new(0x7eb3);
    let (joint_count, seg) = (8usize, 1.0f32);
    let (positions, indices, joint_indices, joint_weights, inverse_bindposes) =
        tube_rig(&mut rng, joint_count, 36, 20);
    let n = positions.len();
    let vertices = SkinnedVertices {
        positions: &positions,
        joint_indices: &joint_indices,
        joint_weights: &joint_weights,
    };
    let axes: Vec<Vec3> = (0..joint_count).map(|_| rng.unit_vector().into()).collect();
    let bind = MeshBvh::new(&positions, &indices).unwrap();
    let mut posed = PosedMeshBvh::new(Arc::from(indices.as_slice()), positions.clone()).unwrap();
    let (mut globals, mut joints, mut tally) = (Vec::new(), Vec::new(), Tally::default());
    let frames = 80;
    for frame in 0..frames {
        // Gentle bends first, then folds of up to about 150 degrees a joint.
        let amplitude = if frame < 40 { 0.4 } else { 2.6 };
        globals.clear();
        for (k, axis) in axes.iter().enumerate() {
            let angle = amplitude * (0.15 * frame as f32 + k as f32).sin();
            let local = Mat4::from_rotation_translation(
                Quat::from_axis_angle(*axis, angle),
                if k == 0 { Vec3::ZERO } else { Vec3::Y * seg },
            );
            let parent = globals.last().copied().unwrap_or(Mat4::IDENTITY);
            globals.push(parent * local);
        }
        joint_matrices(&globals, &inverse_bindposes, &mut joints);
        posed.skin(&vertices, &joints, None).unwrap();
        assert_eq!(posed.positions().len(), n);
        check_pose(&mut rng, &posed, &bind, &mut tally);
    }
    assert_eq!(posed.refit_count(), frames);
    assert!(posed.rebuild_count() >= 1, "no rebuild");
    assert!(
        posed.rebuild_count() < frames / 2,
        "{} rebuilds",
        posed.rebuild_count()
    );
    assert!(
        tally.bind_pose_wrong * 2 > tally.rays,
        "the bind pose answered {} of {} rays wrongly",
        tally.bind_pose_wrong,
        tally.rays
    );
}

/// A sphere whose vertices hang on random joints of a random tree, posed anew at random
/// each frame (rotations, non-uniform and mirrored scales, weights not summing to one):
/// refits that tear the build's neighbourhoods apart, and rebuilds. Every ray answers as
/// brute force; the cost growth the rebuild rule reads is that of a fresh tree afterwards.
#[test]
fn torn_poses_rebuild_and_answer_as_their_triangles() {
    let mut rng = Rng::new(0x7e42);
    let sphere = uv_sphere(16, 24, 2.0);
    let positions: Vec<Vec3> = sphere.vertices.iter().map(|v| Vec3::from(*v)).collect();
    let indices: Vec<u32> = sphere.indices.iter().flatten().copied().collect();
    let rig = Rig::random(&mut rng, 10, Shape::Tree);
    let (joint_indices, joint_weights) = random_weights(&mut rng, positions.len(), 10, false, 0.0);
    let vertices = SkinnedVertices {
        positions: &positions,
        joint_indices: &joint_indices,
        joint_weights: &joint_weights,
    };
    let bind = MeshBvh::new(&positions, &indices).unwrap();
    let mut posed = PosedMeshBvh::new(Arc::from(indices.as_slice()), positions.clone()).unwrap();
    let (mut joints, mut tally) = (Vec::new(), Tally::default());
    let mut refit_only = 0;
    for frame in 0..40 {
        let before = posed.rebuild_count();
        joint_matrices(
            &rig.random_pose(&mut rng, 0.2 + 0.1 * frame as f64, 0.2),
            &rig.inverse_bindposes,
            &mut joints,
        );
        posed.skin(&vertices, &joints, None).unwrap();
        if posed.rebuild_count() > before {
            assert_eq!(posed.cost_growth(), 1.0);
            let fresh = MeshBvh::with_config(
                posed.positions(),
                &indices,
                &MeshBvh::default_config(indices.len() / 3),
            )
            .unwrap();
            assert_eq!(
                posed.mesh_bvh().tree().slot_area_cost(),
                fresh.tree().slot_area_cost()
            );
        } else {
            refit_only += 1;
            assert!(posed.cost_growth() <= posed.rebuild_threshold());
        }
        check_pose(&mut rng, &posed, &bind, &mut tally);
    }
    assert!(
        posed.rebuild_count() >= 5 && refit_only >= 1,
        "{} rebuilds",
        posed.rebuild_count()
    );
    assert!(tally.bind_pose_wrong * 2 > tally.rays);

    // Never rebuilt, the same poses leave the tree far looser than its build: the rebuilds
    // above were needed.
    posed.set_rebuild_threshold(f32::INFINITY);
    let rebuilds = posed.rebuild_count();
    let mut growth = 1.0f32;
    for _ in 0..10 {
        joint_matrices(
            &rig.random_pose(&mut rng, 3.0, 0.2),
            &rig.inverse_bindposes,
            &mut joints,
        );
        posed.skin(&vertices, &joints, None).unwrap();
        growth = growth.max(posed.cost_growth());
        check_pose(&mut rng, &posed, &bind, &mut tally);
    }
    assert_eq!(posed.rebuild_count(), rebuilds);
    assert!(
        growth > PosedMeshBvh::DEFAULT_REBUILD_THRESHOLD,
        "growth {growth}"
    );
}

/// A pose written by a test.
type PoseFn = dyn Fn(&mut Vec<Vec3>) -> Result<(), SkinningError>;

/// A failed pose leaves the mesh in its last good pose; bad topologies are build errors.
#[test]
fn failed_poses_change_nothing() {
    let (positions, indices) = tube(4, 6, 2.0);
    let topology: Arc<[u32]> = Arc::from(indices.as_slice());
    assert_eq!(
        PosedMeshBvh::new(Arc::from(&indices[..4]), positions.clone()).unwrap_err(),
        MeshError::NotATriangleList { index_count: 4 }
    );
    assert!(matches!(
        PosedMeshBvh::new(topology.clone(), positions[..5].to_vec()),
        Err(MeshError::IndexOutOfRange { .. })
    ));
    let mut posed = PosedMeshBvh::new(topology.clone(), positions.clone()).unwrap();
    // Meshes that pose one asset share its topology.
    let other = PosedMeshBvh::new(topology.clone(), positions.clone()).unwrap();
    assert!(Arc::ptr_eq(posed.topology(), other.topology()));
    assert!(posed.memory_bytes() > 0);

    let ray = Ray::new(Vec3::new(0.1, 1.0, -5.0), Vec3::Z);
    let hit = posed.cast_ray(&ray, Backfaces::Include).unwrap();
    let attempts: [&PoseFn; 3] = [
        &|p| {
            p.pop();
            Ok(())
        },
        &|p| {
            p.iter_mut().for_each(|v| *v += Vec3::X);
            Err(SkinningError::NonFinite { vertex: 0 })
        },
        &|p| {
            p.push(Vec3::ZERO);
            Ok(())
        },
    ];
    for attempt in attempts {
        assert!(posed.pose(attempt).is_err());
        assert_eq!(posed.positions(), &positions[..]);
        assert_eq!(posed.cast_ray(&ray, Backfaces::Include), Some(hit));
        assert_eq!(posed.refit_count(), 0);
    }
    assert_eq!(
        posed.pose(|p| {
            p.pop();
            Ok(())
        }),
        Err(SkinningError::LengthMismatch {
            input: SkinningInput::PosedPositions,
            expected: positions.len(),
            got: positions.len() - 1,
        })
    );
    // A skin that fails (a joint past the skin) changes nothing either.
    let joint_indices = vec![[1u16, 0, 0, 0]; positions.len()];
    let joint_weights = vec![[1.0f32, 0.0, 0.0, 0.0]; positions.len()];
    let vertices = SkinnedVertices {
        positions: &positions,
        joint_indices: &joint_indices,
        joint_weights: &joint_weights,
    };
    assert!(posed.skin(&vertices, &[Mat4::IDENTITY], None).is_err());
    assert_eq!(posed.cast_ray(&ray, Backfaces::Include), Some(hit));
    // A pose given whole is taken, and the ray follows it.
    posed
        .pose(|p| {
            p.iter_mut().for_each(|v| *v += Vec3::Z);
            Ok(())
        })
        .unwrap();
    assert_eq!(posed.refit_count(), 1);
    let moved = posed.cast_ray(&ray, Backfaces::Include).unwrap();
    assert!((moved.t - hit.t - 1.0).abs() < 1e-5 && moved.triangle == hit.triangle);
}

/// The tube cut into segments by joint, with two morph targets, posed anew each frame: a
/// ray skins and tests only the segments it reaches, and answers as brute force over every
/// posed triangle (the nearest distance, a triangle hit there); a segment test that skipped
/// a segment it should reach would answer some rays with a farther hit or none.
#[test]
fn segments_answer_as_the_posed_triangles() {
    use spatial_accel::mesh::{MorphTargets, SkinSegments, skin_positions};
    let mut rng = Rng::new(0x5e9);
    let (joint_count, seg) = (6usize, 1.0f32);
    let (positions, indices, joint_indices, joint_weights, inverse_bindposes) =
        tube_rig(&mut rng, joint_count, 30, 16);
    let n = positions.len();
    let vertices = SkinnedVertices {
        positions: &positions,
        joint_indices: &joint_indices,
        joint_weights: &joint_weights,
    };
    let displacements: Vec<Vec3> = (0..2 * n)
        .map(|_| {
            Vec3::new(
                rng.range(-0.3, 0.3),
                rng.range(-0.3, 0.3),
                rng.range(-0.3, 0.3),
            )
        })
        .collect();
    let segments = SkinSegments::new(&vertices, &displacements, 2, &indices).unwrap();
    assert!(segments.segment_count() >= joint_count - 2);
    // Segments of more triangles than a piece holds are cut: the pieces are exercised.
    assert!(segments.piece_count() > 2 * segments.segment_count());
    let (mut globals, mut joints, mut posed, mut scratch) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut rays, mut hits) = (0, 0);
    for _ in 0..40 {
        globals.clear();
        for k in 0..joint_count {
            let axis: Vec3 = rng.unit_vector().into();
            let scale = Vec3::new(
                rng.range(0.6, 1.4),
                rng.range(0.6, 1.4),
                rng.range(0.6, 1.4),
            ) * if rng.below(5) == 0 { -1.0 } else { 1.0 };
            let local = Mat4::from_scale_rotation_translation(
                scale,
                Quat::from_axis_angle(axis, rng.range(-1.5, 1.5)),
                if k == 0 { Vec3::ZERO } else { Vec3::Y * seg },
            );
            let parent = globals.last().copied().unwrap_or(Mat4::IDENTITY);
            globals.push(parent * local);
        }
        joint_matrices(&globals, &inverse_bindposes, &mut joints);
        let weights = [rng.range(-1.0, 1.0), rng.range(0.0, 2.0)];
        let morph = MorphTargets {
            weights: &weights,
            displacements: &displacements,
        };
        skin_positions(&vertices, &joints, Some(morph), &mut posed).unwrap();
        let brute = BruteForceMesh::new(&posed, &indices).unwrap();
        let b = brute.bounds();
        let around = (b.min - 2.0, b.max + 2.0);
        let mut all = Vec::new();
        for _ in 0..40 {
            let ray = ray_at_surface(&mut rng, &posed, &indices, around);
            for bf in [Backfaces::Include, Backfaces::Cull] {
                let want = brute.cast_ray(&ray, bf);
                let got = segments
                    .cast_ray(&ray, bf, &vertices, &joints, &weights, &mut scratch)
                    .unwrap();
                assert_eq!(got.map(|h| h.t), want.map(|h| h.t), "{ray:?} {bf:?}");
                if let Some(h) = got {
                    all.clear();
                    brute.cast_ray_all(&ray, bf, &mut all);
                    assert!(all.iter().any(|w| w.t == h.t && w.triangle == h.triangle));
                    hits += 1;
                }
                rays += 1;
            }
        }
    }
    assert!(hits * 2 > rays, "{hits} of {rays} rays hit");
    // Malformed input is an error, never a panic.
    assert!(SkinSegments::new(&vertices, &displacements, 2, &[0, 1, n as u32]).is_err());
    assert!(SkinSegments::new(&vertices, &displacements, 3, &indices).is_err());
    let ray = Ray::new(Vec3A::ZERO, Vec3A::X);
    assert!(
        segments
            .cast_ray(
                &ray,
                Backfaces::Cull,
                &vertices,
                &joints,
                &[0.0],
                &mut scratch
            )
            .is_err()
    );
}
