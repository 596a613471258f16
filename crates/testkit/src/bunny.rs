//! The Stanford bunny, and the small Wavefront OBJ reader that reads it.
//!
//! The mesh is part of the repository (`assets/bunny.obj`, 3,674 triangles, from the npm
//! package `bunny@1.0.1`; data: Stanford 3D Scanning Repository), so a fresh clone needs
//! nothing beside it. The environment variable `ACCEL_BUNNY_OBJ` names another OBJ file to
//! use instead.

use crate::Mesh;
use glam::Vec3A;
use std::path::{Path, PathBuf};

/// The environment variable that names an OBJ file to use in place of the bunny.
pub const BUNNY_ENV: &str = "ACCEL_BUNNY_OBJ";

/// Where the bunny is: `$ACCEL_BUNNY_OBJ` if set, else the repository's `assets/bunny.obj`.
pub fn bunny_path() -> PathBuf {
    match std::env::var_os(BUNNY_ENV) {
        Some(p) => PathBuf::from(p),
        None => asset_path(),
    }
}

/// The repository's copy of the bunny.
fn asset_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/bunny.obj")
}

/// A minimal OBJ reader: `v x y z` and polygonal `f` lines (fan-triangulated; `i/t/n` and
/// negative indices accepted); everything else is ignored.
pub fn load_obj(path: &Path) -> Result<Mesh, String> {
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
    if indices.is_empty() {
        return Err(format!("{}: no triangles", path.display()));
    }
    Ok(Mesh { vertices, indices })
}

/// The bunny (as read, not moved or scaled), or a panic that says where it was looked for: a
/// test or benchmark on a stand-in mesh would mislead.
pub fn bunny() -> Mesh {
    let path = bunny_path();
    load_obj(&path).unwrap_or_else(|e| {
        panic!("the bunny could not be read ({e}); it is assets/bunny.obj, or ${BUNNY_ENV}")
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_bunny_is_in_the_repository() {
        let bunny = super::load_obj(&super::asset_path()).unwrap();
        assert_eq!((bunny.vertices.len(), bunny.indices.len()), (1839, 3674));
    }
}
