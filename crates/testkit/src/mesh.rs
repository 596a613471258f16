//! An indexed triangle mesh, with the conversions the trees take and the `f64` checks the
//! watertightness tests need.

use glam::{DVec3, Vec3, Vec3A};
use spatial_accel::Triangle;
use std::collections::HashMap;

/// A triangle mesh given by shared vertices and counter-clockwise (outward) index triples.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// The vertex positions.
    pub vertices: Vec<Vec3A>,
    /// Each triangle's three vertex indices, counter-clockwise seen from outside.
    pub indices: Vec<[u32; 3]>,
}

impl Mesh {
    /// The corners of triangle `i`.
    pub fn triangle(&self, i: usize) -> [Vec3A; 3] {
        self.indices[i].map(|k| self.vertices[k as usize])
    }

    /// The corners of every triangle, in index order.
    pub fn triangles(&self) -> impl Iterator<Item = [Vec3A; 3]> + '_ {
        (0..self.indices.len()).map(|i| self.triangle(i))
    }

    /// Every triangle as an `spatial_accel` [`Triangle`], in index order.
    pub fn to_triangles(&self) -> Vec<Triangle> {
        self.triangles()
            .map(|[a, b, c]| Triangle::new(a, b, c))
            .collect()
    }

    /// The vertices as `Vec3`s, the form `MeshBvh::new` takes.
    pub fn positions(&self) -> Vec<Vec3> {
        self.vertices.iter().map(|&v| v.into()).collect()
    }

    /// The indices as one flat list, three per triangle, the form `MeshBvh::new` takes.
    pub fn flat_indices(&self) -> Vec<u32> {
        self.indices.iter().flatten().copied().collect()
    }

    /// The mesh centred on the origin with its longest bounding-box side scaled to `size`
    /// (computed in f64 and rounded once per coordinate).
    pub fn normalized(&self, size: f64) -> Self {
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for &v in &self.vertices {
            lo = lo.min(v.as_dvec3());
            hi = hi.max(v.as_dvec3());
        }
        let (c, s) = ((lo + hi) * 0.5, size / (hi - lo).max_element());
        let vertices = self
            .vertices
            .iter()
            .map(|&v| ((v.as_dvec3() - c) * s).as_vec3a())
            .collect();
        Self {
            vertices,
            indices: self.indices.clone(),
        }
    }

    /// The mesh moved by `offset`, added in f32 as an application far from the origin would, so
    /// the vertices take on the rounding of their new magnitude.
    pub fn translated(&self, offset: Vec3A) -> Self {
        Self {
            vertices: self.vertices.iter().map(|&v| v + offset).collect(),
            indices: self.indices.clone(),
        }
    }

    /// Every undirected edge once, as `[low, high]` vertex indices, sorted.
    pub fn edges(&self) -> Vec<[u32; 2]> {
        let mut edges: Vec<[u32; 2]> = self
            .indices
            .iter()
            .flat_map(|t| [[t[0], t[1]], [t[1], t[2]], [t[2], t[0]]])
            .map(|[a, b]| [a.min(b), a.max(b)])
            .collect();
        edges.sort_unstable();
        edges.dedup();
        edges
    }

    /// Checks that the mesh is a closed, consistently oriented 2-manifold (as far as edges
    /// tell): every directed edge occurs exactly once and so does its reverse. Only then is
    /// "every ray from inside hits" a property a triangle test owes us.
    pub fn check_closed(&self) -> Result<(), String> {
        let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
        for t in &self.indices {
            if t[0] == t[1] || t[1] == t[2] || t[2] == t[0] {
                return Err(format!("degenerate index triple {t:?}"));
            }
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                *directed.entry((a, b)).or_default() += 1;
            }
        }
        for (&(a, b), &n) in &directed {
            if n != 1 || directed.get(&(b, a)) != Some(&1) {
                return Err(format!(
                    "edge {a}-{b} is used {n} times, its reverse not exactly once"
                ));
            }
        }
        Ok(())
    }

    /// The generalised winding number of `p` (Jacobson et al. 2013): the solid angles of all
    /// triangles (Van Oosterom and Strackee 1983) summed over 4 pi. About 1 strictly inside a
    /// closed outward-oriented mesh, 0 outside, and it needs no assumption about the shape.
    pub fn winding_number(&self, p: DVec3) -> f64 {
        let mut sum = 0.0;
        for [a, b, c] in self.triangles() {
            let (a, b, c) = (a.as_dvec3() - p, b.as_dvec3() - p, c.as_dvec3() - p);
            let (la, lb, lc) = (a.length(), b.length(), c.length());
            let num = a.dot(b.cross(c));
            let den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
            sum += 2.0 * num.atan2(den);
        }
        sum / (4.0 * std::f64::consts::PI)
    }

    /// Distance from `p` to the nearest point of the surface, in f64.
    pub fn distance_to_surface(&self, p: DVec3) -> f64 {
        self.triangles()
            .map(|[a, b, c]| {
                let q = closest_point_on_triangle(p, a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
                (q - p).length()
            })
            .fold(f64::INFINITY, f64::min)
    }
}

/// The point of triangle `abc` nearest to `p`, in f64 (Ericson, "Real-Time Collision
/// Detection", 5.1.5).
pub fn closest_point_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}
