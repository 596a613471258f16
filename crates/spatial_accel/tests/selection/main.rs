//! Box selection against the screen-space brute force a game would write: the rectangle's
//! frustum ([`Frustum::from_clip_rect`]) and the three selection tests on random Bevy
//! cameras (infinite reverse-z perspective and reverse-z orthographic), random rectangles
//! (inverted, zero-width, off the screen, larger than it), boxes and triangles; grazing
//! triangles on the conservative side; and the mesh tree's query against every triangle.
//!
//! - [`oracle`]: the cameras and the projecting oracle.
//! - [`grazing`]: triangles built to touch a plane at a point, along an edge or in a face.
//! - [`mesh`]: [`MeshBvh::any_triangle_in_frustum`] and the frustum moved into a mesh's space.

mod grazing;
mod mesh;
mod oracle;

use accel_testkit::Rng;
use glam::{DVec2, DVec3, Mat4, Vec2, Vec3, Vec3A};
use oracle::{Camera, Kind, Oracle, d, f, random_rect};
use spatial_accel::{Aabb, Containment, Frustum, Plane, SelectionMode};

/// Disagreements with the oracle that the rounding band may excuse, at most one in this many
/// cases per test and camera kind, before the band counts as hit too often. The test prints
/// the counts: for touching, where the band is the conservative side, a few in a hundred
/// thousand; for the others, next to none (the cameras keep what they draw where `f32`
/// positions resolve the view, see `Camera::depth`).
const BAND_RARITY: u64 = 4000;

/// Agreement of one selection test with the oracle.
#[derive(Default, Debug)]
struct Tally {
    cases: u64,
    selected: u64,
    /// Disagreements inside the rounding band.
    excused: u64,
    /// Disagreements outside it (or on the wrong side for touching).
    wrong: u64,
    first_wrong: Option<String>,
    first_excused: Vec<String>,
}

impl Tally {
    fn record(
        &mut self,
        got: bool,
        want: bool,
        excused: impl FnOnce() -> bool,
        case: impl FnOnce() -> String,
    ) {
        self.cases += 1;
        self.selected += u64::from(want);
        if got == want {
            return;
        }
        if excused() {
            self.excused += 1;
            if self.first_excused.len() < 8 {
                self.first_excused
                    .push(format!("got {got}, want {want}: {}", case()));
            }
        } else {
            self.wrong += 1;
            if self.first_wrong.is_none() {
                self.first_wrong = Some(format!("got {got}, want {want}: {}", case()));
            }
        }
    }

    fn check(&self, what: &str) {
        println!(
            "{what}: {} cases, {} selected, {} in the band",
            self.cases, self.selected, self.excused
        );
        assert_eq!(self.wrong, 0, "{what}: {self:?}");
        assert!(
            self.excused * BAND_RARITY <= self.cases,
            "{what}: band hit too often: {self:?}"
        );
        assert!(
            self.selected * 40 > self.cases && (self.cases - self.selected) * 40 > self.cases,
            "{what}: generator lost its mix: {self:?}"
        );
    }
}

/// A point on the screen near the rectangle (or anywhere, one time in five).
fn ndc_near(rng: &mut Rng, a: Vec2, b: Vec2) -> DVec2 {
    if rng.below(5) == 0 {
        return DVec2::new(rng.range_f64(-1.5, 1.5), rng.range_f64(-1.5, 1.5));
    }
    let (lo, hi) = (a.min(b).as_dvec2(), a.max(b).as_dvec2());
    let u = DVec2::new(rng.range_f64(-0.5, 1.5), rng.range_f64(-0.5, 1.5));
    lo + (hi - lo) * u + DVec2::new(rng.range_f64(-0.05, 0.05), rng.range_f64(-0.05, 0.05))
}

/// A random box near the rectangle, at a random depth (in view, at the near plane, behind).
fn random_box(rng: &mut Rng, camera: &Camera, a: Vec2, b: Vec2) -> Aabb {
    let depth = camera.depth(rng);
    let centre = camera.world(camera.view_point(ndc_near(rng, a, b), depth));
    let size = camera.size_at(depth);
    let half = DVec3::new(
        f64::from(rng.log_range(1e-3, 0.5)),
        f64::from(rng.log_range(1e-3, 0.5)),
        f64::from(rng.log_range(1e-3, 0.5)),
    ) * size;
    Aabb::from_center_half_extents(f(centre), f(half))
}

/// A random triangle near the rectangle: small to several times the view, some reaching
/// across the near plane or behind the eye.
fn random_triangle(rng: &mut Rng, camera: &Camera, a: Vec2, b: Vec2) -> [Vec3A; 3] {
    let depth = camera.depth(rng);
    let centre = camera.view_point(ndc_near(rng, a, b), depth);
    let size = camera.size_at(depth) * f64::from(rng.log_range(0.01, 3.0));
    let deep = rng.below(6) == 0;
    [0; 3].map(|_| {
        let mut offset = DVec3::new(
            rng.range_f64(-1.0, 1.0),
            rng.range_f64(-1.0, 1.0),
            rng.range_f64(-1.0, 1.0),
        ) * size;
        if deep {
            offset.z = rng.range_f64(-1.0, 1.0) * depth.abs().max(camera.near) * 2.0;
        }
        f(camera.world(centre + offset))
    })
}

/// Runs the three tests on `cameras` random cameras of `kind`, eight rectangles each, against
/// the oracle, after `mutate` (the identity, or a planted bug) has touched each frustum.
fn compare(seed: u64, kind: Kind, cameras: usize, mutate: &dyn Fn(&mut Frustum)) -> [Tally; 3] {
    let mut rng = Rng::new(seed);
    let [mut centre, mut enclosed, mut touching] = [(); 3].map(|_| Tally::default());
    for _ in 0..cameras {
        let camera = Camera::random(&mut rng, kind, 1e3, None);
        for _ in 0..8 {
            let (a, b) = random_rect(&mut rng);
            let mut frustum = Frustum::from_clip_rect(&camera.clip_from_world, a, b).unwrap();
            mutate(&mut frustum);
            let oracle = Oracle::new(&camera.clip_from_world, a, b);
            let case = |what: String| format!("{kind:?} rect {a} {b} {what}");
            for _ in 0..60 {
                let aabb = random_box(&mut rng, &camera, a, b);
                let c = d(aabb.center());
                centre.record(
                    frustum.contains_aabb_center(&aabb),
                    oracle.point(c),
                    || oracle.point_in_band(c, 2.0),
                    || case(format!("{aabb:?}")),
                );
                let corners = aabb.corners().map(d);
                enclosed.record(
                    frustum.encloses_aabb(&aabb),
                    corners.iter().all(|&p| oracle.point(p)),
                    || corners.iter().any(|&p| oracle.point_in_band(p, 2.0)),
                    || case(format!("{aabb:?}")),
                );
                let triangle = random_triangle(&mut rng, &camera, a, b);
                let want = oracle.triangle(triangle.map(d));
                // Only the conservative side is excused: a triangle within the band outside
                // called touching. One the oracle sees touching is never missed.
                touching.record(
                    frustum.touches_triangle(&triangle),
                    want,
                    || !want && oracle.triangle_within_band(triangle.map(d), 2.0),
                    || case(format!("{triangle:?}")),
                );
            }
        }
    }
    [centre, enclosed, touching]
}

#[test]
fn selection_tests_agree_with_the_projecting_oracle() {
    for (seed, kind) in [(1, Kind::Perspective), (2, Kind::Orthographic)] {
        let [centre, enclosed, touching] = compare(seed, kind, 250, &|_| {});
        centre.check(&format!("{kind:?} centre"));
        enclosed.check(&format!("{kind:?} enclosed"));
        touching.check(&format!("{kind:?} touching"));
    }
}

/// The comparison sees a planted sign error in any plane, in every test.
#[test]
fn a_flipped_plane_is_caught() {
    for kind in [Kind::Perspective, Kind::Orthographic] {
        for plane in 0..6 {
            let flip = |f: &mut Frustum| {
                let p = &mut f.planes[plane];
                *p = Plane {
                    normal: -p.normal,
                    d: -p.d,
                };
            };
            let tallies = compare(3, kind, 20, &flip);
            for (tally, test) in tallies.iter().zip(["centre", "enclosed", "touching"]) {
                assert!(
                    tally.wrong > 0,
                    "{kind:?} plane {plane} flipped: {test} missed it"
                );
            }
        }
    }
}

#[test]
fn full_screen_rect_is_the_view_frustum_without_far_plane() {
    let mut rng = Rng::new(4);
    for kind in [Kind::Perspective, Kind::Orthographic] {
        for _ in 0..100 {
            let camera = Camera::random(&mut rng, kind, 1e3, None);
            let view = Frustum::from_clip_from_world(&camera.clip_from_world);
            let rect =
                Frustum::from_clip_rect(&camera.clip_from_world, Vec2::NEG_ONE, Vec2::ONE).unwrap();
            for (a, b) in view.planes[..5].iter().zip(&rect.planes[..5]) {
                let scale = 1.0 + a.d.abs();
                assert!(
                    a.normal.distance(b.normal) < 1e-5,
                    "{kind:?}: {a:?} vs {b:?}"
                );
                assert!((a.d - b.d).abs() < 1e-5 * scale, "{kind:?}: {a:?} vs {b:?}");
            }
            assert_eq!(rect.planes[Frustum::FAR].normal, Vec3A::ZERO);
            assert!(rect.planes[Frustum::FAR].d > 0.0);
        }
    }
}

#[test]
fn inverted_rects_are_sorted_and_bad_input_refused() {
    let proj = Mat4::perspective_infinite_reverse_rh(1.0, 1.5, 0.1);
    let m = proj * Mat4::look_at_rh(Vec3::new(1.0, 2.0, 3.0), Vec3::ZERO, Vec3::Y);
    let (lo, hi) = (Vec2::new(-0.3, -0.2), Vec2::new(0.5, 0.1));
    let sorted = Frustum::from_clip_rect(&m, lo, hi).unwrap();
    for (a, b) in [(hi, lo), (Vec2::new(lo.x, hi.y), Vec2::new(hi.x, lo.y))] {
        assert_eq!(Frustum::from_clip_rect(&m, a, b), Some(sorted));
    }
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        assert_eq!(Frustum::from_clip_rect(&m, Vec2::new(bad, 0.0), hi), None);
        assert_eq!(Frustum::from_clip_rect(&m, lo, Vec2::new(0.0, bad)), None);
        let mut broken = m;
        broken.z_axis.y = bad;
        assert_eq!(Frustum::from_clip_rect(&broken, lo, hi), None);
    }
}

/// A zero-width rectangle's opposite planes are exact negatives: a point is inside only on
/// them, and the boxes around it are never enclosed.
#[test]
fn zero_width_rect_has_zero_thickness() {
    let proj = Mat4::perspective_infinite_reverse_rh(1.0, 1.5, 0.1);
    let m = proj * Mat4::look_at_rh(Vec3::new(1.0, 2.0, 3.0), Vec3::ZERO, Vec3::Y);
    let line = Frustum::from_clip_rect(&m, Vec2::new(0.25, -0.5), Vec2::new(0.25, 0.5)).unwrap();
    let [left, right, ..] = line.planes;
    assert_eq!((left.normal, left.d), (-right.normal, -right.d));
    let eye = Vec3A::new(1.0, 2.0, 3.0);
    let on_centre_line = Aabb::from_center_half_extents(eye * 0.5, Vec3A::splat(0.01));
    assert_eq!(line.classify_aabb(&on_centre_line), Containment::Outside);
    let across = Aabb::from_center_half_extents(Vec3A::ZERO, Vec3A::splat(1.0));
    assert!(line.intersects_aabb(&across));
    assert!(!line.encloses_aabb(&across));
}

#[test]
fn modes_decide_by_box_where_the_box_decides() {
    let proj = Mat4::perspective_infinite_reverse_rh(1.0, 1.0, 0.1);
    let m = proj * Mat4::look_at_rh(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y);
    let rect = Frustum::from_clip_rect(&m, Vec2::new(0.0, -1.0), Vec2::ONE).unwrap();
    let across = Aabb::from_center_half_extents(Vec3A::new(0.2, 0.0, -10.0), Vec3A::splat(0.5));
    let behind = Aabb::from_center_half_extents(Vec3A::new(0.0, 0.0, 10.0), Vec3A::splat(0.5));
    let invalid = Aabb::new(Vec3A::splat(f32::NAN), Vec3A::ZERO);
    assert_eq!(
        SelectionMode::Center.select_by_aabb(&rect, &across),
        Some(true)
    );
    assert_eq!(
        SelectionMode::Enclosed.select_by_aabb(&rect, &across),
        Some(false)
    );
    assert_eq!(SelectionMode::Touching.select_by_aabb(&rect, &across), None);
    for mode in [
        SelectionMode::Center,
        SelectionMode::Enclosed,
        SelectionMode::Touching,
    ] {
        assert_eq!(mode.select_by_aabb(&rect, &behind), Some(false), "{mode:?}");
        assert_eq!(
            mode.select_by_aabb(&rect, &invalid),
            Some(false),
            "{mode:?}"
        );
        assert_eq!(
            mode.select_by_aabb(&rect, &Aabb::EMPTY),
            Some(false),
            "{mode:?}"
        );
    }
}

/// A transform that is not finite leaves no plane undecided: the frustum holds nothing.
#[test]
fn non_finite_transform_gives_an_empty_frustum() {
    let proj = Mat4::perspective_infinite_reverse_rh(1.0, 1.0, 0.1);
    let m = proj * Mat4::look_at_rh(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y);
    let rect = Frustum::from_clip_rect(&m, Vec2::NEG_ONE, Vec2::ONE).unwrap();
    let ahead = Aabb::from_center_half_extents(Vec3A::new(0.0, 0.0, -10.0), Vec3A::ONE);
    let triangle = [
        Vec3A::new(-1.0, -1.0, -10.0),
        Vec3A::new(1.0, -1.0, -10.0),
        Vec3A::new(0.0, 1.0, -10.0),
    ];
    for bad in [f32::NAN, f32::INFINITY] {
        for broken in [
            Mat4::from_translation(Vec3::new(bad, 0.0, 0.0)),
            Mat4::from_scale(Vec3::new(1.0, bad, 1.0)),
        ] {
            let local = rect.transformed(&broken);
            assert_eq!(
                local.classify_aabb(&ahead),
                Containment::Outside,
                "{broken}"
            );
            assert!(!local.touches_triangle(&triangle), "{broken}");
        }
    }
    // A finite one keeps it.
    let local = rect.transformed(&Mat4::from_scale(Vec3::new(2.0, -1.0, 0.5)));
    assert!(local.touches_triangle(&triangle));
    assert_eq!(
        local.classify_aabb(&Aabb::from_center_half_extents(
            Vec3A::new(0.0, 0.0, -20.0),
            Vec3A::splat(0.1)
        )),
        Containment::Inside
    );
}
