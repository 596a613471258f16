//! A small software rasteriser for the painter's-order tests: a perspective camera, flat
//! fills by triangle id, a painter's pass (no depth buffer) and a depth-buffered pass, and
//! the pixels where the two may honestly differ (near an edge, or where two depths tie).

use glam::{DVec2, DVec3, Vec3A};

/// Pixels closer than this to a projected edge are not compared: which side of an edge a
/// pixel centre falls on is a rounding matter there.
const EDGE_PIXELS: f64 = 1.0;
/// Relative depth gap under which two surfaces tie at a pixel (where triangles cross, or a
/// piece's rounded corner pokes through its neighbour).
const DEPTH_TIE: f64 = 1e-4;

/// A pinhole camera looking from `eye` towards a target.
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    pub eye: DVec3,
    forward: DVec3,
    right: DVec3,
    up: DVec3,
    /// Pixels per unit of `x / z` on the image plane.
    focal: f64,
    /// Pixels a side.
    size: usize,
    /// Triangles with a corner nearer than this (along the view axis) are left out of both
    /// passes alike: their projections are unbounded.
    near: f64,
}

impl Camera {
    /// A camera with a 60 degree field of view and an image `size` pixels a side; `near` as
    /// in the type's docs.
    pub fn look_at(eye: Vec3A, target: Vec3A, near: f64, size: usize) -> Self {
        let (eye, target) = (eye.as_dvec3(), target.as_dvec3());
        let forward = (target - eye).normalize();
        let helper = if forward.z.abs() < 0.9 {
            DVec3::Z
        } else {
            DVec3::X
        };
        let right = forward.cross(helper).normalize();
        let up = right.cross(forward);
        let focal = (size as f64 / 2.0) / (30f64.to_radians().tan());
        Self {
            eye,
            forward,
            right,
            up,
            focal,
            size,
            near,
        }
    }

    /// Screen position and view depth of a point.
    fn project(&self, p: Vec3A) -> (DVec2, f64) {
        let v = p.as_dvec3() - self.eye;
        let z = v.dot(self.forward);
        let half = self.size as f64 / 2.0;
        let s = DVec2::new(v.dot(self.right), v.dot(self.up)) * (self.focal / z) + half;
        (s, z)
    }

    /// The view depth at which the ray through the pixel centre `s` meets the plane of the
    /// triangle (exact up to f64 rounding: the perspective-correct depth).
    fn depth_at(&self, s: DVec2, corners: &[DVec3; 3]) -> f64 {
        let half = self.size as f64 / 2.0;
        let d = self.forward
            + self.right * ((s.x - half) / self.focal)
            + self.up * ((s.y - half) / self.focal);
        let n = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
        n.dot(corners[0] - self.eye) / n.dot(d)
    }
}

/// A triangle on screen: its corners there, in the world, and the pixels it may cover.
struct Projected {
    screen: [DVec2; 3],
    world: [DVec3; 3],
    pixels: [usize; 4],
}

fn project(camera: &Camera, corners: &[Vec3A; 3], grow: f64) -> Option<Projected> {
    let projected = corners.map(|c| camera.project(c));
    if !projected.iter().all(|&(_, z)| z > camera.near) {
        return None;
    }
    let screen = projected.map(|(s, _)| s);
    let lo = screen[0].min(screen[1]).min(screen[2]) - grow;
    let hi = screen[0].max(screen[1]).max(screen[2]) + grow;
    let clamp = |x: f64| x.clamp(0.0, camera.size as f64) as usize;
    Some(Projected {
        screen,
        world: corners.map(|c| c.as_dvec3()),
        pixels: [
            clamp(lo.x),
            clamp(hi.x + 1.0),
            clamp(lo.y),
            clamp(hi.y + 1.0),
        ],
    })
}

impl Projected {
    /// Every pixel whose centre the triangle covers (either facing), with its depth there.
    fn for_each_covered(&self, camera: &Camera, mut f: impl FnMut(usize, f64)) {
        let [a, b, c] = self.screen;
        let area = (b - a).perp_dot(c - a);
        if area == 0.0 {
            return;
        }
        for y in self.pixels[2]..self.pixels[3] {
            for x in self.pixels[0]..self.pixels[1] {
                let p = DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
                let w = [
                    (c - b).perp_dot(p - b),
                    (a - c).perp_dot(p - c),
                    (b - a).perp_dot(p - a),
                ];
                if w.iter().all(|&w| w * area >= 0.0) {
                    f(y * camera.size + x, camera.depth_at(p, &self.world));
                }
            }
        }
    }

    /// Every pixel whose centre is within [`EDGE_PIXELS`] of an edge.
    fn for_each_near_edge(&self, size: usize, mut f: impl FnMut(usize)) {
        let s = self.screen;
        for y in self.pixels[2]..self.pixels[3] {
            for x in self.pixels[0]..self.pixels[1] {
                let p = DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
                let near = (0..3).any(|i| segment_distance(p, s[i], s[(i + 1) % 3]) < EDGE_PIXELS);
                if near {
                    f(y * size + x);
                }
            }
        }
    }
}

fn segment_distance(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let ab = b - a;
    let t = if ab.length_squared() > 0.0 {
        ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + ab * t).distance(p)
}

/// What one view compared: pixels where the painter and the depth buffer could be told
/// apart, and those where they disagreed.
#[derive(Clone, Copy, Debug, Default)]
pub struct Comparison {
    /// Covered pixels away from edges and depth ties.
    pub compared: usize,
    /// Of those, pixels where a triangle of another id lies behind the nearest: those an
    /// order can get wrong.
    pub overlapped: usize,
    /// Of those, pixels whose painted id is not the nearest triangle's.
    pub wrong: usize,
}

/// Paints `triangles` (corners and id) in the order of `order` without a depth buffer, and
/// compares with the depth-buffered image of the same triangles.
pub fn compare(camera: &Camera, triangles: &[([Vec3A; 3], u32)], order: &[u32]) -> Comparison {
    const EMPTY: u32 = u32::MAX;
    let pixels = camera.size * camera.size;
    let projected: Vec<Option<Projected>> = triangles
        .iter()
        .map(|(c, _)| project(camera, c, EDGE_PIXELS + 1.0))
        .collect();
    let mut painted = vec![EMPTY; pixels];
    for &i in order {
        if let Some(p) = &projected[i as usize] {
            p.for_each_covered(camera, |px, _| painted[px] = triangles[i as usize].1);
        }
    }
    // The nearest surface and the nearest one of another id, for the tie test.
    let mut nearest = vec![(f64::INFINITY, EMPTY); pixels];
    let mut runner_up = vec![(f64::INFINITY, EMPTY); pixels];
    let mut near_edge = vec![false; pixels];
    for (i, p) in projected.iter().enumerate() {
        let Some(p) = p else { continue };
        let id = triangles[i].1;
        p.for_each_covered(camera, |px, depth| {
            let (best, second) = (&mut nearest[px], &mut runner_up[px]);
            if id == best.1 {
                best.0 = best.0.min(depth);
            } else if depth < best.0 {
                *second = *best;
                *best = (depth, id);
            } else if id == second.1 {
                second.0 = second.0.min(depth);
            } else if depth < second.0 {
                *second = (depth, id);
            }
        });
        p.for_each_near_edge(camera.size, |px| near_edge[px] = true);
    }
    let mut result = Comparison::default();
    for px in 0..pixels {
        let (best, second) = (nearest[px], runner_up[px]);
        let tie = second.0 - best.0 <= DEPTH_TIE * best.0.abs();
        if best.1 == EMPTY || near_edge[px] || tie {
            continue;
        }
        result.compared += 1;
        if second.1 != EMPTY {
            result.overlapped += 1;
        }
        if painted[px] != best.1 {
            result.wrong += 1;
        }
    }
    result
}
