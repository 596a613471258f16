//! The character's mesh: six vertical tubes (torso, neck and head, two arms, two legs) and two
//! box feet, skinned by blending neighbouring joints along each tube.

use super::{
    CHEST, Detail, FOREARM_L, FOREARM_R, HEAD, HIPS, JOINT_COUNT, NECK, SHIN_L, SHIN_R, SHOULDER_L,
    SHOULDER_R, SPINE, SkinnedCharacter, THIGH_L, THIGH_R, UPPER_ARM_L, UPPER_ARM_R, globals,
    rest_pose,
};
use glam::Vec3;
use std::f32::consts::TAU;

/// Half the height over which a tube's weights pass from one joint to the next: wide enough
/// that a bent knee or elbow stays round, narrow enough that two handovers overlap only at
/// the shoulder (where vertices then have three joints: chest, shoulder and upper arm).
const BLEND: f32 = 0.05;

/// The length of tube section that gets [`Detail::rings`] rings.
const RING_LENGTH: f32 = 0.3;

/// How far the cone closing a tube end sticks out, relative to the tube's radius there.
const CAP: f32 = 0.4;

/// A vertical tube: an elliptic cross-section swept along `y`, closed by a cone at each end.
struct Tube {
    /// Where the axis is.
    x: f32,
    z: f32,
    /// Section ends from bottom to top; each section gets its own share of rings.
    sections: Vec<f32>,
    /// The joints from bottom to top, each with the height above which the next one takes
    /// over (the last one's is infinite).
    joints: Vec<(usize, f32)>,
    /// The half-width along X at increasing heights, linearly interpolated.
    radius: Vec<(f32, f32)>,
    /// The half-depth along Z relative to the half-width.
    depth: f32,
    /// Whether the chest breathes (the morph target moves this tube).
    breathes: bool,
}

/// The character's tubes: torso, neck and head, then each side's arm and leg.
fn tubes() -> Vec<Tube> {
    let mut tubes = vec![
        Tube {
            x: 0.0,
            z: 0.0,
            sections: vec![0.86, 1.07, 1.32, 1.60],
            joints: vec![(HIPS, 1.07), (SPINE, 1.32), (CHEST, f32::INFINITY)],
            radius: vec![
                (0.86, 0.15),
                (0.95, 0.16),
                (1.07, 0.14),
                (1.32, 0.18),
                (1.47, 0.19),
                (1.54, 0.20),
                (1.60, 0.09),
            ],
            depth: 0.62,
            breathes: true,
        },
        Tube {
            x: 0.0,
            z: 0.0,
            sections: vec![1.54, 1.68, 1.92],
            joints: vec![(CHEST, 1.57), (NECK, 1.69), (HEAD, f32::INFINITY)],
            radius: vec![
                (1.54, 0.05),
                (1.66, 0.05),
                (1.69, 0.075),
                (1.73, 0.095),
                (1.79, 0.105),
                (1.85, 0.098),
                (1.89, 0.08),
                (1.92, 0.045),
            ],
            depth: 1.1,
            breathes: false,
        },
    ];
    for (side, shoulder, upper, fore, thigh, shin) in [
        (1.0, SHOULDER_L, UPPER_ARM_L, FOREARM_L, THIGH_L, SHIN_L),
        (-1.0, SHOULDER_R, UPPER_ARM_R, FOREARM_R, THIGH_R, SHIN_R),
    ] {
        tubes.push(Tube {
            x: side * 0.23,
            z: 0.0,
            sections: vec![0.90, 1.24, 1.52, 1.58],
            joints: vec![
                (fore, 1.24),
                (upper, 1.52),
                (shoulder, 1.56),
                (CHEST, f32::INFINITY),
            ],
            radius: vec![(0.90, 0.035), (1.24, 0.045), (1.52, 0.055), (1.58, 0.05)],
            depth: 1.0,
            breathes: false,
        });
        tubes.push(Tube {
            x: side * 0.10,
            z: 0.0,
            sections: vec![0.07, 0.49, 0.91, 1.0],
            joints: vec![(shin, 0.49), (thigh, 0.91), (HIPS, f32::INFINITY)],
            radius: vec![(0.07, 0.045), (0.49, 0.06), (0.91, 0.085), (1.0, 0.085)],
            depth: 1.0,
            breathes: false,
        });
    }
    tubes
}

/// The foot boxes: each side's shin and the box's corners.
fn feet() -> [(usize, Vec3, Vec3); 2] {
    [(SHIN_L, 1.0), (SHIN_R, -1.0)].map(|(shin, side)| {
        let x = side * 0.10;
        (
            shin,
            Vec3::new(x - 0.05, 0.0, -0.06),
            Vec3::new(x + 0.05, 0.09, 0.17),
        )
    })
}

/// The number of rings of each of a tube's sections at `detail` (proportional to its length).
fn section_rings(sections: &[f32], detail: Detail) -> Vec<u32> {
    sections
        .windows(2)
        .map(|s| ((detail.rings as f32 * (s[1] - s[0]) / RING_LENGTH).round() as u32).max(1))
        .collect()
}

/// The triangle count of [`character`] at `detail`, without building it.
pub(super) fn triangle_count(detail: Detail) -> usize {
    let around = detail.around.max(3) as usize;
    let tubes: usize = tubes()
        .iter()
        .map(|t| {
            let rings: u32 = section_rings(&t.sections, detail).iter().sum();
            2 * around * rings as usize + 2 * around
        })
        .sum();
    tubes + 12 * feet().len()
}

/// Linear interpolation in a table of `(x, y)` sorted by `x`, clamped at its ends.
fn interpolate(table: &[(f32, f32)], x: f32) -> f32 {
    let i = table.partition_point(|&(tx, _)| tx <= x);
    if i == 0 {
        return table[0].1;
    }
    if i == table.len() {
        return table[i - 1].1;
    }
    let ((x0, y0), (x1, y1)) = (table[i - 1], table[i]);
    y0 + (y1 - y0) * (x - x0) / (x1 - x0)
}

/// 0 below the handover at `d = 0`, 1 above it, passing smoothly over `2 * BLEND`.
fn ramp(d: f32) -> f32 {
    let s = (d / (2.0 * BLEND) + 0.5).clamp(0.0, 1.0);
    s * s * (3.0 - 2.0 * s)
}

/// The joints and weights of a point at height `y` of a tube: joint `k` gets the part of the
/// ramp above its lower handover that the ramp above its upper handover does not take, so
/// the weights sum to 1 by construction; the largest is then recomputed as one minus the
/// others so that rounding leaves the sum as close to 1 as `f32` allows.
fn tube_weights(joints: &[(usize, f32)], y: f32) -> ([u16; 4], [f32; 4]) {
    let mut found: Vec<(usize, f32)> = Vec::with_capacity(4);
    let mut below = 1.0;
    for &(joint, handover) in joints {
        let above = if handover.is_finite() {
            ramp(y - handover)
        } else {
            0.0
        };
        let w = below - above;
        if w > 0.0 {
            found.push((joint, w));
        }
        below = above;
    }
    pack_weights(found)
}

/// Up to four `(joint, weight)` pairs, heaviest first, normalized, as glTF vertex attributes.
fn pack_weights(mut found: Vec<(usize, f32)>) -> ([u16; 4], [f32; 4]) {
    found.sort_by(|a, b| b.1.total_cmp(&a.1));
    found.truncate(4);
    let sum: f32 = found.iter().map(|f| f.1).sum();
    let (mut joints, mut weights) = ([0u16; 4], [0f32; 4]);
    for (k, &(j, w)) in found.iter().enumerate() {
        joints[k] = j as u16;
        weights[k] = w / sum;
    }
    weights[0] = 1.0 - weights[1..].iter().sum::<f32>();
    (joints, weights)
}

/// The mesh being built.
#[derive(Default)]
struct Builder {
    positions: Vec<Vec3>,
    indices: Vec<u32>,
    joints: Vec<[u16; 4]>,
    weights: Vec<[f32; 4]>,
    breathe: Vec<Vec3>,
}

impl Builder {
    fn vertex(&mut self, p: Vec3, skin: ([u16; 4], [f32; 4]), breathe: Vec3) -> u32 {
        self.positions.push(p);
        self.joints.push(skin.0);
        self.weights.push(skin.1);
        self.breathe.push(breathe);
        self.positions.len() as u32 - 1
    }

    /// Rings from bottom to top, `around` vertices each, then a cone at each end; every
    /// triangle counter-clockwise seen from outside.
    fn tube(&mut self, tube: &Tube, detail: Detail) {
        let around = detail.around.max(3);
        let mut heights = vec![tube.sections[0]];
        for (s, rings) in tube
            .sections
            .windows(2)
            .zip(section_rings(&tube.sections, detail))
        {
            heights.extend((1..=rings).map(|k| s[0] + (s[1] - s[0]) * k as f32 / rings as f32));
        }
        let first = self.positions.len() as u32;
        for &y in &heights {
            let r = interpolate(&tube.radius, y);
            let skin = tube_weights(&tube.joints, y);
            // The chest swells by up to 3 cm at the front and back, less at the sides.
            let swell = if tube.breathes {
                0.03 * (1.0 - ((y - 1.36) / 0.18).powi(2)).max(0.0).powi(2)
            } else {
                0.0
            };
            for j in 0..around {
                let (sin, cos) = (TAU * j as f32 / around as f32).sin_cos();
                let p = Vec3::new(tube.x + r * cos, y, tube.z + tube.depth * r * sin);
                self.vertex(p, skin, Vec3::new(0.6 * cos, 0.0, sin) * swell);
            }
        }
        let ring = |k: usize, j: u32| first + k as u32 * around + j % around;
        for k in 0..heights.len() - 1 {
            for j in 0..around {
                let (a, b) = (ring(k, j), ring(k, j + 1));
                let (c, d) = (ring(k + 1, j + 1), ring(k + 1, j));
                self.indices.extend([a, d, c, a, c, b]);
            }
        }
        let (bottom, top) = (heights[0], heights[heights.len() - 1]);
        for (y, k, up) in [(bottom, 0, false), (top, heights.len() - 1, true)] {
            let out = CAP * interpolate(&tube.radius, y);
            let apex_y = if up { y + out } else { y - out };
            let apex = self.vertex(
                Vec3::new(tube.x, apex_y, tube.z),
                tube_weights(&tube.joints, apex_y),
                Vec3::ZERO,
            );
            for j in 0..around {
                let (a, b) = (ring(k, j), ring(k, j + 1));
                self.indices
                    .extend(if up { [apex, b, a] } else { [apex, a, b] });
            }
        }
    }

    /// A box with its own four vertices per face (so its normals stay flat), on one joint.
    fn foot(&mut self, joint: usize, min: Vec3, max: Vec3) {
        let (center, half) = ((min + max) * 0.5, (max - min) * 0.5);
        let skin = pack_weights(vec![(joint, 1.0)]);
        for axis in 0..3 {
            let (n, u, v) = (
                Vec3::AXES[axis],
                Vec3::AXES[(axis + 1) % 3],
                Vec3::AXES[(axis + 2) % 3],
            );
            for sign in [1.0, -1.0] {
                let corner = |su: f32, sv: f32| center + (n * sign + u * su + v * sv) * half;
                let mut quad = [
                    corner(-1.0, -1.0),
                    corner(1.0, -1.0),
                    corner(1.0, 1.0),
                    corner(-1.0, 1.0),
                ];
                if sign < 0.0 {
                    quad.reverse();
                }
                let q = quad.map(|p| self.vertex(p, skin, Vec3::ZERO));
                self.indices.extend([q[0], q[1], q[2], q[0], q[2], q[3]]);
            }
        }
    }
}

/// Vertex normals: each the sum of its triangles' area-weighted normals, normalized.
fn smooth_normals(positions: &[Vec3], indices: &[u32]) -> Vec<Vec3> {
    let mut normals = vec![Vec3::ZERO; positions.len()];
    for t in indices.chunks_exact(3) {
        let [a, b, c] = [t[0], t[1], t[2]].map(|i| positions[i as usize]);
        let n = (b - a).cross(c - a);
        for &i in t {
            normals[i as usize] += n;
        }
    }
    normals
        .into_iter()
        .map(|n| n.try_normalize().unwrap_or(Vec3::Y))
        .collect()
}

/// The character at `detail` (see [`Detail::for_triangles`] for a triangle count), in its rest
/// pose. Deterministic: the same detail gives the same data on every run (across platforms,
/// up to the last bit of `sin` and `cos`).
pub fn character(detail: Detail) -> SkinnedCharacter {
    let mut b = Builder::default();
    for tube in tubes() {
        b.tube(&tube, detail);
    }
    for (joint, min, max) in feet() {
        b.foot(joint, min, max);
    }
    let normals = smooth_normals(&b.positions, &b.indices);
    let inverse_bind = globals(&rest_pose()).iter().map(|g| g.inverse()).collect();
    debug_assert_eq!(b.indices.len() / 3, triangle_count(detail));
    debug_assert!(
        b.joints
            .iter()
            .flatten()
            .all(|&j| (j as usize) < JOINT_COUNT)
    );
    SkinnedCharacter {
        detail,
        positions: b.positions,
        normals,
        indices: b.indices,
        joints: b.joints,
        weights: b.weights,
        inverse_bind,
        breathe: b.breathe,
    }
}
