//! Writes `assets/bunny.glb`, the examples' bunny, from `assets/bunny.obj`, the test kit's
//! copy: `cargo run -p accel_testkit --bin bunny_glb`.
//!
//! The examples load meshes through Bevy's own glTF loader, so the bunny they show is a
//! binary glTF file: one mesh of one indexed triangle primitive, with positions and
//! smooth normals weighted by each corner's angle (as Bevy's `Mesh::compute_smooth_normals`
//! weights them), the vertices and triangles in the OBJ file's order.

use accel_testkit::{Mesh, bunny};
use glam::Vec3;
use std::path::Path;

fn main() {
    let mesh = bunny();
    let out = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/bunny.glb");
    let glb = glb(&mesh);
    std::fs::write(&out, glb).unwrap_or_else(|e| panic!("{}: {e}", out.display()));
    println!(
        "{}: {} vertices, {} triangles",
        out.display(),
        mesh.vertices.len(),
        mesh.indices.len()
    );
}

/// Smooth vertex normals, each the sum of its triangles' normals weighted by the angle of
/// the triangle's corner at the vertex, normalized (zero where they cancel).
fn smooth_normals(mesh: &Mesh) -> Vec<Vec3> {
    let mut normals = vec![Vec3::ZERO; mesh.vertices.len()];
    for tri in &mesh.indices {
        let [a, b, c] = tri.map(|i| Vec3::from(mesh.vertices[i as usize]));
        let normal = (b - a).cross(c - a).normalize_or_zero();
        let corner = |p: Vec3, q: Vec3, r: Vec3| {
            let (u, v) = (q - p, r - p);
            if u.length_squared() * v.length_squared() > f32::EPSILON {
                u.angle_between(v)
            } else {
                0.0
            }
        };
        normals[tri[0] as usize] += normal * corner(a, b, c);
        normals[tri[1] as usize] += normal * corner(b, c, a);
        normals[tri[2] as usize] += normal * corner(c, a, b);
    }
    normals
        .into_iter()
        .map(|n| n.try_normalize().unwrap_or(Vec3::ZERO))
        .collect()
}

/// The mesh as a binary glTF 2.0 file: a JSON chunk, then one buffer of positions, normals
/// and `u32` indices.
fn glb(mesh: &Mesh) -> Vec<u8> {
    let positions: Vec<Vec3> = mesh.vertices.iter().map(|&v| v.into()).collect();
    let normals = smooth_normals(mesh);
    let mut bin = Vec::new();
    for v in positions.iter().chain(&normals) {
        for c in v.to_array() {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in mesh.indices.iter().flatten() {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    let n = positions.len();
    let vec3_bytes = n * 12;
    let index_bytes = mesh.indices.len() * 12;
    let min = positions.iter().fold(Vec3::INFINITY, |m, &p| m.min(p));
    let max = positions.iter().fold(Vec3::NEG_INFINITY, |m, &p| m.max(p));
    let json = format!(
        r#"{{"asset":{{"version":"2.0","generator":"accel_testkit bunny_glb"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0,"name":"bunny"}}],"meshes":[{{"name":"bunny","primitives":[{{"attributes":{{"POSITION":0,"NORMAL":1}},"indices":2,"mode":4}}]}}],"accessors":[{{"bufferView":0,"componentType":5126,"count":{n},"type":"VEC3","min":[{},{},{}],"max":[{},{},{}]}},{{"bufferView":1,"componentType":5126,"count":{n},"type":"VEC3"}},{{"bufferView":2,"componentType":5125,"count":{},"type":"SCALAR"}}],"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":{vec3_bytes},"target":34962}},{{"buffer":0,"byteOffset":{vec3_bytes},"byteLength":{vec3_bytes},"target":34962}},{{"buffer":0,"byteOffset":{},"byteLength":{index_bytes},"target":34963}}],"buffers":[{{"byteLength":{}}}]}}"#,
        min.x,
        min.y,
        min.z,
        max.x,
        max.y,
        max.z,
        mesh.indices.len() * 3,
        2 * vec3_bytes,
        bin.len(),
    );
    accel_testkit::glb::glb(&json, &bin)
}
