//! The brute force a game would write with Bevy alone, in `f64`: project every triangle
//! (touching: clipped at the near plane, then tested against the rectangle by separating axes)
//! or every corner of every world box (enclosed, centre), and compare with the rectangle; and the random scenes it judges (`scene`).

pub mod scene;

use accel_testkit::screen_oracle::{clip_polygon, polygon_meets_rect};
use bevy::math::{DAffine3, DMat4, DVec2, DVec3, DVec4};

/// One rectangle of one camera, in `f64`, with the rectangle moved by `grow` (NDC) outwards
/// (inwards when negative, never past zero width) and the near plane by as much: the
/// verdicts under `+eps` and `-eps` bound what rounding may decide.
pub struct Screen {
    pub m: DMat4,
    pub lo: DVec2,
    pub hi: DVec2,
    pub grow: f64,
}

impl Screen {
    /// `None` when the rectangle, clamped to the viewport, is empty.
    pub fn new(clip_from_world: DMat4, a: DVec2, b: DVec2, grow: f64) -> Option<Self> {
        let lo = a.min(b).max(DVec2::NEG_ONE);
        let hi = a.max(b).min(DVec2::ONE);
        if !(lo.cmple(hi).all()) {
            return None;
        }
        let half = (hi - lo) * 0.5;
        let g = DVec2::splat(grow).max(-half);
        Some(Self {
            m: clip_from_world,
            lo: lo - g,
            hi: hi + g,
            grow,
        })
    }

    fn clip(&self, p: DVec3) -> DVec4 {
        self.m * p.extend(1.0)
    }

    /// In front of the near plane (reverse-z: `z <= w`) and projected inside.
    pub fn point(&self, p: DVec3) -> bool {
        let c = self.clip(p);
        if !(c.z <= c.w * (1.0 + self.grow) && c.w > 0.0) {
            return false;
        }
        let ndc = c.truncate().truncate() / c.w;
        ndc.cmpge(self.lo).all() && ndc.cmple(self.hi).all()
    }

    /// Some part of the triangle in front of the near plane projects into the rectangle.
    pub fn triangle(&self, corners: [DVec3; 3]) -> bool {
        let grow = self.grow;
        let clipped = clip_polygon(&corners.map(|p| self.clip(p)), |c| c.w * (1.0 + grow) - c.z);
        // Behind the eye nothing is drawn.
        let clipped = clip_polygon(&clipped, |c| c.w - 1e-9);
        let projected: Vec<DVec2> = clipped
            .iter()
            .map(|c| c.truncate().truncate() / c.w)
            .collect();
        polygon_meets_rect(&projected, self.lo, self.hi)
    }
}

/// The corners of a box given by centre and half extents, through an affine map.
pub fn box_corners(affine: &DAffine3, center: DVec3, half: DVec3) -> [DVec3; 8] {
    core::array::from_fn(|i| {
        let s = DVec3::new(
            if i & 1 == 0 { -1.0 } else { 1.0 },
            if i & 2 == 0 { -1.0 } else { 1.0 },
            if i & 4 == 0 { -1.0 } else { 1.0 },
        );
        affine.transform_point3(center + half * s)
    })
}

/// The twelve triangles of a box's faces, from its corners as [`box_corners`] numbers them.
pub fn box_triangles(c: &[DVec3; 8]) -> Vec<[DVec3; 3]> {
    const FACES: [[usize; 4]; 6] = [
        [0, 2, 6, 4],
        [1, 3, 7, 5],
        [0, 1, 5, 4],
        [2, 3, 7, 6],
        [0, 1, 3, 2],
        [4, 5, 7, 6],
    ];
    FACES
        .iter()
        .flat_map(|&[a, b, cc, d]| [[c[a], c[b], c[cc]], [c[a], c[cc], c[d]]])
        .collect()
}
