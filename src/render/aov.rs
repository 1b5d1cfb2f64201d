//! Auxiliary outputs (AOVs) for every integrator: what the camera sees first, averaged over
//! the pixel with the same filter as the image: albedo (the reflectance of the first surface),
//! its shading normal (facing the camera) and depth (distance along the ray). Pixels that see
//! the background get zero.

use super::{thread_pool, Tile};
use crate::bsdf::Bsdf;
use crate::image::filter::Filter;
use crate::image::Image;
use crate::integrators::{Context, RayStats};
use crate::math::sobol::Sampler;
use crate::math::Rgb;
use crate::Result;
use rayon::prelude::*;

/// Samples per pixel for the auxiliary outputs.
pub const AOV_SAMPLES: u32 = 16;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Aov {
    Albedo,
    Normal,
    Depth,
}

impl Aov {
    pub const ALL: [Aov; 3] = [Aov::Albedo, Aov::Normal, Aov::Depth];

    pub fn name(&self) -> &'static str {
        match self {
            Aov::Albedo => "albedo",
            Aov::Normal => "normal",
            Aov::Depth => "depth",
        }
    }
}

/// Renders the albedo, normal and depth images (in that order).
pub fn render_aovs(
    ctx: &Context,
    width: u32,
    height: u32,
    filter: Filter,
    seed: u64,
    threads: Option<usize>,
) -> Result<[Image; 3]> {
    let whole = Tile {
        x0: 0,
        y0: 0,
        x1: width,
        y1: height,
    };
    render_aovs_region(ctx, width, height, &whole, filter, seed, threads)
}

/// The pixels of `region` of the images [`render_aovs`] renders (a render job's part of the
/// image, crate::farm): each pixel's samples depend only on the pixel.
pub fn render_aovs_region(
    ctx: &Context,
    width: u32,
    height: u32,
    region: &Tile,
    filter: Filter,
    seed: u64,
    threads: Option<usize>,
) -> Result<[Image; 3]> {
    let mut camera = ctx.scene.camera.clone();
    camera.width = width;
    camera.height = height;
    let basis = camera.basis();
    let pool = thread_pool(threads)?;
    let tiles = super::tiles_in(region);
    let results: Vec<Vec<[Rgb; 3]>> = pool.install(|| {
        tiles
            .par_iter()
            .map(|t| {
                let mut out = Vec::new();
                let mut stats = RayStats::default();
                for y in t.y0..t.y1 {
                    for x in t.x0..t.x1 {
                        let mut acc = [Rgb::ZERO; 3];
                        for i in 0..AOV_SAMPLES {
                            // A stream of its own, apart from the image's samples.
                            let mut s = Sampler::new(seed ^ 0xa0f, &[x as u64, y as u64], i);
                            let o = filter.sample(s.next_2d());
                            let ray = basis.ray(x as f32 + 0.5 + o.x, y as f32 + 0.5 + o.y);
                            if let Some(sp) = ctx.intersect(&ray, &mut stats) {
                                let m = &ctx.scene.materials[sp.material];
                                let bsdf = Bsdf::new(m, &sp, -ray.dir);
                                let mut n = sp.ns;
                                if n.dot(ray.dir) > 0.0 {
                                    n = -n;
                                }
                                acc[0] += bsdf.albedo();
                                acc[1] += n;
                                acc[2] += Rgb::splat(sp.t * ray.dir.length());
                            }
                        }
                        out.push(acc.map(|a| a / AOV_SAMPLES as f32));
                    }
                }
                out
            })
            .collect()
    });
    let mut images = [0; 3].map(|_| Image::new(region.x1 - region.x0, region.y1 - region.y0));
    for (t, px) in tiles.iter().zip(results) {
        let w = t.x1 - t.x0;
        for (i, v) in px.into_iter().enumerate() {
            let (x, y) = (t.x0 + i as u32 % w, t.y0 + i as u32 / w);
            for (img, c) in images.iter_mut().zip(v) {
                img.set(x - region.x0, y - region.y0, c);
            }
        }
    }
    Ok(images)
}
