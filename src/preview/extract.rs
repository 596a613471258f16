//! The ECS scene in the preview core's terms: the camera, the lights, the materials and the
//! objects by tree slot.

use super::scene::{PosedPreviewObject, PreviewMesh, PreviewObject, PreviewObjects};
use crate::AccelTrees;
use crate::meshes::{Posing, SkinInputs};
use crate::picking::{AccelMeshCache, AccelPosedMeshes, MeshShape};
use bevy::camera::Exposure;
use bevy::ecs::entity::EntityHashSet;
use bevy::ecs::system::SystemChangeTick;
use bevy::ecs::system::SystemParam;
use bevy::image::Image;
use bevy::light::GlobalAmbientLight;
use bevy::mesh::morph::{MeshMorphWeights, MorphWeights};
use bevy::mesh::skinning::{SkinnedMesh, SkinnedMeshInverseBindposes};
use bevy::platform::collections::HashMap;
use bevy::prelude::*;
use spatial_accel::preview::MeshSurface;
use spatial_accel::preview::{
    PreviewCamera, PreviewLight, PreviewMaterial, Texture, TextureFilter,
};
use std::sync::Arc;

/// The main view: the active 3D camera of lowest order.
pub(super) type ViewItem = (
    Entity,
    &'static Camera,
    &'static GlobalTransform,
    Option<&'static Exposure>,
);

/// A skinned or morphed entity: traced as Bevy draws it, posed.
pub(super) type PosedItem = (
    Entity,
    Option<&'static SkinnedMesh>,
    Option<&'static MeshMorphWeights>,
    &'static Mesh3d,
    &'static GlobalTransform,
    Option<&'static MeshMaterial3d<StandardMaterial>>,
    &'static InheritedVisibility,
);

/// The entities Bevy poses before drawing.
pub(super) type PosedFilter = Or<(With<SkinnedMesh>, With<MeshMorphWeights>)>;

/// What the preview reads of the world to build a frame's scene.
#[derive(SystemParam)]
pub(super) struct PreviewWorld<'w, 's> {
    pub(super) trees: Res<'w, AccelTrees>,
    cache: Res<'w, AccelMeshCache>,
    meshes: Res<'w, Assets<Mesh>>,
    materials: Option<Res<'w, Assets<StandardMaterial>>>,
    ambient: Option<Res<'w, GlobalAmbientLight>>,
    pub(super) cameras: Query<'w, 's, ViewItem, With<Camera3d>>,
    renderables: Query<
        'w,
        's,
        (
            &'static Mesh3d,
            &'static GlobalTransform,
            Option<&'static MeshMaterial3d<StandardMaterial>>,
            &'static InheritedVisibility,
        ),
    >,
    posed: Res<'w, AccelPosedMeshes>,
    pub(super) posed_targets: Query<'w, 's, PosedItem, PosedFilter>,
    joints: Query<'w, 's, &'static GlobalTransform>,
    morph_weights: Query<'w, 's, &'static MorphWeights>,
    bindposes: Option<Res<'w, Assets<SkinnedMeshInverseBindposes>>>,
    ticks: SystemChangeTick,
    directional: Query<'w, 's, (&'static DirectionalLight, &'static GlobalTransform)>,
    points: Query<'w, 's, (&'static PointLight, &'static GlobalTransform)>,
    spots: Query<'w, 's, (&'static SpotLight, &'static GlobalTransform)>,
}

/// The camera the preview traces, with its exposure multiplier.
pub(super) struct PreviewView {
    pub(super) entity: Entity,
    pub(super) camera: PreviewCamera,
    pub(super) exposure: f32,
}

impl PreviewWorld<'_, '_> {
    /// The main view: the active 3D camera of lowest order (Bevy draws the others over it).
    pub(super) fn view(&self) -> Option<PreviewView> {
        let (entity, camera, tf, exposure) = self
            .cameras
            .iter()
            .filter(|(_, c, _, _)| c.is_active)
            .min_by_key(|(e, c, _, _)| (c.order, *e))?;
        let world_from_clip = tf.to_matrix() * camera.clip_from_view().inverse();
        Some(PreviewView {
            entity,
            camera: PreviewCamera::new(world_from_clip, tf.translation()),
            exposure: exposure.copied().unwrap_or_default().exposure(),
        })
    }

    /// Every light, in the core's units: lumens over `4 pi` for point and spot lights (the
    /// candela Bevy's shaders use), lux for directional ones.
    pub(super) fn lights(&self) -> Vec<PreviewLight> {
        let rgb = |c: Color| Vec3::from_slice(&c.to_linear().to_f32_array()[..3]);
        let mut lights = Vec::new();
        for (light, tf) in &self.directional {
            lights.push(PreviewLight::Directional {
                direction: *tf.forward(),
                illuminance: rgb(light.color) * light.illuminance,
            });
        }
        let candela = |lumens: f32| lumens / (4.0 * core::f32::consts::PI);
        for (light, tf) in &self.points {
            lights.push(PreviewLight::Point {
                position: tf.translation(),
                intensity: rgb(light.color) * candela(light.intensity),
                range: light.range,
            });
        }
        for (light, tf) in &self.spots {
            lights.push(PreviewLight::Spot {
                position: tf.translation(),
                direction: *tf.forward(),
                intensity: rgb(light.color) * candela(light.intensity),
                range: light.range,
                inner_angle: light.inner_angle,
                outer_angle: light.outer_angle,
            });
        }
        lights
    }

    /// The ambient light's radiance (colour times brightness), or none.
    pub(super) fn ambient(&self) -> Vec3 {
        self.ambient.as_ref().map_or(Vec3::ZERO, |a| {
            Vec3::from_slice(&a.color.to_linear().to_f32_array()[..3]) * a.brightness
        })
    }

    /// The objects by slot and their materials: every tracked, visible entity with a
    /// readable mesh. `objects` keeps its meshes from the last build (a mesh BVH and its
    /// vertex copy are made once per asset), dropping those the cache no longer holds.
    pub(super) fn objects(
        &self,
        objects: &mut PreviewObjects,
        images: &Assets<Image>,
        textures: &mut HashMap<AssetId<Image>, Option<Arc<Texture>>>,
    ) -> Vec<PreviewMaterial> {
        objects.by_slot.clear();
        objects
            .by_slot
            .resize_with(self.trees.slot_entities().len(), || None);
        objects.meshes.retain(|id, _| self.cache.contains(*id));
        let mut materials = Vec::new();
        let mut material_ids = HashMap::<AssetId<StandardMaterial>, u32>::default();
        let mut material_index = |handle: Option<&MeshMaterial3d<StandardMaterial>>| match handle {
            None => u32::MAX,
            Some(handle) => *material_ids.entry(handle.0.id()).or_insert_with(|| {
                materials.push(self.material(handle.0.id(), images, textures));
                materials.len() as u32 - 1
            }),
        };
        // Posed entities first, each posed as the picking plugin poses it for rays.
        objects.posed.clear();
        let mut posed_entities = EntityHashSet::default();
        let inputs = SkinInputs {
            meshes: &self.meshes,
            bindposes: self.bindposes.as_deref(),
            joints: &self.joints,
            morph_weights: &self.morph_weights,
            this_run: self.ticks.this_run(),
        };
        let mut state = self.posed.lock();
        for (entity, skin, morph, mesh, tf, material, visible) in &self.posed_targets {
            let posing = skin.map_or(Posing::MorphOnly(tf), Posing::Skin);
            if !state.update_pose(entity, mesh.0.id(), posing, morph, &inputs) {
                continue;
            }
            // Posed or not, the walk leaves it to this list (a pose it cannot read is not
            // traced unposed: the trace shows what Bevy draws or nothing).
            posed_entities.insert(entity);
            let Some(slot) = self.trees.tracked_location(entity).map(|(slot, _)| slot) else {
                continue;
            };
            if !visible.get() {
                continue;
            }
            let crate::meshes::PosedState {
                entities, refits, ..
            } = &mut *state;
            let Some(posed) = entities.get_mut(&entity) else {
                continue;
            };
            let shape = posed.shape.clone();
            let Some(bvh) = posed.posed_bvh(refits) else {
                continue;
            };
            let mut surface = MeshSurface::new(bvh.positions().to_vec(), shape.topology.to_vec())
                .with_smooth_normals();
            surface.uvs = shape.uvs.clone();
            objects.posed.push(PosedPreviewObject {
                slot,
                bvh: bvh.mesh_bvh().clone(),
                surface,
                bounds: bvh.bounds(),
                material: material_index(material),
            });
        }
        drop(state);
        for (entity, slot) in self.trees.iter() {
            if posed_entities.contains(&entity) {
                continue;
            }
            let Ok((mesh, tf, material, visible)) = self.renderables.get(entity) else {
                continue;
            };
            if !visible.get() {
                continue;
            }
            let id = mesh.0.id();
            let preview_mesh = match objects.meshes.get(&id) {
                Some(m) => m.clone(),
                None => match self.cache.get_or_build(id, &self.meshes) {
                    Some(MeshShape::Triangles(cached)) => {
                        let m = Arc::new(PreviewMesh::new(cached));
                        objects.meshes.insert(id, m.clone());
                        m
                    }
                    _ => continue,
                },
            };
            let material = material_index(material);
            let world_from_local = tf.affine();
            objects.by_slot[slot as usize] =
                PreviewObject::new(preview_mesh, world_from_local, material);
        }
        materials
    }

    fn material(
        &self,
        id: AssetId<StandardMaterial>,
        images: &Assets<Image>,
        textures: &mut HashMap<AssetId<Image>, Option<Arc<Texture>>>,
    ) -> PreviewMaterial {
        let Some(m) = self.materials.as_ref().and_then(|all| all.get(id)) else {
            return PreviewMaterial::default();
        };
        let base = m.base_color.to_linear();
        let texture = m.base_color_texture.as_ref().and_then(|handle| {
            textures
                .entry(handle.id())
                .or_insert_with(|| images.get(handle).and_then(texture_of))
                .clone()
        });
        PreviewMaterial {
            base_color: Vec3::new(base.red, base.green, base.blue),
            base_color_texture: texture,
            emissive: Vec3::new(m.emissive.red, m.emissive.green, m.emissive.blue),
        }
    }
}

/// An image as the core's sRGB texture, read texel by texel through Bevy's own decoding
/// (any uncompressed format); `None` for an image whose texels cannot be read.
fn texture_of(image: &Image) -> Option<Arc<Texture>> {
    let (w, h) = (image.width(), image.height());
    let mut texels = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let c = image.get_color_at(x, y).ok()?.to_srgba().to_u8_array();
            texels.push(c);
        }
    }
    Texture::new(w, h, texels, TextureFilter::Bilinear).map(Arc::new)
}
