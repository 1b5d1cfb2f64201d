//! Where a pixel's camera samples fall and the ray each one traces: shared by the progressive
//! passes and everything that must see exactly their camera rays (the irradiance cache's
//! overture).

use crate::image::filter::{Filter, FilterSampler, FilterWeights, Reconstruction};
use crate::math::sobol::Sampler;
use crate::math::Ray;
use crate::scene::camera::CameraBasis;
use crate::scene::Scene;
use crate::transport::ProgressiveOptions;

/// Where a pixel's camera samples fall: offsets drawn from the filter (each sample counts
/// in its own pixel), or spread uniformly over the pixel, to be splatted.
pub(crate) enum PixelJitter {
    Filter(FilterSampler),
    Uniform(Splatting),
}

impl PixelJitter {
    pub fn new(filter: Filter, reconstruction: Reconstruction) -> PixelJitter {
        match reconstruction {
            Reconstruction::Importance => PixelJitter::Filter(FilterSampler::new(filter)),
            Reconstruction::Splat => PixelJitter::Uniform(Splatting::new(filter)),
        }
    }

    /// How samples are splatted, if they are.
    pub(crate) fn splatting(&self) -> Option<&Splatting> {
        match self {
            PixelJitter::Filter(_) => None,
            PixelJitter::Uniform(s) => Some(s),
        }
    }
}

/// How splatted samples reach pixels: the filter's weights and how many pixels past its
/// own a sample can reach.
pub(crate) struct Splatting {
    pub(crate) weights: FilterWeights,
    pub(crate) reach: u32,
}

impl Splatting {
    fn new(filter: Filter) -> Splatting {
        Splatting {
            weights: FilterWeights::new(filter),
            // A sample anywhere in its pixel reaches centres within the radius.
            reach: (filter.radius() + 0.5).ceil() as u32,
        }
    }
}

/// Camera sample `i` of pixel (x, y): its ray through the pixel, at a position drawn by
/// `jitter`, its sampler with that position's numbers drawn, and the position. Anything
/// that must see exactly the render's camera rays (the irradiance cache's overture) calls
/// this. The ray gets a shutter time only if the scene is `moving`: a still scene looks the
/// same at any time, and drawing the time costs as much as a bounce's sample values.
pub(crate) fn camera_sample(
    camera: &CameraBasis,
    seed: u64,
    jitter: &PixelJitter,
    moving: bool,
    (x, y): (u32, u32),
    i: u32,
) -> (Sampler, Ray, (f32, f32)) {
    let mut sampler = Sampler::new(seed, &[x as u64, y as u64], i);
    let u = sampler.next_2d();
    let (fx, fy) = match jitter {
        PixelJitter::Filter(filter) => {
            let offset = filter.sample(u);
            (x as f32 + 0.5 + offset.x, y as f32 + 0.5 + offset.y)
        }
        PixelJitter::Uniform(_) => (x as f32 + u.x, y as f32 + u.y),
    };
    // Only a thin lens draws a lens sample, so pinhole images keep their sample streams.
    let ray = if camera.has_lens() {
        camera.ray_through_lens(fx, fy, sampler.next_2d())
    } else {
        camera.ray(fx, fy)
    };
    // From a stream of its own: drawing it leaves the other dimensions as they were.
    let ray = if moving {
        ray.at_time(sampler.shutter_time())
    } else {
        ray
    };
    (sampler, ray, (fx, fy))
}

/// The scene's camera at the render's size, with light-path splats accepted as far outside
/// the film as the filter reaches.
pub(crate) fn view_basis(scene: &Scene, options: &ProgressiveOptions) -> CameraBasis {
    let mut camera = scene.camera.clone();
    camera.width = options.view.width;
    camera.height = options.view.height;
    let mut basis = camera.basis();
    basis.margin = options.filter.radius();
    basis
}
