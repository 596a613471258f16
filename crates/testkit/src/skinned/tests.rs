use super::*;
use crate::Mesh;
use std::collections::HashMap;

/// The mesh with vertices at the same position merged, so that the feet's split faces and
/// the tubes' rings form closed surfaces as far as edges tell.
fn welded(c: &SkinnedCharacter) -> Mesh {
    let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
    let mut vertices = Vec::new();
    let remap: Vec<u32> = c
        .positions
        .iter()
        .map(|p| {
            *ids.entry(p.to_array().map(f32::to_bits))
                .or_insert_with(|| {
                    vertices.push((*p).into());
                    vertices.len() as u32 - 1
                })
        })
        .collect();
    let indices = c
        .indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]].map(|i| remap[i as usize]))
        .collect();
    Mesh { vertices, indices }
}

#[test]
fn skeleton_is_listed_parents_first() {
    for (j, parent) in JOINT_PARENTS.iter().enumerate() {
        assert_eq!(parent.is_none(), j == 0, "{}", JOINT_NAMES[j]);
        assert!(parent.is_none_or(|p| p < j), "{}", JOINT_NAMES[j]);
    }
    let rest = globals(&rest_pose());
    let at = |j: usize| rest[j].w_axis.truncate();
    assert!(at(HEAD).abs_diff_eq(Vec3::new(0.0, 1.68, 0.0), 1e-6));
    assert!(at(FOREARM_L).abs_diff_eq(Vec3::new(0.23, 1.24, 0.0), 1e-6));
    assert!(at(FOREARM_R).abs_diff_eq(Vec3::new(-0.23, 1.24, 0.0), 1e-6));
    assert!(at(SHIN_L).abs_diff_eq(Vec3::new(0.10, 0.49, 0.0), 1e-6));
}

#[test]
fn detail_hits_the_wanted_triangle_counts() {
    for wanted in [2000, 5000, 20000] {
        let detail = Detail::for_triangles(wanted);
        let c = character(detail);
        assert_eq!(c.triangle_count(), detail.triangle_count());
        let error = c.triangle_count().abs_diff(wanted as usize) as f32 / wanted as f32;
        assert!(error < 0.05, "{detail:?}: {} triangles", c.triangle_count());
    }
    assert_eq!(Detail::default(), Detail::for_triangles(5000));
}

#[test]
fn mesh_is_closed_and_outward() {
    for detail in [
        Detail {
            around: 3,
            rings: 1,
        },
        Detail::default(),
    ] {
        let c = character(detail);
        let n = c.positions.len();
        assert_eq!(c.normals.len(), n);
        assert_eq!(c.joints.len(), n);
        assert_eq!(c.weights.len(), n);
        assert_eq!(c.breathe.len(), n);
        assert!(c.indices.iter().all(|&i| (i as usize) < n));
        let mesh = welded(&c);
        mesh.check_closed().unwrap();
        // Every part is closed, so each one's signed volume is its volume: all positive
        // means every triangle faces out. The parts overlap, so only their sum is checked.
        let volume: f32 = mesh
            .triangles()
            .map(|[a, b, cc]| a.dot(b.cross(cc)) / 6.0)
            .sum();
        assert!((0.02..0.12).contains(&volume), "{volume}");
        for (p, nrm) in c.positions.iter().zip(&c.normals) {
            assert!((nrm.length() - 1.0).abs() < 1e-5, "{p}: {nrm}");
        }
    }
}

#[test]
fn weights_are_normalized_and_blend_near_joints() {
    let c = character(Detail::default());
    let mut counts = [0usize; 5];
    for (joints, weights) in c.joints.iter().zip(&c.weights) {
        let sum: f32 = weights.iter().sum();
        assert!((sum - 1.0).abs() <= 1e-6, "{weights:?}");
        let used = weights.iter().filter(|&&w| w > 0.0).count();
        counts[used] += 1;
        assert!(weights.iter().all(|&w| (0.0..=1.0).contains(&w)));
        assert!(weights.windows(2).all(|w| w[0] >= w[1]), "{weights:?}");
        assert!(joints.iter().all(|&j| (j as usize) < JOINT_COUNT));
    }
    assert_eq!(counts[0], 0);
    assert!(
        counts[1] > 0 && counts[2] > 0 && counts[3] > 0,
        "{counts:?}"
    );
}

#[test]
fn bind_pose_skinning_gives_back_the_rest_positions() {
    let c = character(Detail::default());
    let skinned = c.skin(&globals(&rest_pose()), 0.0);
    for (a, b) in skinned.iter().zip(&c.positions) {
        assert!(a.abs_diff_eq(*b, 1e-5), "{a} != {b}");
    }
}

#[test]
fn walk_loops_and_keeps_the_mesh_together() {
    let c = character(Detail::default());
    let (a, b) = (walk_pose(0.0), walk_pose(WALK_PERIOD));
    for (x, y) in a.iter().zip(&b) {
        assert!(x.translation.abs_diff_eq(y.translation, 1e-5));
        assert!(x.rotation.abs_diff_eq(y.rotation, 1e-5));
    }
    let rest = welded(&c);
    let edge_length =
        |m: &Mesh, [a, b]: [u32; 2]| (m.vertices[a as usize] - m.vertices[b as usize]).length();
    for k in 0..24 {
        let t = k as f32 / 24.0;
        let pose = walk_pose(t);
        assert_eq!(pose.len(), JOINT_COUNT);
        assert!(pose.iter().all(|j| j.rotation.is_normalized()));
        let posed = c.walk_mesh(t);
        let lowest = posed
            .vertices
            .iter()
            .map(|v| v.y)
            .fold(f32::INFINITY, f32::min);
        assert!(
            (-0.06..0.04).contains(&lowest),
            "t = {t}: lowest point {lowest}"
        );
        // Skinning bends but does not tear: no edge stretches or shrinks much.
        let posed = welded(&SkinnedCharacter {
            positions: posed.vertices.iter().map(|&v| v.into()).collect(),
            ..c.clone()
        });
        if posed.vertices.len() == rest.vertices.len() {
            for e in rest.edges() {
                let ratio = edge_length(&posed, e) / edge_length(&rest, e);
                assert!((0.4..2.5).contains(&ratio), "t = {t}: edge {e:?} x{ratio}");
            }
        }
    }
    // The left foot is in front at a quarter cycle, behind at three quarters.
    let foot_z = |t: f32| {
        globals(&walk_pose(t))[SHIN_L]
            .transform_point3(Vec3::new(0.0, -0.42, 0.0))
            .z
    };
    assert!(foot_z(0.25) > 0.15 && foot_z(0.75) < -0.15);
}

#[test]
fn breathing_moves_only_the_chest() {
    let c = character(Detail::default());
    let moved: Vec<_> = c
        .positions
        .iter()
        .zip(&c.breathe)
        .filter(|(_, d)| **d != Vec3::ZERO)
        .collect();
    assert!(!moved.is_empty());
    for (p, d) in moved {
        assert!((1.18..1.54).contains(&p.y), "{p}");
        assert!(d.length() <= 0.0301);
    }
    assert_eq!(breathe_weight(0.0), 0.0);
    assert!((breathe_weight(WALK_PERIOD / 2.0) - 1.0).abs() < 1e-6);
}
