//! The screen-space brute force a game would write, in `f64` on the same `f32` inputs: project
//! each point (after clipping at the near plane in clip space) and compare with the NDC
//! rectangle in 2D. And the random cameras, rectangles and shapes it is run on.

use accel_testkit::Rng;
use accel_testkit::screen_oracle::{clip_polygon, polygon_meets_rect};
use glam::{DMat4, DVec2, DVec3, DVec4, Mat4, Vec2, Vec3, Vec3A};
use spatial_accel::TOUCH_TOLERANCE;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Bevy's `perspective_infinite_reverse_rh`.
    Perspective,
    /// Bevy's orthographic projection: `orthographic_rh` with near and far swapped (reverse-z).
    Orthographic,
}

/// A random camera, Bevy's way.
#[derive(Clone, Debug)]
pub struct Camera {
    pub kind: Kind,
    pub clip_from_world: Mat4,
    world_from_view: DMat4,
    /// Perspective: `tan(fov / 2)`, the aspect, the near distance.
    tan_half: f64,
    aspect: f64,
    pub near: f64,
    /// Orthographic: the view's area on x and y.
    area: [f64; 4],
    far: f64,
    /// The least distance from the eye at which `f32` world positions resolve the view:
    /// 2^-12 of the eye's distance from the origin (positions there are good to 2^-12 of
    /// that distance). Nearer, every point is within rounding of every plane.
    resolved: f64,
}

impl Camera {
    /// Eye up to `reach` from the origin (log-uniform from a thousandth of that) looking
    /// anywhere, or at `target` when given.
    pub fn random(rng: &mut Rng, kind: Kind, reach: f32, target: Option<Vec3>) -> Self {
        loop {
            let eye = Vec3::from(rng.unit_vector_f64() * rng.log_range(reach * 1e-3, reach));
            let fwd = match target {
                Some(t) => (t - eye).normalize_or_zero(),
                None => Vec3::from(rng.unit_vector_f64()),
            };
            let up = Vec3::from(rng.unit_vector_f64());
            if fwd.cross(up).length() < 0.05 {
                continue;
            }
            let view = Mat4::look_to_rh(eye, fwd, up);
            let (fov, aspect) = (rng.range(0.3, 2.5), rng.range(0.5, 2.5));
            let near = rng.log_range(0.01, 1.0);
            let (proj, area, near, far) = match kind {
                Kind::Perspective => (
                    Mat4::perspective_infinite_reverse_rh(fov, aspect, near),
                    [0.0; 4],
                    near,
                    0.0,
                ),
                Kind::Orthographic => {
                    // From a few world units across (a 3D view) to a window's pixels (2D).
                    let (w, h) = (rng.log_range(1.0, 1000.0), rng.log_range(1.0, 1000.0));
                    let off = rng.range(-0.5, 0.5) * w;
                    // Bevy's 3D default starts at the eye, its 2D one 1000 behind it.
                    let near = match rng.below(3) {
                        0 => 0.0,
                        1 => near,
                        _ => -rng.log_range(1.0, 1000.0),
                    };
                    let far = near + rng.log_range(10.0, 2000.0);
                    let area = [off - w, off + w, -h, h];
                    let proj = Mat4::orthographic_rh(area[0], area[1], area[2], area[3], far, near);
                    (proj, area.map(f64::from), near, far)
                }
            };
            let clip_from_world = proj * view;
            if !clip_from_world.is_finite() {
                continue;
            }
            return Self {
                kind,
                clip_from_world,
                world_from_view: view.as_dmat4().inverse(),
                tan_half: (f64::from(fov) * 0.5).tan(),
                aspect: f64::from(aspect),
                near: f64::from(near),
                area,
                far: f64::from(far),
                resolved: f64::from(eye.abs().max_element()) / 256.0,
            };
        }
    }

    /// The view-space point at `ndc` on the screen and `depth` ahead of the eye (negative:
    /// behind it).
    pub fn view_point(&self, ndc: DVec2, depth: f64) -> DVec3 {
        match self.kind {
            Kind::Perspective => DVec3::new(
                ndc.x * depth * self.tan_half * self.aspect,
                ndc.y * depth * self.tan_half,
                -depth,
            ),
            Kind::Orthographic => {
                let [l, r, b, t] = self.area;
                let u = (ndc + 1.0) * 0.5;
                DVec3::new(l + (r - l) * u.x, b + (t - b) * u.y, -depth)
            }
        }
    }

    /// A view-space point in the world, in `f64`.
    pub fn world(&self, view: DVec3) -> DVec3 {
        self.world_from_view.transform_point3(view)
    }

    /// A depth ahead of the eye: mostly in view, some around the near plane, some behind it
    /// or behind the eye; never nearer the eye than `f32` positions resolve.
    pub fn depth(&self, rng: &mut Rng) -> f64 {
        let near = self.near;
        let depth = match self.kind {
            Kind::Perspective => match rng.below(10) {
                0 => -f64::from(rng.log_range(1e-3, 100.0)) * near.max(0.1),
                1 => near * rng.range_f64(0.5, 1.5),
                _ => near * f64::from(rng.log_range(1.0, 1e4)),
            },
            Kind::Orthographic => match rng.below(10) {
                0 => near - rng.range_f64(0.0, 100.0),
                1 => near + rng.range_f64(-1.0, 1.0),
                _ => near + rng.range_f64(0.0, (self.far - near) * 1.5),
            },
        };
        if depth.abs() < self.resolved {
            self.resolved.copysign(depth) * rng.range_f64(1.0, 2.0)
        } else {
            depth
        }
    }

    /// A depth well in view: past the near plane, before the far one of an orthographic
    /// camera.
    pub fn depth_in_view(&self, rng: &mut Rng) -> f64 {
        match self.kind {
            Kind::Perspective => self.near * f64::from(rng.log_range(1.5, 1e3)),
            Kind::Orthographic => self.near + (self.far - self.near) * rng.range_f64(0.05, 1.0),
        }
    }

    /// Half the view's height at a depth: the size shapes are drawn at.
    pub fn size_at(&self, depth: f64) -> f64 {
        match self.kind {
            Kind::Perspective => depth.abs().max(self.near) * self.tan_half,
            Kind::Orthographic => (self.area[3] - self.area[2]) * 0.5,
        }
    }
}

/// A random rectangle in NDC, its corners in either order: ordinary drags, drags reaching
/// past the screen, tiny ones, ones wholly off the screen, and zero-width ones (a line, a
/// point).
pub fn random_rect(rng: &mut Rng) -> (Vec2, Vec2) {
    let mut a = Vec2::new(rng.range(-1.2, 1.2), rng.range(-1.2, 1.2));
    let mut b = Vec2::new(rng.range(-1.2, 1.2), rng.range(-1.2, 1.2));
    match rng.below(10) {
        0 => b.x = a.x,
        1 => b.y = a.y,
        2 => b = a,
        3 => {
            a *= 4.0;
            b *= 4.0;
        }
        4 => b = a + Vec2::new(rng.signed_log(1e-4, 1e-2), rng.signed_log(1e-4, 1e-2)),
        5 => {
            a.x = rng.range(1.1, 3.0);
            b.x = a.x + rng.range(0.0, 2.0);
        }
        _ => {}
    }
    (a, b)
}

/// The screen-space answer for one rectangle: what a game that projects everything would
/// select, and (only to excuse a disagreement) the `f64` planes of the same matrix.
pub struct Oracle {
    m: DMat4,
    lo: DVec2,
    hi: DVec2,
    /// The five planes (left, right, bottom, top, near) from the matrix's rows, in `f64`,
    /// unit normals.
    planes: [DVec4; 5],
}

impl Oracle {
    pub fn new(clip_from_world: &Mat4, a: Vec2, b: Vec2) -> Self {
        let m = clip_from_world.as_dmat4();
        let (lo, hi) = (a.min(b).as_dvec2(), a.max(b).as_dvec2());
        let t = m.transpose();
        let (r0, r1, r2, r3) = (t.x_axis, t.y_axis, t.z_axis, t.w_axis);
        let planes = [
            r0 - r3 * lo.x,
            r3 * hi.x - r0,
            r1 - r3 * lo.y,
            r3 * hi.y - r1,
            r3 - r2,
        ]
        .map(|p| p / p.truncate().length());
        Self { m, lo, hi, planes }
    }

    fn clip(&self, p: DVec3) -> DVec4 {
        self.m * p.extend(1.0)
    }

    /// Whether the point is drawn inside the rectangle: in front of the near plane, and its
    /// projection inside.
    pub fn point(&self, p: DVec3) -> bool {
        let c = self.clip(p);
        if !(c.z <= c.w && c.w > 0.0) {
            return false;
        }
        let ndc = c.truncate().truncate() / c.w;
        ndc.cmpge(self.lo).all() && ndc.cmple(self.hi).all()
    }

    /// Whether the triangle is drawn over the rectangle: clipped at the near plane in clip
    /// space, projected, and tested against the rectangle by separating axes in 2D.
    pub fn triangle(&self, corners: [DVec3; 3]) -> bool {
        let clipped = clip_polygon(&corners.map(|p| self.clip(p)), |c| c.w - c.z);
        let projected: Vec<DVec2> = clipped
            .iter()
            .map(|c| c.truncate().truncate() / c.w)
            .collect();
        polygon_meets_rect(&projected, self.lo, self.hi)
    }

    /// The band of a plane at points up to `scale` on each axis: `bands` touching bands.
    fn band(&self, plane: &DVec4, scale: f64, bands: f64) -> f64 {
        bands
            * f64::from(TOUCH_TOLERANCE)
            * (plane.w.abs() + plane.truncate().abs().element_sum() * scale)
    }

    /// Whether moving every plane by `bands` bands, in or out, changes the point's verdict:
    /// the rounding band in which the `f32` frustum may disagree.
    pub fn point_in_band(&self, p: DVec3, bands: f64) -> bool {
        let scale = p.abs().max_element();
        let inside = |sign: f64| {
            self.planes
                .iter()
                .all(|pl| pl.truncate().dot(p) + pl.w + sign * self.band(pl, scale, bands) >= 0.0)
        };
        inside(1.0) != inside(-1.0)
    }

    /// Whether the triangle meets the frustum with every plane moved out by `bands` bands
    /// (in, for a negative count), clipped in world space in `f64`: with a positive count, a
    /// triangle the `f32` test may call touching; with a negative one, a triangle that
    /// reaches in farther than the band.
    pub fn triangle_within_band(&self, corners: [DVec3; 3], bands: f64) -> bool {
        let scale = corners
            .iter()
            .fold(0.0f64, |m, c| m.max(c.abs().max_element()));
        let mut polygon: Vec<DVec4> = corners.iter().map(|c| c.extend(1.0)).collect();
        for pl in &self.planes {
            let band = self.band(pl, scale, bands);
            polygon = clip_polygon(&polygon, |p| pl.dot(p) + band);
        }
        !polygon.is_empty()
    }
}

/// `f32` world points widened exactly.
pub fn d(v: Vec3A) -> DVec3 {
    v.as_dvec3()
}

/// An `f64` point rounded to the `f32` grid.
pub fn f(v: DVec3) -> Vec3A {
    v.as_vec3a()
}
