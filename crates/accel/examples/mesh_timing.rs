//! Prints mesh BVH build rate and refit cost per triangle on a ~1M-triangle sphere: a quick
//! look before the criterion benches. `cargo run --release -p accel --example mesh_timing`.

use accel::mesh::MeshBvh;
use glam::Vec3;
use std::time::Instant;

fn main() {
    let (rings, segments) = (708u32, 708u32);
    let mut vertices = Vec::new();
    for r in 0..=rings {
        let phi = core::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..segments {
            let theta = core::f32::consts::TAU * s as f32 / segments as f32;
            vertices.push(
                Vec3::new(phi.sin() * theta.cos(), phi.cos(), phi.sin() * theta.sin()) * 10.0,
            );
        }
    }
    let mut indices = Vec::new();
    for r in 0..rings {
        for s in 0..segments {
            let (a, b) = (r * segments + s, r * segments + (s + 1) % segments);
            let (c, d) = (a + segments, b + segments);
            indices.extend_from_slice(&[a, c, b, b, c, d]);
        }
    }
    let n = indices.len() / 3;
    let mut best = f64::INFINITY;
    let mut mesh = None;
    for _ in 0..3 {
        let t = Instant::now();
        mesh = Some(MeshBvh::new(&vertices, &indices).expect("valid mesh"));
        best = best.min(t.elapsed().as_secs_f64());
    }
    let mut mesh = mesh.expect("built");
    println!(
        "build: {n} triangles in {:.1} ms = {:.2} M tris/s",
        best * 1e3,
        n as f64 / best / 1e6
    );
    // A skinned-like pose: every vertex displaced a little.
    let moved: Vec<Vec3> = vertices
        .iter()
        .enumerate()
        .map(|(i, v)| *v * (1.0 + 0.01 * (i % 7) as f32))
        .collect();
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let t = Instant::now();
        mesh.refit(&moved).expect("same vertex count");
        best = best.min(t.elapsed().as_secs_f64());
    }
    println!(
        "refit: {:.1} ms = {:.1} ns per triangle",
        best * 1e3,
        best * 1e9 / n as f64
    );
}
