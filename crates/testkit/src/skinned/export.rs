//! The character as a binary glTF file: the skeleton as a node hierarchy, the skinned mesh
//! with its morph target, and the animation "walk".

use super::{
    BREATHE_TARGET, JOINT_COUNT, JOINT_NAMES, JOINT_PARENTS, SkinnedCharacter,
    WALK_KEYS_PER_SECOND, WALK_PERIOD, breathe_weight, rest_pose, walk_pose,
};
use crate::glb::{ARRAY_BUFFER, GlbBuffer, json_floats};
use std::fmt::Write;
use std::path::{Path, PathBuf};

/// The repository's `assets/character.glb`, which the `character_glb` binary writes and the
/// `animated` example loads.
pub fn character_glb_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/character.glb")
}

/// The glTF node index of the skinned mesh, the scene's root.
const BODY_NODE: usize = 0;

/// The glTF node index of joint `j`: the joints follow the mesh node in their order.
fn joint_node(j: usize) -> usize {
    j + 1
}

impl SkinnedCharacter {
    /// The character as a binary glTF 2.0 file, as Bevy's loader reads it:
    ///
    /// - one scene whose single root is the skinned mesh node `body` (identity transform, so
    ///   the mesh and the skeleton share one frame), with the skeleton's root `hips` as its
    ///   child (the joints as a node hierarchy named after [`JOINT_NAMES`], in their rest
    ///   pose). glTF ignores a skinned mesh node's transform and its validator warns when
    ///   that node has a parent, so the mesh node is the root; and the animation targets
    ///   the mesh node's morph weights as well as the joints, so with the joints below it the
    ///   whole character is one animation root, to which Bevy gives one `AnimationPlayer`
    ///   (a mesh node beside the skeleton root would make two roots, each with a player);
    /// - the skin `skeleton`: the joints, `skeleton` = `hips`, and the inverse bind matrices;
    /// - the mesh `body`: one triangle primitive with `POSITION` (with bounds), `NORMAL`,
    ///   `JOINTS_0` (unsigned shorts), `WEIGHTS_0` (floats) and `u32` indices, a base-colour
    ///   material, and the morph target `breathe` (a `POSITION` displacement, default
    ///   weight 0, named in `extras.targetNames`);
    /// - the animation `walk`: one [`WALK_PERIOD`] of [`walk_pose`] sampled
    ///   [`WALK_KEYS_PER_SECOND`] times per second (both ends included, so the loop closes),
    ///   with linear interpolation: a rotation channel per joint, the hips' translation and
    ///   the `breathe` weight.
    pub fn to_glb(&self) -> Vec<u8> {
        let mut buf = GlbBuffer::new();
        let to_arrays = |v: &[glam::Vec3]| v.iter().map(|v| v.to_array()).collect::<Vec<_>>();
        let position = buf.floats(&to_arrays(&self.positions), Some(ARRAY_BUFFER), true);
        let normal = buf.floats(&to_arrays(&self.normals), Some(ARRAY_BUFFER), false);
        let joints = buf.u16x4(&self.joints);
        let weights = buf.floats(&self.weights, Some(ARRAY_BUFFER), false);
        let indices = buf.indices(&self.indices);
        let breathe = buf.floats(&to_arrays(&self.breathe), Some(ARRAY_BUFFER), true);
        let inverse_bind: Vec<[f32; 16]> = self
            .inverse_bind
            .iter()
            .map(|m| m.to_cols_array())
            .collect();
        let inverse_bind = buf.floats(&inverse_bind, None, false);

        let keys = (WALK_PERIOD * WALK_KEYS_PER_SECOND as f32).round() as usize;
        let times: Vec<[f32; 1]> = (0..=keys)
            .map(|k| [k as f32 * WALK_PERIOD / keys as f32])
            .collect();
        let poses: Vec<_> = times.iter().map(|t| walk_pose(t[0])).collect();
        let time_accessor = buf.floats(&times, None, true);
        // (output accessor, target node, path) of each channel.
        let mut channels = Vec::new();
        for j in 0..JOINT_COUNT {
            let rotations: Vec<[f32; 4]> = poses.iter().map(|p| p[j].rotation.to_array()).collect();
            channels.push((
                buf.floats(&rotations, None, false),
                joint_node(j),
                "rotation",
            ));
        }
        let hips: Vec<[f32; 3]> = poses.iter().map(|p| p[0].translation.to_array()).collect();
        channels.push((buf.floats(&hips, None, false), joint_node(0), "translation"));
        let breaths: Vec<[f32; 1]> = times.iter().map(|t| [breathe_weight(t[0])]).collect();
        channels.push((buf.floats(&breaths, None, false), BODY_NODE, "weights"));

        let mut nodes = vec![format!(
            r#"{{"name":"body","mesh":0,"skin":0,"children":[{}]}}"#,
            joint_node(0)
        )];
        for (j, rest) in rest_pose().iter().enumerate() {
            let mut node = format!(
                r#"{{"name":"{}","translation":{},"rotation":{},"scale":{}"#,
                JOINT_NAMES[j],
                json_floats(&rest.translation.to_array()),
                json_floats(&rest.rotation.to_array()),
                json_floats(&rest.scale.to_array()),
            );
            let children: Vec<String> = (0..JOINT_COUNT)
                .filter(|&c| JOINT_PARENTS[c] == Some(j))
                .map(|c| joint_node(c).to_string())
                .collect();
            if !children.is_empty() {
                write!(node, r#","children":[{}]"#, children.join(",")).unwrap();
            }
            node.push('}');
            nodes.push(node);
        }

        let joint_nodes: Vec<String> = (0..JOINT_COUNT)
            .map(|j| joint_node(j).to_string())
            .collect();
        let samplers: Vec<String> = channels
            .iter()
            .map(|(output, _, _)| {
                format!(r#"{{"input":{time_accessor},"output":{output},"interpolation":"LINEAR"}}"#)
            })
            .collect();
        let channels: Vec<String> = channels
            .iter()
            .enumerate()
            .map(|(s, (_, node, path))| {
                format!(r#"{{"sampler":{s},"target":{{"node":{node},"path":"{path}"}}}}"#)
            })
            .collect();
        let document = format!(
            concat!(
                r#""asset":{{"version":"2.0","generator":"accel_testkit character_glb"}},"#,
                r#""scene":0,"scenes":[{{"name":"character","nodes":[{body}]}}],"#,
                r#""nodes":[{nodes}],"#,
                r#""skins":[{{"name":"skeleton","inverseBindMatrices":{inverse_bind},"skeleton":{hips},"joints":[{joints_list}]}}],"#,
                r#""materials":[{{"name":"skin","pbrMetallicRoughness":{{"baseColorFactor":[0.8,0.45,0.3,1],"metallicFactor":0,"roughnessFactor":0.7}}}}],"#,
                r#""meshes":[{{"name":"body","primitives":[{{"attributes":{{"POSITION":{position},"NORMAL":{normal},"JOINTS_0":{joints},"WEIGHTS_0":{weights}}},"#,
                r#""indices":{indices},"material":0,"mode":4,"targets":[{{"POSITION":{breathe}}}]}}],"#,
                r#""weights":[0],"extras":{{"targetNames":["{target}"]}}}}],"#,
                r#""animations":[{{"name":"walk","samplers":[{samplers}],"channels":[{channels}]}}]"#,
            ),
            body = BODY_NODE,
            nodes = nodes.join(","),
            inverse_bind = inverse_bind,
            hips = joint_node(0),
            joints_list = joint_nodes.join(","),
            position = position,
            normal = normal,
            joints = joints,
            weights = weights,
            indices = indices,
            breathe = breathe,
            target = BREATHE_TARGET,
            samplers = samplers.join(","),
            channels = channels.join(","),
        );
        buf.into_glb(&document)
    }
}
