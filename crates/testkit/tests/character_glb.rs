//! `assets/character.glb` read back with the `gltf` crate that Bevy's loader uses: valid glTF
//! 2.0 with what the `animated` example relies on (one skin on a node hierarchy, the "walk"
//! animation, the morph target), skinning that reproduces the rest pose, and the same
//! character as `accel_testkit::skinned` (else: `cargo run -p accel_testkit --bin
//! character_glb` rewrites the file).

use accel_testkit::skinned::{
    BREATHE_TARGET, Detail, JOINT_COUNT, JOINT_NAMES, JOINT_PARENTS, WALK_KEYS_PER_SECOND,
    WALK_PERIOD, breathe_weight, character, character_glb_path, walk_pose,
};
use glam::{Mat4, Quat, Vec3};
use gltf::Gltf;
use gltf::animation::Property;
use gltf::animation::util::ReadOutputs;
use gltf::json::Value;
use std::collections::HashMap;

fn load() -> Gltf {
    let path = character_glb_path();
    let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(bytes.len() < 1 << 20, "{} bytes", bytes.len());
    // `from_slice` also runs the crate's validation (indices in range, required fields).
    Gltf::from_slice(&bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// An accessor's `min` or `max` as floats.
fn bound(value: Option<Value>) -> Vec<f32> {
    let value = value.expect("accessor bounds");
    value
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap() as f32)
        .collect()
}

fn node_by_name<'a>(gltf: &'a Gltf, name: &str) -> gltf::Node<'a> {
    gltf.nodes()
        .find(|n| n.name() == Some(name))
        .unwrap_or_else(|| panic!("no node {name}"))
}

#[test]
fn layout_is_what_bevy_and_the_example_expect() {
    let gltf = load();
    let blob = gltf.blob.as_deref().expect("a GLB binary chunk");
    assert_eq!(gltf.buffers().count(), 1);
    for view in gltf.views() {
        assert_eq!(
            view.offset() % 4,
            0,
            "buffer view {} misaligned",
            view.index()
        );
        assert!(view.offset() + view.length() <= blob.len());
    }
    // One scene whose one root is the mesh node (identity), with the skeleton below it.
    let scene = gltf.default_scene().expect("a default scene");
    let roots: Vec<_> = scene.nodes().collect();
    assert_eq!(roots.len(), 1);
    let body = &roots[0];
    assert_eq!(body.name(), Some("body"));
    let identity = gltf::scene::Transform::Decomposed {
        translation: [0.0; 3],
        rotation: [0.0, 0.0, 0.0, 1.0],
        scale: [1.0; 3],
    }
    .matrix();
    assert_eq!(body.transform().matrix(), identity);
    assert!(body.mesh().is_some());
    let children: Vec<_> = body.children().filter_map(|c| c.name()).collect();
    assert_eq!(children, ["hips"]);

    // The skin: every joint once, named and parented as the module's skeleton.
    assert_eq!(gltf.skins().count(), 1);
    let skin = body.skin().expect("the body's skin");
    let joints: Vec<_> = skin.joints().collect();
    assert_eq!(joints.len(), JOINT_COUNT);
    let names: Vec<_> = joints.iter().map(|j| j.name().unwrap()).collect();
    assert_eq!(names, JOINT_NAMES);
    assert_eq!(skin.skeleton().map(|s| s.index()), Some(joints[0].index()));
    let index_of: HashMap<usize, usize> = joints
        .iter()
        .enumerate()
        .map(|(j, n)| (n.index(), j))
        .collect();
    let mut parents = [None; JOINT_COUNT];
    for (j, joint) in joints.iter().enumerate() {
        for child in joint.children() {
            parents[index_of[&child.index()]] = Some(j);
        }
    }
    assert_eq!(parents, JOINT_PARENTS);
    let inverse_bind = skin.inverse_bind_matrices().unwrap();
    assert_eq!(inverse_bind.count(), JOINT_COUNT);

    // The mesh: one primitive with the skinning attributes and one morph target.
    assert_eq!(gltf.meshes().count(), 1);
    let mesh = body.mesh().unwrap();
    assert_eq!(mesh.weights(), Some(&[0.0][..]));
    let extras = mesh.extras().as_ref().expect("targetNames").get();
    assert!(
        extras.contains(&format!("\"{BREATHE_TARGET}\"")),
        "{extras}"
    );
    let primitives: Vec<_> = mesh.primitives().collect();
    assert_eq!(primitives.len(), 1);
    let primitive = &primitives[0];
    assert_eq!(primitive.mode(), gltf::mesh::Mode::Triangles);
    let color = primitive
        .material()
        .pbr_metallic_roughness()
        .base_color_factor();
    assert_eq!(color[3], 1.0);
    use gltf::Semantic::{Joints, Normals, Positions, Weights};
    use gltf::accessor::{DataType, Dimensions};
    let attribute = |s: gltf::Semantic| primitive.get(&s).unwrap_or_else(|| panic!("{s:?}"));
    let count = attribute(Positions).count();
    for (semantic, data_type, dimensions) in [
        (Positions, DataType::F32, Dimensions::Vec3),
        (Normals, DataType::F32, Dimensions::Vec3),
        (Joints(0), DataType::U16, Dimensions::Vec4),
        (Weights(0), DataType::F32, Dimensions::Vec4),
    ] {
        let a = attribute(semantic.clone());
        assert_eq!(a.count(), count, "{semantic:?}");
        assert_eq!(a.data_type(), data_type, "{semantic:?}");
        assert_eq!(a.dimensions(), dimensions, "{semantic:?}");
        assert!(!a.normalized(), "{semantic:?}");
    }
    let targets: Vec<_> = primitive.morph_targets().collect();
    assert_eq!(targets.len(), 1);
    let displacement = targets[0].positions().expect("a POSITION displacement");
    assert_eq!(displacement.count(), count);
    assert!(displacement.min().is_some() && displacement.max().is_some());
    let indices = primitive.indices().unwrap();
    assert_eq!(indices.count() % 3, 0);
    assert_eq!(indices.data_type(), DataType::U32);

    let reader = primitive.reader(|_| Some(blob));
    let positions: Vec<Vec3> = reader.read_positions().unwrap().map(Vec3::from).collect();
    let min = positions.iter().fold(Vec3::INFINITY, |m, &p| m.min(p));
    let max = positions.iter().fold(Vec3::NEG_INFINITY, |m, &p| m.max(p));
    let position = attribute(Positions);
    assert_eq!(bound(position.min()), min.to_array());
    assert_eq!(bound(position.max()), max.to_array());
    let triangles: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
    assert!(triangles.iter().all(|&i| (i as usize) < count));
    for normal in reader.read_normals().unwrap() {
        assert!((Vec3::from(normal).length() - 1.0).abs() < 1e-5);
    }
}

#[test]
fn weights_are_normalized_and_bind_pose_skinning_is_the_identity() {
    let gltf = load();
    let blob = gltf.blob.as_deref().unwrap();
    let body = node_by_name(&gltf, "body");
    let skin = body.skin().unwrap();
    let primitive = body.mesh().unwrap().primitives().next().unwrap();
    let reader = primitive.reader(|_| Some(blob));
    let positions: Vec<Vec3> = reader.read_positions().unwrap().map(Vec3::from).collect();
    let joints: Vec<[u16; 4]> = reader.read_joints(0).unwrap().into_u16().collect();
    let weights: Vec<[f32; 4]> = reader.read_weights(0).unwrap().into_f32().collect();
    assert_eq!(joints.len(), positions.len());
    assert_eq!(weights.len(), positions.len());
    for (j, w) in joints.iter().zip(&weights) {
        let sum: f32 = w.iter().sum();
        assert!((sum - 1.0).abs() <= 1e-6, "weights {w:?} sum to {sum}");
        assert!(w.iter().all(|&w| w >= 0.0));
        assert!(w.iter().any(|&w| w > 0.0));
        assert!(j.iter().all(|&j| (j as usize) < JOINT_COUNT), "{j:?}");
    }

    // The joints' rest globals from the file's own node transforms, parents first.
    let skin_joints: Vec<_> = skin.joints().collect();
    let mut globals: Vec<Mat4> = Vec::new();
    for (j, node) in skin_joints.iter().enumerate() {
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        globals.push(match JOINT_PARENTS[j] {
            Some(p) => globals[p] * local,
            None => local,
        });
    }
    let inverse_bind: Vec<Mat4> = skin
        .reader(|_| Some(blob))
        .read_inverse_bind_matrices()
        .unwrap()
        .map(|m| Mat4::from_cols_array_2d(&m))
        .collect();
    for (j, (g, ib)) in globals.iter().zip(&inverse_bind).enumerate() {
        assert!(
            (*g * *ib).abs_diff_eq(Mat4::IDENTITY, 1e-5),
            "joint {}",
            JOINT_NAMES[j]
        );
    }
    for ((p, j), w) in positions.iter().zip(&joints).zip(&weights) {
        let skinned: Vec3 = (0..4)
            .map(|k| {
                (globals[j[k] as usize] * inverse_bind[j[k] as usize]).transform_point3(*p) * w[k]
            })
            .sum();
        assert!(skinned.abs_diff_eq(*p, 1e-4), "{p} skinned to {skinned}");
    }
}

#[test]
fn walk_animation_samples_the_walk_cycle() {
    let gltf = load();
    let blob = gltf.blob.as_deref().unwrap();
    let animations: Vec<_> = gltf.animations().collect();
    assert_eq!(animations.len(), 1);
    let walk = &animations[0];
    assert_eq!(walk.name(), Some("walk"));
    let joint_of: HashMap<usize, usize> = node_by_name(&gltf, "body")
        .skin()
        .unwrap()
        .joints()
        .enumerate()
        .map(|(j, n)| (n.index(), j))
        .collect();
    let keys = (WALK_PERIOD * WALK_KEYS_PER_SECOND as f32).round() as usize + 1;
    let (mut rotated, mut translated, mut weighted) = (vec![false; JOINT_COUNT], 0, 0);
    for channel in walk.channels() {
        let sampler = channel.sampler();
        assert_eq!(
            sampler.interpolation(),
            gltf::animation::Interpolation::Linear
        );
        let input = sampler.input();
        assert_eq!(bound(input.min()), [0.0]);
        assert_eq!(bound(input.max()), [WALK_PERIOD]);
        let reader = channel.reader(|_| Some(blob));
        let times: Vec<f32> = reader.read_inputs().unwrap().collect();
        assert_eq!(times.len(), keys);
        assert!(times.windows(2).all(|t| t[0] < t[1]));
        let target = channel.target().node();
        match (reader.read_outputs().unwrap(), channel.target().property()) {
            (ReadOutputs::Rotations(r), Property::Rotation) => {
                let j = joint_of[&target.index()];
                assert!(!rotated[j], "two rotation channels on {}", JOINT_NAMES[j]);
                rotated[j] = true;
                let rotations: Vec<[f32; 4]> = r.into_f32().collect();
                assert_eq!(rotations.len(), keys);
                for (t, q) in times.iter().zip(&rotations) {
                    let q = Quat::from_array(*q);
                    assert!((q.length() - 1.0).abs() < 1e-6, "{q}");
                    assert!(q.abs_diff_eq(walk_pose(*t)[j].rotation, 1e-6));
                }
                // The loop closes: the last key is the first.
                assert!(
                    Quat::from_array(rotations[0])
                        .abs_diff_eq(Quat::from_array(rotations[keys - 1]), 1e-5)
                );
            }
            (ReadOutputs::Translations(tr), Property::Translation) => {
                assert_eq!(target.name(), Some("hips"));
                translated += 1;
                for (t, p) in times.iter().zip(tr) {
                    assert!(Vec3::from(p).abs_diff_eq(walk_pose(*t)[0].translation, 1e-6));
                }
            }
            (ReadOutputs::MorphTargetWeights(w), Property::MorphTargetWeights) => {
                assert_eq!(target.name(), Some("body"));
                weighted += 1;
                let w: Vec<f32> = w.into_f32().collect();
                assert_eq!(w.len(), keys);
                for (t, w) in times.iter().zip(w) {
                    assert!((w - breathe_weight(*t)).abs() < 1e-6);
                }
            }
            (_, property) => panic!("unexpected channel {property:?}"),
        }
    }
    assert!(
        rotated.iter().all(|&r| r),
        "every joint has a rotation channel"
    );
    assert_eq!((translated, weighted), (1, 1));
}

#[test]
fn file_is_the_default_character() {
    let gltf = load();
    let blob = gltf.blob.as_deref().unwrap();
    let expected = character(Detail::default());
    let primitive = node_by_name(&gltf, "body")
        .mesh()
        .unwrap()
        .primitives()
        .next()
        .unwrap();
    let reader = primitive.reader(|_| Some(blob));
    let indices: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
    assert_eq!(
        indices, expected.indices,
        "stale file: run `cargo run -p accel_testkit --bin character_glb`"
    );
    let joints: Vec<[u16; 4]> = reader.read_joints(0).unwrap().into_u16().collect();
    assert_eq!(joints, expected.joints);
    let positions: Vec<Vec3> = reader.read_positions().unwrap().map(Vec3::from).collect();
    for (a, b) in positions.iter().zip(&expected.positions) {
        assert!(a.abs_diff_eq(*b, 1e-6), "{a} != {b}");
    }
    let mut targets = reader.read_morph_targets();
    let (breathe, _, _) = targets.next().unwrap();
    for (a, b) in breathe.unwrap().zip(&expected.breathe) {
        assert!(Vec3::from(a).abs_diff_eq(*b, 1e-6));
    }
    let (w_file, w_expected): (Vec<[f32; 4]>, _) = (
        reader.read_weights(0).unwrap().into_f32().collect(),
        &expected.weights,
    );
    for (a, b) in w_file.iter().zip(w_expected) {
        assert!(a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-6));
    }
}
