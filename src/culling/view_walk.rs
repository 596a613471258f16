//! A view's last tree walk, kept for the next frame.

use bevy::math::Vec4;
use bevy::prelude::Entity;

/// What a view's walk of the trees found, with the frustum it walked.
///
/// Why keep it: the walk and the slot ordering after it are about a third of the tree path
/// (1.3 + 1.4 ms of about 9 ms at 1M entities, 5% in view), and when neither the view's
/// frustum nor the trees changed since the last frame they would find the same entities in
/// the same order. Only the walk is kept: every entity is still decided each frame (its
/// visibility, layers and range can change without the trees changing), as Bevy requires
/// `ViewVisibility` to be set again every frame.
#[derive(Default)]
pub(crate) struct ViewWalk {
    /// The planes walked, compared bit for bit.
    planes: Option<[Vec4; 6]>,
    /// Entities a tree proved inside, in slot order.
    pub(crate) inside: Vec<Entity>,
    /// Entities whose leaf crosses a plane, in slot order.
    pub(crate) crossing: Vec<Entity>,
}

impl ViewWalk {
    /// Whether this walk was of exactly these planes (and has not been forgotten).
    pub(crate) fn walked(&self, planes: &[Vec4; 6]) -> bool {
        self.planes.is_some_and(|p| {
            p.iter()
                .zip(planes)
                .all(|(a, b)| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits))
        })
    }

    /// Starts a new walk of `planes`: forgets what the last one found.
    pub(crate) fn restart(&mut self, planes: [Vec4; 6]) {
        self.planes = Some(planes);
        self.inside.clear();
        self.crossing.clear();
    }

    /// Forgets the walk (the trees changed).
    pub(crate) fn forget(&mut self) {
        self.planes = None;
    }
}

#[cfg(test)]
mod tests {
    use super::ViewWalk;
    use bevy::math::Vec4;

    #[test]
    fn matches_only_the_same_planes_until_forgotten() {
        let planes = [Vec4::new(1.0, 0.0, 0.0, 2.0); 6];
        let mut walk = ViewWalk::default();
        assert!(!walk.walked(&planes));
        walk.restart(planes);
        assert!(walk.walked(&planes));
        let mut moved = planes;
        moved[3].w = f32::from_bits(2.0f32.to_bits() + 1);
        assert!(!walk.walked(&moved));
        // -0.0 == 0.0, but a frustum built from other numbers is another walk.
        let mut signed = planes;
        signed[0].y = -0.0;
        assert!(!walk.walked(&signed));
        walk.forget();
        assert!(!walk.walked(&planes));
    }
}
