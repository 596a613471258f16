//! The preview camera: a world ray through any point of any pixel, from the view's inverse
//! view-projection.

use crate::Ray;
use glam::{Mat4, Vec2, Vec3, Vec3A, Vec4};

/// A camera given as the engine keeps it: `world_from_clip` (the inverse of the view's
/// clip-from-world matrix) and the eye position.
///
/// Clip depth follows Bevy's reverse-Z convention: depth 1 is the near plane and depth 0
/// the far one (at infinity for Bevy's infinite perspective). A ray starts on the near plane,
/// so geometry the rasteriser clips away in front of it is not hit either, and runs through
/// the point of clip depth 1/2 (twice the near distance for a perspective view, halfway
/// through the box for an orthographic one). Both points are finite for both projections,
/// which is why they are used rather than the far plane, and why one formula serves both.
///
/// A matrix that is not finite or not invertible gives rays that miss everything (see
/// [`Ray`]): a broken camera draws the background, it does not panic.
///
/// ```
/// use spatial_accel::preview::PreviewCamera;
/// use glam::{Mat4, Vec2, Vec3};
/// let eye = Vec3::new(0.0, 0.0, 5.0);
/// let view = Mat4::look_at_rh(eye, Vec3::ZERO, Vec3::Y);
/// let clip_from_view = Mat4::perspective_infinite_reverse_rh(1.0, 16.0 / 9.0, 0.1);
/// let camera = PreviewCamera::new((clip_from_view * view).inverse(), eye);
/// // The centre of the image looks down -z, from the near plane.
/// let ray = camera.pixel_ray(Vec2::new(8.0, 4.5), 16, 9);
/// assert!((ray.direction - glam::Vec3A::NEG_Z).length() < 1e-5);
/// assert!((ray.origin.z - 4.9).abs() < 1e-4);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreviewCamera {
    /// Clip space to world space: `(clip_from_view * view_from_world).inverse()`.
    pub world_from_clip: Mat4,
    /// The eye, in world space; depths in the depth view are distances from it.
    pub position: Vec3,
}

impl PreviewCamera {
    /// A camera from its inverse view-projection and its position.
    pub fn new(world_from_clip: Mat4, position: Vec3) -> Self {
        Self {
            world_from_clip,
            position,
        }
    }

    /// The point at normalised device coordinates `ndc` and clip depth `depth`, in world
    /// space.
    fn unproject(&self, ndc: Vec2, depth: f32) -> Vec3A {
        let p = self.world_from_clip * Vec4::new(ndc.x, ndc.y, depth, 1.0);
        Vec3A::from(p.truncate() / p.w)
    }

    /// The ray through normalised device coordinates `ndc` (`x` right, `y` up, each in
    /// `[-1, 1]` across the view), with a unit direction so that `t` is a distance.
    pub fn ray_through(&self, ndc: Vec2) -> Ray {
        let near = self.unproject(ndc, 1.0);
        let mid = self.unproject(ndc, 0.5);
        // A NaN or zero direction (a broken matrix) makes a degenerate ray, which misses.
        Ray::new(near, (mid - near).normalize_or_zero())
    }

    /// The ray through the point `pixel` of an image `width` x `height` pixels, in pixel
    /// units from the top-left corner (pixel `(x, y)` covers `[x, x + 1) x [y, y + 1)`, so
    /// its centre is `(x + 0.5, y + 0.5)`), rows running down as in the image buffer.
    pub fn pixel_ray(&self, pixel: Vec2, width: u32, height: u32) -> Ray {
        let size = Vec2::new(width.max(1) as f32, height.max(1) as f32);
        let ndc = Vec2::new(2.0 * pixel.x / size.x - 1.0, 1.0 - 2.0 * pixel.y / size.y);
        self.ray_through(ndc)
    }
}
