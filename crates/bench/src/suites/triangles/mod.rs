//! The triangle structures besides the BVHs: the SAH kd-tree against our mesh BVH and the
//! `kdtree-ray` crate (`kdtree.rs`), and the BSP tree against the mesh BVH (`bsp.rs`).

mod bsp;
mod kdtree;

use crate::json::Report;
use crate::progress::Progress;
use glam::Vec3;

/// A mesh as the trees take it.
struct TestMesh {
    vertices: Vec<Vec3>,
    indices: Vec<u32>,
}

/// The Stanford bunny as read (3,674 triangles).
fn bunny() -> TestMesh {
    let m = accel_testkit::bunny();
    TestMesh {
        vertices: m.positions(),
        indices: m.flat_indices(),
    }
}

/// Runs the suite.
pub fn run(quick: bool) -> Report {
    let kd = kdtree::Settings::new(quick);
    let mut progress = Progress::new("triangles", kd.steps() + 1);
    let mut report = Report {
        suite: "triangles".into(),
        quick,
        ..Report::default()
    };
    kdtree::run(&kd, &mut report, &mut progress);
    progress.step("BSP tree");
    bsp::run(quick, &mut report);
    progress.finish();
    report
}
