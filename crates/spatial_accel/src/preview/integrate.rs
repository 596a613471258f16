//! The radiometric views: direct light with shadows, ambient occlusion, and diffuse path
//! tracing.

use super::light::offset_ray_origin;
use super::rng::{Sampler, cosine_hemisphere};
use super::scene::{PreviewScene, SurfaceHit};
use super::tracer::PreviewTracer;
use crate::Ray;
use glam::{Vec3, Vec3A};

/// A ray leaving `hit` in `direction`, from an origin moved off the surface on the side
/// the ray leaves by (see [`offset_ray_origin`]).
fn leave(hit: &SurfaceHit, direction: Vec3A) -> Ray {
    let side = if direction.dot(hit.geometric_normal) >= 0.0 {
        hit.geometric_normal
    } else {
        -hit.geometric_normal
    };
    Ray::new(offset_ray_origin(hit.position, side), direction)
}

/// Light reflected towards the viewer at `hit` from every light, each tested for a shadow
/// by one any-hit ray: Lambertian, `albedo / pi` times the irradiance.
pub(super) fn direct_light<S: PreviewScene + ?Sized>(
    tracer: &PreviewTracer,
    scene: &S,
    hit: &SurfaceHit,
    albedo: Vec3,
) -> Vec3 {
    let mut sum = Vec3::ZERO;
    for light in &tracer.lights {
        let Some(sample) = light.illuminate(hit.position, hit.shading_normal) else {
            continue;
        };
        // A light behind the triangle's plane but in front of its interpolated normal would
        // light the surface through itself, and its shadow ray would start inside: skipped.
        if sample.to_light.dot(hit.geometric_normal) <= 0.0 {
            continue;
        }
        let shadow = leave(hit, sample.to_light);
        // The point light's own position is not an occluder, so the full distance is kept.
        if !scene.occluded(&shadow, sample.distance) {
            sum += sample.irradiance;
        }
    }
    albedo * sum * core::f32::consts::FRAC_1_PI
}

/// The shaded view at the first hit of `ray`: emission, the ambient term (the sky's
/// radiance times the albedo, what a uniform sky gives an unoccluded Lambertian surface),
/// and direct light with hard shadows. A miss sees the background.
pub(super) fn shaded<S: PreviewScene + ?Sized>(
    tracer: &PreviewTracer,
    scene: &S,
    ray: &Ray,
) -> Vec3 {
    let Some(hit) = scene.closest(ray) else {
        return tracer.settings.background;
    };
    let material = tracer.material(hit.material);
    let albedo = material.albedo(hit.uv);
    material.emissive + albedo * tracer.settings.ambient + direct_light(tracer, scene, &hit, albedo)
}

/// The ambient-occlusion view: the fraction of `samples` cosine-distributed rays from the
/// first hit that travel `radius` without meeting anything, as grey; the background on a
/// miss.
pub(super) fn ambient_occlusion<S: PreviewScene + ?Sized>(
    tracer: &PreviewTracer,
    scene: &S,
    ray: &Ray,
    samples: u32,
    radius: f32,
    sampler: &mut Sampler,
) -> Vec3 {
    let Some(hit) = scene.closest(ray) else {
        return tracer.settings.background;
    };
    let samples = samples.max(1);
    let open = (0..samples)
        .filter(|_| {
            let d = cosine_hemisphere(hit.shading_normal, sampler.next_vec2());
            // Around the interpolated normal a direction can point into the surface; it is
            // blocked by the surface itself.
            d.dot(hit.geometric_normal) > 0.0 && !scene.occluded(&leave(&hit, d), radius)
        })
        .count();
    Vec3::splat(open as f32 / samples as f32)
}

/// The path-traced view: a diffuse random walk from the first hit, `max_bounces` bounces
/// at most, adding at every vertex its emission and its direct light (next-event
/// estimation: the lights are points, which a bounce can never hit), and the ambient
/// colour as the sky's radiance where a bounce escapes.
///
/// Unbiased for the bounces it follows (a cosine-distributed bounce of a Lambertian
/// surface carries the albedo as its weight, see [`cosine_hemisphere`]); Russian roulette
/// is left out, since short walks are what a preview wants.
pub(super) fn path_traced<S: PreviewScene + ?Sized>(
    tracer: &PreviewTracer,
    scene: &S,
    ray: &Ray,
    max_bounces: u32,
    sampler: &mut Sampler,
) -> Vec3 {
    let Some(mut hit) = scene.closest(ray) else {
        return tracer.settings.background;
    };
    let mut radiance = Vec3::ZERO;
    let mut throughput = Vec3::ONE;
    for bounce in 0..=max_bounces {
        let material = tracer.material(hit.material);
        let albedo = material.albedo(hit.uv);
        radiance += throughput * (material.emissive + direct_light(tracer, scene, &hit, albedo));
        if bounce == max_bounces {
            break;
        }
        throughput *= albedo;
        if throughput.max_element() <= 0.0 {
            break;
        }
        let d = cosine_hemisphere(hit.shading_normal, sampler.next_vec2());
        if d.dot(hit.geometric_normal) <= 0.0 {
            // Into the surface: absorbed (see `ambient_occlusion`).
            break;
        }
        match scene.closest(&leave(&hit, d)) {
            Some(next) => hit = next,
            None => {
                radiance += throughput * tracer.settings.ambient;
                break;
            }
        }
    }
    radiance
}
