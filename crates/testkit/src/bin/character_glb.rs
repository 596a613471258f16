//! Writes `assets/character.glb`, the `animated` example's skinned character, from
//! `accel_testkit::skinned`: `cargo run -p accel_testkit --bin character_glb [-- TRIANGLES]`.
//!
//! The committed file is the default character (about 5k triangles); a triangle count as the
//! argument writes a finer or coarser one in its place, for trying the example's picking on
//! heavier meshes. The test `tests/character_glb.rs` checks the committed file against the
//! module.

use accel_testkit::skinned::{Detail, character, character_glb_path};

fn main() {
    let detail = match std::env::args().nth(1) {
        Some(arg) => {
            let triangles = arg
                .parse()
                .unwrap_or_else(|_| panic!("expected a triangle count, got {arg:?}"));
            Detail::for_triangles(triangles)
        }
        None => Detail::default(),
    };
    let character = character(detail);
    let glb = character.to_glb();
    let out = character_glb_path();
    std::fs::write(&out, &glb).unwrap_or_else(|e| panic!("{}: {e}", out.display()));
    println!(
        "{}: {} vertices, {} triangles ({detail:?}), {} bytes",
        out.display(),
        character.positions.len(),
        character.triangle_count(),
        glb.len()
    );
}
