//! A Wavefront OBJ loader for the examples' models (Bevy reads glTF, not OBJ): positions and
//! polygonal faces, fan-triangulated, smooth normals computed; everything else is ignored.

use bevy::asset::io::Reader;
use bevy::asset::{AssetLoader, LoadContext, RenderAssetUsages};
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;

/// Loads `.obj` files as [`Mesh`]es: `app.init_asset_loader::<ObjLoader>()`.
#[derive(Default, TypePath)]
pub struct ObjLoader;

/// What went wrong reading an OBJ file, with its line.
#[derive(Debug)]
pub struct ObjError(String);

impl core::fmt::Display for ObjError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ObjError {}

impl AssetLoader for ObjLoader {
    type Asset = Mesh;
    type Settings = ();
    type Error = ObjError;

    async fn load(
        &self,
        reader: &mut dyn Reader,
        _settings: &(),
        _load_context: &mut LoadContext<'_>,
    ) -> Result<Mesh, ObjError> {
        let mut bytes = Vec::new();
        reader
            .read_to_end(&mut bytes)
            .await
            .map_err(|e| ObjError(e.to_string()))?;
        let text = String::from_utf8(bytes).map_err(|e| ObjError(e.to_string()))?;
        parse(&text)
    }

    fn extensions(&self) -> &[&str] {
        &["obj"]
    }
}

fn parse(text: &str) -> Result<Mesh, ObjError> {
    let (mut positions, mut indices) = (Vec::<[f32; 3]>::new(), Vec::<u32>::new());
    for (n, line) in text.lines().enumerate() {
        let err = |what: &str| ObjError(format!("line {}: {what}: {line}", n + 1));
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let c: Vec<f32> = words
                    .take(3)
                    .map(|s| s.parse().map_err(|_| err("bad coordinate")))
                    .collect::<Result<_, _>>()?;
                let [x, y, z] = c[..] else {
                    return Err(err("a vertex needs 3 coordinates"));
                };
                positions.push([x, y, z]);
            }
            Some("f") => {
                let face: Vec<u32> = words
                    .map(|s| {
                        let i: i64 = s
                            .split('/')
                            .next()
                            .unwrap_or("")
                            .parse()
                            .map_err(|_| err("bad index"))?;
                        // OBJ counts from 1, and from the end when negative.
                        let k = if i < 0 {
                            positions.len() as i64 + i
                        } else {
                            i - 1
                        };
                        u32::try_from(k)
                            .ok()
                            .filter(|&k| (k as usize) < positions.len())
                            .ok_or_else(|| err("index out of range"))
                    })
                    .collect::<Result<_, _>>()?;
                for k in 2..face.len() {
                    indices.extend([face[0], face[k - 1], face[k]]);
                }
            }
            _ => {}
        }
    }
    if indices.is_empty() {
        return Err(ObjError("no faces".into()));
    }
    Ok(Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::default(),
    )
    .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions)
    .with_inserted_indices(Indices::U32(indices))
    .with_computed_smooth_normals())
}
