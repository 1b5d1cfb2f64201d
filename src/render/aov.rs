//! Auxiliary outputs (AOVs) for every integrator: what the camera sees first, averaged over
//! the pixel with the same filter as the image: albedo (the reflectance of the first surface),
//! its shading normal (facing the camera), depth (distance along the ray) and position (the
//! world-space point). Pixels that see the background get zero. The object and material
//! indices are those of the surface seen through the pixel's centre (1-based; 0 is the
//! background), not averaged.

use super::{place, Tile, MERGE_WINDOW};
use crate::control::Control;
use crate::image::filter::Filter;
use crate::image::Image;
use crate::math::sobol::Sampler;
use crate::math::Rgb;
use crate::transport::driver::drive;
use crate::transport::{Context, RayStats};

/// Samples per pixel for the auxiliary outputs.
pub const AOV_SAMPLES: u32 = 16;

/// One auxiliary image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Aov {
    /// The reflectance of the first surface (RGB).
    Albedo,
    /// Its shading normal, facing the camera (world-space XYZ).
    Normal,
    /// Its distance along the camera ray (one value).
    Depth,
    /// The world-space point seen (XYZ).
    Position,
    /// 1 + the index of the object seen through the pixel's centre: a shape of the scene
    /// (in the order the scene lists them), then the instances; 0 for the background.
    ObjectId,
    /// 1 + the index of the material seen through the pixel's centre; 0 for the background.
    MaterialId,
}

impl Aov {
    /// The auxiliary images written as files of their own (`STEM.NAME.exr`).
    pub const ALL: [Aov; 3] = [Aov::Albedo, Aov::Normal, Aov::Depth];

    /// Every auxiliary image, in the order of
    /// [`Renderer::render_aov_layers`](crate::Renderer::render_aov_layers).
    pub const LAYERS: [Aov; 6] = [
        Aov::Albedo,
        Aov::Normal,
        Aov::Depth,
        Aov::Position,
        Aov::ObjectId,
        Aov::MaterialId,
    ];

    /// Its name in file names and as an EXR layer.
    pub fn name(&self) -> &'static str {
        match self {
            Aov::Albedo => "albedo",
            Aov::Normal => "normal",
            Aov::Depth => "depth",
            Aov::Position => "P",
            Aov::ObjectId => "IndexOB",
            Aov::MaterialId => "IndexMA",
        }
    }

    /// Its channels in an EXR layer (after `NAME.`): the image's first channels (R, G, B
    /// of the image in memory) in this order.
    pub fn channels(&self) -> &'static [&'static str] {
        match self {
            Aov::Albedo => &["R", "G", "B"],
            Aov::Normal | Aov::Position => &["X", "Y", "Z"],
            Aov::Depth => &["Z"],
            Aov::ObjectId | Aov::MaterialId => &["X"],
        }
    }
}

/// The images of [`Aov::LAYERS`] (in that order) of `region` of a `width` × `height` view
/// (the whole image or a render job's part of it): each pixel's samples depend only on the
/// pixel. Single-valued images hold their value in every channel. `None` if cancelled.
pub(crate) fn render_aovs(
    ctx: &Context,
    (width, height): (u32, u32),
    region: &Tile,
    (filter, seed, threads): (Filter, u64, Option<usize>),
    control: &Control,
) -> crate::error::Result<Option<[Image; 6]>> {
    let mut camera = ctx.scene.camera.clone();
    camera.width = width;
    camera.height = height;
    let basis = camera.basis();
    let tiles = super::tiles_in(region);
    let mut images = [
        Image::try_new(region.width(), region.height())?,
        Image::try_new(region.width(), region.height())?,
        Image::try_new(region.width(), region.height())?,
        Image::try_new(region.width(), region.height())?,
        Image::try_new(region.width(), region.height())?,
        Image::try_new(region.width(), region.height())?,
    ];
    let shapes = ctx.scene.shapes.len();
    let phase = control.phase("auxiliary images", Some(region.pixels()), "pixels");
    let driven = drive(
        &tiles,
        threads,
        MERGE_WINDOW,
        &control.cancel,
        |t| {
            let mut out = Vec::new();
            let mut stats = RayStats::default();
            for y in t.y0..t.y1 {
                for x in t.x0..t.x1 {
                    let mut acc = [Rgb::ZERO; 6];
                    for i in 0..AOV_SAMPLES {
                        // A stream of its own, apart from the image's samples.
                        let mut s = Sampler::new(seed ^ 0xa0f, &[x as u64, y as u64], i);
                        let o = filter.sample(s.next_2d());
                        let (fx, fy) = (x as f32 + 0.5 + o.x, y as f32 + 0.5 + o.y);
                        let ray = if basis.has_lens() {
                            basis.ray_through_lens(fx, fy, s.next_2d())
                        } else {
                            basis.ray(fx, fy)
                        }
                        .at_time(s.shutter_time());
                        if let Some(sp) = ctx.intersect(&ray, &mut stats) {
                            let m = &ctx.scene.materials[sp.material];
                            let bsdf = m.bsdf(&sp, -ray.dir);
                            let mut n = sp.ns;
                            if n.dot(ray.dir) > 0.0 {
                                n = -n;
                            }
                            acc[0] += bsdf.albedo();
                            acc[1] += n;
                            acc[2] += Rgb::splat(sp.t * ray.dir.length());
                            acc[3] += sp.p;
                        }
                    }
                    let mut px = acc.map(|a| a / AOV_SAMPLES as f32);
                    // The indices of what the pixel's centre sees, at the shutter's opening.
                    let centre = basis.ray(x as f32 + 0.5, y as f32 + 0.5);
                    if let Some(sp) = ctx.intersect(&centre, &mut stats) {
                        let object = match sp.instance {
                            Some(i) => shapes + i as usize,
                            None => sp.shape,
                        };
                        px[4] = Rgb::splat((object + 1) as f32);
                        px[5] = Rgb::splat((sp.material + 1) as f32);
                    }
                    out.push(px);
                }
            }
            out
        },
        |i, px| {
            let t = &tiles[i];
            for (k, img) in images.iter_mut().enumerate() {
                place(img, (region.x0, region.y0), t, px.iter().map(|v| v[k]));
            }
            phase.advance(t.pixels());
        },
    );
    phase.end("");
    Ok((!driven.cancelled).then_some(images))
}
