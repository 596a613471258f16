//! Bounding volumes, rays, frusta, triangles and the robust tests between them.

mod aabb;
mod frustum;
mod frustum_lanes;
mod frustum_triangle;
mod ray;
mod ray_aabb;
mod ray_lanes;
mod ray_sphere;
mod selection;
mod sphere;
mod triangle;
mod triangle4;
mod triangle_clip;

pub use aabb::Aabb;
pub use frustum::{Containment, Frustum, Plane};
pub use frustum_lanes::FrustumLanes;
pub use frustum_triangle::TOUCH_TOLERANCE;
pub(crate) use frustum_triangle::touch_band;
pub use ray::Ray;
pub use ray_aabb::SLAB_WIDENING;
pub(crate) use ray_lanes::RayLanes;
pub use selection::SelectionMode;
pub use sphere::Sphere;
pub use triangle::{Backfaces, Triangle, TriangleHit, WatertightRay, intersect_triangle_f64};
pub use triangle_clip::clipped_triangle_bounds;
pub(crate) use triangle_clip::{chopped_triangle_bounds, cut_triangle_part};
pub use triangle4::{Triangle4, Triangle4Hits};
