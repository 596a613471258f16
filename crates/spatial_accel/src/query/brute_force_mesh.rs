//! Every triangle tested in turn: the oracle of [`TriangleQuery`].

use super::TriangleQuery;
use crate::mesh::{MeshError, MeshHit};
use crate::{Aabb, Backfaces, Ray, Triangle, WatertightRay};

/// The triangles of one mesh in a list, each query a loop over all of them with the same
/// watertight test the trees run: the reference the conformance suite compares every
/// [`TriangleQuery`] with.
#[derive(Clone, Debug, Default)]
pub struct BruteForceMesh {
    /// Triangle `i` of the index buffer, or `None` when a corner is not finite.
    triangles: Vec<Option<Triangle>>,
}

impl BruteForceMesh {
    /// The mesh of an indexed triangle list (triangle `i` uses `indices[3i..3i + 3]`).
    pub fn new(vertices: &[glam::Vec3], indices: &[u32]) -> Result<Self, MeshError> {
        Ok(Self {
            triangles: mesh_triangles(vertices, indices)?,
        })
    }

    fn finite(&self) -> impl Iterator<Item = (u32, &Triangle)> {
        self.triangles
            .iter()
            .enumerate()
            .filter_map(|(i, t)| t.as_ref().map(|t| (i as u32, t)))
    }

    /// The finite triangles whose box the ray touches: the only ones a ray can truly hit.
    ///
    /// Why the box first: the trees test a triangle only inside a box that holds it, while
    /// on corners near the float range's ends (subnormal or `f32::MAX`-sized) the watertight
    /// test's rounding can report a hit at a point outside the triangle's own box; the
    /// oracle alone then found it.
    fn reachable<'a>(&'a self, ray: &'a Ray) -> impl Iterator<Item = (u32, &'a Triangle)> + 'a {
        self.finite().filter(|(_, t)| ray.hits_aabb(&t.aabb()))
    }

    /// The hit record of triangle `triangle` (corners `tri`), as every mesh query gives it.
    pub(crate) fn record(triangle: u32, tri: &Triangle, hit: crate::TriangleHit) -> MeshHit {
        let [a, b, c] = tri.vertices;
        MeshHit {
            t: hit.t,
            triangle,
            barycentrics: hit.barycentrics(),
            geometric_normal: (b - a).cross(c - a).normalize_or_zero(),
            front_face: hit.front_face,
        }
    }
}

impl TriangleQuery for BruteForceMesh {
    fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    fn bounds(&self) -> Aabb {
        self.finite()
            .fold(Aabb::EMPTY, |acc, (_, t)| acc.union(&t.aabb()))
    }

    fn cast_ray(&self, ray: &Ray, backfaces: Backfaces) -> Option<MeshHit> {
        // The oracle turns untraceable rays away as the trees do (see `Ray::is_traceable`):
        // a ray written field by field with an infinite direction hit here and not there.
        if !ray.is_traceable() {
            return None;
        }
        let mut wt = WatertightRay::new(ray);
        let mut best = None;
        for (i, tri) in self.reachable(ray) {
            // A tie keeps the lower index, as the trees' walks do for hits in one leaf.
            if let Some(hit) = wt.intersect(tri, backfaces)
                && best.is_none_or(|b: MeshHit| hit.t < b.t)
            {
                wt.set_t_max(hit.t);
                best = Some(Self::record(i, tri, hit));
            }
        }
        best
    }

    fn cast_ray_any(&self, ray: &Ray, backfaces: Backfaces) -> bool {
        if !ray.is_traceable() {
            return false;
        }
        let wt = WatertightRay::new(ray);
        self.reachable(ray)
            .any(|(_, tri)| wt.intersect(tri, backfaces).is_some())
    }

    fn cast_ray_all(&self, ray: &Ray, backfaces: Backfaces, out: &mut Vec<MeshHit>) {
        if !ray.is_traceable() {
            return;
        }
        let wt = WatertightRay::new(ray);
        let start = out.len();
        for (i, tri) in self.reachable(ray) {
            if let Some(hit) = wt.intersect(tri, backfaces) {
                out.push(Self::record(i, tri, hit));
            }
        }
        out[start..].sort_unstable_by(|a, b| a.t.total_cmp(&b.t).then(a.triangle.cmp(&b.triangle)));
    }

    fn for_each_triangle_overlapping<F: FnMut(u32)>(&self, aabb: &Aabb, mut visit: F) {
        for (i, tri) in self.finite() {
            if tri.aabb().intersects_aabb(aabb) {
                visit(i);
            }
        }
    }
}

/// Triangle `i` of an indexed triangle list (`indices[3i..3i + 3]`), or `None` when a corner
/// is not finite: what every structure over one mesh starts from.
pub(crate) fn mesh_triangles(
    vertices: &[glam::Vec3],
    indices: &[u32],
) -> Result<Vec<Option<Triangle>>, MeshError> {
    if !indices.len().is_multiple_of(3) {
        return Err(MeshError::NotATriangleList {
            index_count: indices.len(),
        });
    }
    let corner = |i: u32| {
        vertices
            .get(i as usize)
            .copied()
            .ok_or(MeshError::IndexOutOfRange {
                index: i,
                vertex_count: vertices.len(),
            })
    };
    indices
        .chunks_exact(3)
        .map(|t| {
            let tri = Triangle::new(corner(t[0])?, corner(t[1])?, corner(t[2])?);
            let finite = tri.vertices.iter().all(|v| v.is_finite());
            Ok(finite.then_some(tri))
        })
        .collect()
}
