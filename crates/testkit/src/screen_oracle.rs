//! The screen-space half of the selection oracles (the core's frustum tests and the plugin's
//! rectangle selections): a polygon clipped in homogeneous coordinates, then tested against
//! a screen rectangle, all in f64.

use glam::{DVec2, DVec4};

/// Sutherland-Hodgman: the part of a convex polygon (homogeneous points) where `inside >= 0`.
pub fn clip_polygon(points: &[DVec4], inside: impl Fn(DVec4) -> f64) -> Vec<DVec4> {
    let mut out = Vec::new();
    for i in 0..points.len() {
        let (a, b) = (points[i], points[(i + 1) % points.len()]);
        let (da, db) = (inside(a), inside(b));
        if da >= 0.0 {
            out.push(a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            out.push(a + (b - a) * (da / (da - db)));
        }
    }
    out
}

/// Whether a convex polygon (possibly degenerate: a segment, a point) meets the closed
/// rectangle `[lo, hi]` (possibly degenerate), by separating axes: the rectangle's two and
/// the polygon's edge normals.
pub fn polygon_meets_rect(polygon: &[DVec2], lo: DVec2, hi: DVec2) -> bool {
    if polygon.is_empty() {
        return false;
    }
    let (min, max) = polygon
        .iter()
        .fold((DVec2::INFINITY, DVec2::NEG_INFINITY), |(a, b), &p| {
            (a.min(p), b.max(p))
        });
    if max.cmplt(lo).any() || min.cmpgt(hi).any() {
        return false;
    }
    let rect = [lo, DVec2::new(hi.x, lo.y), hi, DVec2::new(lo.x, hi.y)];
    for i in 0..polygon.len() {
        let e = polygon[(i + 1) % polygon.len()] - polygon[i];
        let axis = e.perp();
        if axis == DVec2::ZERO {
            continue;
        }
        let span = |pts: &mut dyn Iterator<Item = DVec2>| {
            pts.map(|p| p.dot(axis))
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                    (a.min(x), b.max(x))
                })
        };
        let (p0, p1) = span(&mut polygon.iter().copied());
        let (r0, r1) = span(&mut rect.iter().copied());
        if p1 < r0 || r1 < p0 {
            return false;
        }
    }
    true
}
