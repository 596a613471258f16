//! `InstancedScene::update_instances` allocates nothing once it only refits: a game moves
//! instances every frame, and an allocation per frame is what Bevy users profile for.
//!
//! Its own test binary, because it counts every allocation through the global allocator.

use glam::{Affine3A, Vec3};
use spatial_accel::mesh::{Instance, InstancedScene, MeshBvh};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

/// The system allocator, counting the allocations and reallocations of threads that asked
/// for it (the test harness's own threads may allocate meanwhile).
struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    static COUNTED: Cell<bool> = const { Cell::new(false) };
}

fn count_this_thread() {
    if COUNTED.with(Cell::get) {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
    }
}

// SAFETY: every call is forwarded to `System` unchanged.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count_this_thread();
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count_this_thread();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

fn cube() -> Arc<MeshBvh> {
    let corners: Vec<Vec3> = (0..8)
        .map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32))
        .collect();
    let faces = [
        [0, 2, 1, 1, 2, 3],
        [4, 5, 6, 5, 7, 6],
        [0, 1, 4, 1, 5, 4],
        [2, 6, 3, 3, 6, 7],
        [0, 4, 2, 2, 4, 6],
        [1, 3, 5, 3, 7, 5],
    ];
    let indices: Vec<u32> = faces.iter().flatten().copied().collect();
    Arc::new(MeshBvh::new(&corners, &indices).expect("a cube"))
}

/// Instance `i` of a 10 x 10 x 10 lattice, moved along x by `shift`.
fn placed(mesh: &Arc<MeshBvh>, i: u32, shift: f32) -> Instance {
    let cell = Vec3::new((i % 10) as f32, ((i / 10) % 10) as f32, (i / 100) as f32);
    Instance {
        mesh: mesh.clone(),
        world_from_local: Affine3A::from_translation(cell * 3.0 + Vec3::X * shift),
    }
}

#[test]
fn refitting_updates_allocate_nothing() {
    let mesh = cube();
    let mut scene = InstancedScene::new((0..1000).map(|i| placed(&mesh, i, 0.0)).collect());
    // Far below the rebuild threshold: ten instances nudged by a hundredth of their size.
    let frame = |k: u32| (0..10).map(move |j| (j * 97 + k) % 1000);
    let nudge = |k: u32, i: u32| (i, placed(&mesh, i, 0.01 * (k % 2) as f32));
    // The first updates make the refit links and grow the kept lists.
    for k in 0..4 {
        scene
            .update_instances(frame(k).map(|i| nudge(k, i)))
            .expect("indices in range");
    }
    COUNTED.with(|c| c.set(true));
    let before = ALLOCATIONS.load(Ordering::Relaxed);
    for k in 4..64 {
        scene
            .update_instances(frame(k % 4).map(|i| nudge(k, i)))
            .expect("indices in range");
    }
    let allocations = ALLOCATIONS.load(Ordering::Relaxed) - before;
    COUNTED.with(|c| c.set(false));
    assert_eq!(allocations, 0, "allocations in 60 refitting updates");
    // The updates were refits, not rebuilds, and the scene still answers from the new places.
    let ray = spatial_accel::Ray::new(glam::Vec3A::new(0.5, 0.5, -5.0), glam::Vec3A::Z);
    let hit = scene
        .cast_ray(&ray, spatial_accel::Backfaces::Include)
        .expect("the first cube");
    assert_eq!(hit.instance, 0);
}
