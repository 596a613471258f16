//! Shared helpers for the acceptance tests (and, later, the tree tests): a deterministic RNG,
//! closed test meshes, and double-precision reference versions of the geometric tests.
//!
//! Every test binary includes this module with `mod support;` and uses a different subset of it.
#![allow(dead_code)]

use glam::{DVec3, Vec3A};
use std::collections::HashMap;
use std::path::PathBuf;

/// SplitMix64 (Steele, Lea, Flood 2014): tiny, fast, and the same stream on every platform, so a
/// failing case is reproduced by its seed alone. Owning it also keeps the tests free of a
/// dependency whose stream could change with a version bump.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed ^ 0x5851_f42d_4c95_7f2d)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)` with all 53 bits used.
    pub fn f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in `[0, 1)`.
    pub fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }

    pub fn range_f64(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.f64()
    }

    /// Uniform in `0..n`.
    pub fn below(&mut self, n: usize) -> usize {
        ((u128::from(self.next_u64()) * n as u128) >> 64) as usize
    }

    pub fn bool(&mut self) -> bool {
        self.next_u64() >> 63 == 1
    }

    pub fn pick<T: Copy>(&mut self, items: &[T]) -> T {
        items[self.below(items.len())]
    }

    /// Log-uniform magnitude in `[lo, hi]` (both positive): spreads values over many binades,
    /// where uniform sampling would almost never produce a small one.
    pub fn log_range(&mut self, lo: f32, hi: f32) -> f32 {
        (lo.ln() + (hi.ln() - lo.ln()) * self.f32()).exp()
    }

    /// `log_range` with a random sign.
    pub fn signed_log(&mut self, lo: f32, hi: f32) -> f32 {
        let m = self.log_range(lo, hi);
        if self.bool() { m } else { -m }
    }

    pub fn vec3a(&mut self, lo: f32, hi: f32) -> Vec3A {
        Vec3A::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }

    /// Uniform on the unit sphere (computed in f64, rounded once).
    pub fn unit_vec3a(&mut self) -> Vec3A {
        let z = self.range_f64(-1.0, 1.0);
        let phi = self.range_f64(0.0, std::f64::consts::TAU);
        let s = (1.0 - z * z).sqrt();
        DVec3::new(s * phi.cos(), s * phi.sin(), z).as_vec3a()
    }
}

/// `f32` vectors widened to `f64` exactly.
pub fn d(v: Vec3A) -> DVec3 {
    v.as_dvec3()
}

/// A triangle mesh given by shared vertices and counter-clockwise (outward) index triples.
#[derive(Clone, Debug)]
pub struct Mesh {
    pub vertices: Vec<Vec3A>,
    pub indices: Vec<[u32; 3]>,
}

impl Mesh {
    pub fn triangle(&self, i: usize) -> [Vec3A; 3] {
        self.indices[i].map(|k| self.vertices[k as usize])
    }

    pub fn triangles(&self) -> impl Iterator<Item = [Vec3A; 3]> + '_ {
        (0..self.indices.len()).map(|i| self.triangle(i))
    }

    /// The mesh centred on the origin with its longest bounding-box side scaled to `size`
    /// (computed in f64 and rounded once per coordinate).
    pub fn normalized(&self, size: f64) -> Self {
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for &v in &self.vertices {
            lo = lo.min(d(v));
            hi = hi.max(d(v));
        }
        let (c, s) = ((lo + hi) * 0.5, size / (hi - lo).max_element());
        let vertices = self
            .vertices
            .iter()
            .map(|&v| ((d(v) - c) * s).as_vec3a())
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

    /// Every undirected edge once.
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
    /// "every ray from inside hits" a property the triangle test owes us.
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
            let (a, b, c) = (d(a) - p, d(b) - p, d(c) - p);
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
            .map(|[a, b, c]| (closest_point_on_triangle(p, d(a), d(b), d(c)) - p).length())
            .fold(f64::INFINITY, f64::min)
    }
}

/// Ericson, "Real-Time Collision Detection", 5.1.5, in f64.
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

/// The unit icosahedron subdivided `levels` times and pushed onto the unit sphere. Midpoints are
/// shared through an edge cache, so the result is welded and closed (20 * 4^levels triangles).
pub fn icosphere(levels: u32) -> Mesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut verts: Vec<DVec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|&v| DVec3::from(v).normalize())
    .collect();
    let mut faces: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut cache: HashMap<(u32, u32), u32> = HashMap::new();
        let mut mid = |a: u32, b: u32, verts: &mut Vec<DVec3>| {
            *cache.entry((a.min(b), a.max(b))).or_insert_with(|| {
                verts.push(((verts[a as usize] + verts[b as usize]) * 0.5).normalize());
                verts.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(faces.len() * 4);
        for [a, b, c] in faces {
            let (ab, bc, ca) = (
                mid(a, b, &mut verts),
                mid(b, c, &mut verts),
                mid(c, a, &mut verts),
            );
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        faces = next;
    }
    Mesh {
        vertices: verts.iter().map(|v| v.as_vec3a()).collect(),
        indices: faces,
    }
}

/// The cube `[-1, 1]^3` as 8 shared corners and 12 outward triangles.
pub fn cube() -> Mesh {
    let vertices = (0..8)
        .map(|i| {
            let s = |bit: u32| if i & bit == 0 { -1.0 } else { 1.0 };
            Vec3A::new(s(1), s(2), s(4))
        })
        .collect();
    // Corner index = x + 2y + 4z; each face as two counter-clockwise triangles seen from outside.
    let quads = [
        [0, 4, 6, 2], // -x
        [1, 3, 7, 5], // +x
        [0, 1, 5, 4], // -y
        [2, 6, 7, 3], // +y
        [0, 2, 3, 1], // -z
        [4, 5, 7, 6], // +z
    ];
    let indices = quads
        .iter()
        .flat_map(|&[a, b, c, e]| [[a, b, c], [a, c, e]])
        .collect();
    Mesh { vertices, indices }
}

/// Where the Stanford bunny lives: `$ACCEL_BUNNY_OBJ`, else `shared/models/bunny.obj` beside the
/// repository (CI clones `shared/` next to it) or beside the worktree's parent.
pub fn bunny_path() -> Result<PathBuf, String> {
    if let Ok(p) = std::env::var("ACCEL_BUNNY_OBJ") {
        let p = PathBuf::from(p);
        return if p.is_file() {
            Ok(p)
        } else {
            Err(format!("ACCEL_BUNNY_OBJ={} is not a file", p.display()))
        };
    }
    let manifest = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let candidates = [
        manifest.join("../../../shared/models/bunny.obj"),
        manifest.join("../../shared/models/bunny.obj"),
    ];
    candidates
        .iter()
        .find(|p| p.is_file())
        .cloned()
        .ok_or_else(|| {
            format!(
                "bunny.obj not found: set ACCEL_BUNNY_OBJ or place it at one of {candidates:?}; \
             this test must not pass without its mesh"
            )
        })
}

/// A minimal OBJ reader: `v x y z` and polygonal `f` lines (fan-triangulated; `i/t/n` and
/// negative indices accepted); everything else is ignored.
pub fn load_obj(path: &std::path::Path) -> Result<Mesh, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let (mut vertices, mut indices) = (Vec::new(), Vec::new());
    for (n, line) in text.lines().enumerate() {
        let err = |what: &str| format!("{}:{}: {what}: {line}", path.display(), n + 1);
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let c: Vec<f32> = it
                    .take(3)
                    .map(|s| s.parse().map_err(|_| err("bad coordinate")))
                    .collect::<Result<_, _>>()?;
                if c.len() != 3 {
                    return Err(err("vertex needs 3 coordinates"));
                }
                vertices.push(Vec3A::new(c[0], c[1], c[2]));
            }
            Some("f") => {
                let ids: Vec<u32> = it
                    .map(|s| {
                        let i: i64 = s
                            .split('/')
                            .next()
                            .unwrap_or("")
                            .parse()
                            .map_err(|_| err("bad index"))?;
                        let k = if i < 0 {
                            vertices.len() as i64 + i
                        } else {
                            i - 1
                        };
                        u32::try_from(k).map_err(|_| err("index out of range"))
                    })
                    .collect::<Result<_, _>>()?;
                if ids.len() < 3 || ids.iter().any(|&k| k as usize >= vertices.len()) {
                    return Err(err("bad face"));
                }
                indices.extend((1..ids.len() - 1).map(|i| [ids[0], ids[i], ids[i + 1]]));
            }
            _ => {}
        }
    }
    Ok(Mesh { vertices, indices })
}

/// The bunny, or a panic that says where it was looked for.
pub fn bunny() -> Mesh {
    let path = bunny_path().unwrap_or_else(|e| panic!("{e}"));
    load_obj(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// Reference slab test in f64 on the exact (widened) inputs: the parameter interval of the ray
/// inside the closed box, clamped to `[t_min, t_max]`, or `None`. A zero direction component
/// (either sign) constrains nothing when the origin lies in that slab and rejects otherwise.
pub fn slab_f64(
    origin: DVec3,
    dir: DVec3,
    min: DVec3,
    max: DVec3,
    t_min: f64,
    t_max: f64,
) -> Option<(f64, f64)> {
    let (mut near, mut far) = (t_min, t_max);
    for k in 0..3 {
        if dir[k] == 0.0 {
            if origin[k] < min[k] || origin[k] > max[k] {
                return None;
            }
        } else {
            let t1 = (min[k] - origin[k]) / dir[k];
            let t2 = (max[k] - origin[k]) / dir[k];
            near = near.max(t1.min(t2));
            far = far.min(t1.max(t2));
        }
    }
    (near <= far).then_some((near, far))
}

/// What the f64 reference knows about a ray and a sphere.
#[derive(Clone, Copy, Debug)]
pub struct SphereRef {
    /// Distance from the centre to the ray's line, over the radius: < 1 crosses, > 1 misses,
    /// near 1 is the tangency band where f32 is allowed to disagree.
    pub closeness: f64,
    /// Both roots of the line, ascending, when it crosses.
    pub roots: Option<(f64, f64)>,
}

/// Reference ray/sphere in f64, with the same stable formulation (closest point of the line,
/// `c / q` for the near root) so that f64 itself is not the weak link.
pub fn sphere_f64(origin: DVec3, dir: DVec3, center: DVec3, radius: f64) -> SphereRef {
    let f = origin - center;
    let a = dir.length_squared();
    let b = -f.dot(dir);
    let l = f + dir * (b / a);
    let closeness = l.length() / radius;
    let disc = a * (radius * radius - l.length_squared());
    let roots = (disc >= 0.0).then(|| {
        let q = b + disc.sqrt().copysign(b);
        let c = f.length_squared() - radius * radius;
        if q == 0.0 {
            (0.0, 0.0)
        } else {
            let (r0, r1) = (c / q, q / a);
            (r0.min(r1), r0.max(r1))
        }
    });
    SphereRef { closeness, roots }
}

/// Relative difference, safe at zero: `|a - b| / max(|a|, |b|, floor)`.
pub fn rel_diff(a: f64, b: f64, floor: f64) -> f64 {
    (a - b).abs() / a.abs().max(b.abs()).max(floor)
}
