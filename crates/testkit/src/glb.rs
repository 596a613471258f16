//! Binary glTF 2.0 (GLB) files written by hand, for the assets that the test kit generates
//! (`assets/bunny.glb`, `assets/character.glb`).
//!
//! The examples load their meshes through Bevy's glTF loader, so the test kit writes what
//! that loader reads; a serializer crate would be a dependency for the sake of a few
//! hundred bytes of JSON, so the JSON is formatted here and the binary chunk is filled by
//! [`GlbBuffer`], which keeps every buffer view 4-byte aligned as glTF requires.

use std::fmt::Write;

/// glTF `componentType` of 32-bit floats.
pub const FLOAT: u32 = 5126;
/// glTF `componentType` of unsigned 16-bit integers (`JOINTS_0` uses them).
pub const UNSIGNED_SHORT: u32 = 5123;
/// glTF `componentType` of unsigned 32-bit integers (large meshes' indices).
pub const UNSIGNED_INT: u32 = 5125;
/// Buffer view `target` of vertex attributes.
pub const ARRAY_BUFFER: u32 = 34962;
/// Buffer view `target` of indices.
pub const ELEMENT_ARRAY_BUFFER: u32 = 34963;

/// The binary chunk of a GLB file being filled, with the buffer views and accessors that
/// describe it, so that a document's JSON only has to name accessors by index.
#[derive(Clone, Debug, Default)]
pub struct GlbBuffer {
    bin: Vec<u8>,
    views: Vec<String>,
    accessors: Vec<String>,
}

impl GlbBuffer {
    /// An empty buffer.
    pub fn new() -> Self {
        Self::default()
    }

    /// Appends `bytes` as a new buffer view starting on a 4-byte boundary (glTF requires
    /// accessors' offsets to be multiples of their component size) and returns its index.
    /// `target` is [`ARRAY_BUFFER`] for vertex attributes, [`ELEMENT_ARRAY_BUFFER`] for
    /// indices and `None` for data that is not for the GPU (skins, animations).
    pub fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut json = format!(
            r#"{{"buffer":0,"byteOffset":{},"byteLength":{}"#,
            self.bin.len(),
            bytes.len()
        );
        if let Some(target) = target {
            write!(json, r#","target":{target}"#).unwrap();
        }
        json.push('}');
        self.bin.extend_from_slice(bytes);
        self.views.push(json);
        self.views.len() - 1
    }

    /// Adds an accessor of `count` elements of glTF type `ty` (`"SCALAR"`, `"VEC3"`...) on
    /// buffer view `view` and returns its index. `bounds` are the per-component minimum and
    /// maximum, which glTF requires of positions and of animation times.
    pub fn accessor(
        &mut self,
        view: usize,
        component_type: u32,
        count: usize,
        ty: &str,
        bounds: Option<(&[f32], &[f32])>,
    ) -> usize {
        let mut json = format!(
            r#"{{"bufferView":{view},"componentType":{component_type},"count":{count},"type":"{ty}""#
        );
        if let Some((min, max)) = bounds {
            write!(
                json,
                r#","min":{},"max":{}"#,
                json_floats(min),
                json_floats(max)
            )
            .unwrap();
        }
        json.push('}');
        self.accessors.push(json);
        self.accessors.len() - 1
    }

    /// Adds `data`, `N` floats per element, as a view and an accessor of type `SCALAR`,
    /// `VEC2`, `VEC3`, `VEC4` or `MAT4` (by `N`), with its bounds if `bounds` is set, and
    /// returns the accessor's index.
    pub fn floats<const N: usize>(
        &mut self,
        data: &[[f32; N]],
        target: Option<u32>,
        bounds: bool,
    ) -> usize {
        let ty = match N {
            1 => "SCALAR",
            2 => "VEC2",
            3 => "VEC3",
            4 => "VEC4",
            16 => "MAT4",
            _ => panic!("no glTF accessor type has {N} floats"),
        };
        let bytes: Vec<u8> = data
            .iter()
            .flatten()
            .flat_map(|c| c.to_le_bytes())
            .collect();
        let view = self.view(&bytes, target);
        let (mut min, mut max) = ([f32::INFINITY; N], [f32::NEG_INFINITY; N]);
        for element in data {
            for (k, &c) in element.iter().enumerate() {
                min[k] = min[k].min(c);
                max[k] = max[k].max(c);
            }
        }
        let bounds = (bounds && !data.is_empty()).then_some((&min[..], &max[..]));
        self.accessor(view, FLOAT, data.len(), ty, bounds)
    }

    /// Adds `data` as a vertex attribute of four unsigned shorts per vertex (`JOINTS_0`) and
    /// returns the accessor's index.
    pub fn u16x4(&mut self, data: &[[u16; 4]]) -> usize {
        let bytes: Vec<u8> = data
            .iter()
            .flatten()
            .flat_map(|c| c.to_le_bytes())
            .collect();
        let view = self.view(&bytes, Some(ARRAY_BUFFER));
        self.accessor(view, UNSIGNED_SHORT, data.len(), "VEC4", None)
    }

    /// Adds `indices` as a triangle list's `u32` indices and returns the accessor's index.
    pub fn indices(&mut self, indices: &[u32]) -> usize {
        let bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(ELEMENT_ARRAY_BUFFER));
        self.accessor(view, UNSIGNED_INT, indices.len(), "SCALAR", None)
    }

    /// The file: `document` is the JSON object's members other than `accessors`,
    /// `bufferViews` and `buffers` (which this buffer supplies), without the braces.
    pub fn into_glb(self, document: &str) -> Vec<u8> {
        let json = format!(
            r#"{{{document},"accessors":[{}],"bufferViews":[{}],"buffers":[{{"byteLength":{}}}]}}"#,
            self.accessors.join(","),
            self.views.join(","),
            self.bin.len()
        );
        glb(&json, &self.bin)
    }
}

/// The GLB container: a 12-byte header, the JSON chunk padded with spaces and the binary
/// chunk padded with zeros, each to a multiple of 4 bytes.
pub fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut json = json.as_bytes().to_vec();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut bin = bin.to_vec();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

/// `values` as a JSON array. Rust prints the shortest decimal that reads back as the same
/// `f32`, never with an exponent, which JSON accepts as it is.
pub fn json_floats(values: &[f32]) -> String {
    let items: Vec<String> = values
        .iter()
        .map(|v| {
            assert!(v.is_finite(), "JSON has no {v}");
            // `-0` is valid JSON, but "0" reads better in the file.
            if *v == 0.0 {
                "0".to_string()
            } else {
                v.to_string()
            }
        })
        .collect();
    format!("[{}]", items.join(","))
}
