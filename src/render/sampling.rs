//! How pixels are sampled: Whitted's adaptive corner subdivision, or regular supersampling.

use super::small_objects::{Disc, SmallObjects};
use super::Tile;
use crate::math::{Rgb, Rng};
use crate::scene::camera::CameraBasis;
use crate::transport::{Context, Integrator, PixelSampling, RayStats, Sample};
use rustc_hash::FxHashMap;

/// Mixed into the seed of the stream a sample's shutter time comes from.
const SHUTTER_STREAM: u64 = 0x5417_7e27_11ae_0001;

struct TileRenderer<'a> {
    ctx: &'a Context<'a>,
    integrator: &'a dyn Integrator,
    camera: &'a CameraBasis,
    seed: u64,
    stats: RayStats,
    samples: u64,
    invalid: u64,
}

impl TileRenderer<'_> {
    /// One image sample at raster position (x, y), whose random stream is keyed by `key`.
    fn sample(&mut self, x: f32, y: f32, key: &[u64]) -> Sample {
        let mut rng = Rng::for_key(self.seed, key);
        self.samples += 1;
        let ray = if self.camera.has_lens() {
            let u = crate::math::Vec2::new(rng.uniform(), rng.uniform());
            self.camera.ray_through_lens(x, y, u)
        } else {
            self.camera.ray(x, y)
        };
        // The shutter time from a stream of its own, so `rng` (and still scenes' images)
        // stay as they were.
        let ray = ray.at_time(Rng::for_key(self.seed ^ SHUTTER_STREAM, key).uniform());
        let mut sample = self
            .integrator
            .radiance(self.ctx, &ray, &mut rng, &mut self.stats);
        if !sample.radiance.is_finite() {
            // A numerical failure must not poison the pixel: dropped and counted.
            sample.radiance = Rgb::ZERO;
            self.invalid += 1;
        }
        sample
    }
}

/// What [`render_tile`] produced.
pub(super) struct TileOutput {
    /// The tile's pixels, row-major.
    pub pixels: Vec<Rgb>,
    pub rays: RayStats,
    /// Image samples taken.
    pub samples: u64,
    /// Samples dropped for a NaN or infinite value.
    pub invalid: u64,
}

/// Renders one tile; returns its pixels (row-major), rays traced and samples taken. The
/// adaptive sampler looks for the objects of `small` (made for this camera) between corners.
pub(super) fn render_tile(
    ctx: &Context,
    integrator: &dyn Integrator,
    camera: &CameraBasis,
    sampling: &PixelSampling,
    seed: u64,
    small: &SmallObjects,
    tile: &Tile,
) -> TileOutput {
    let mut r = TileRenderer {
        ctx,
        integrator,
        camera,
        seed,
        stats: RayStats::default(),
        samples: 0,
        invalid: 0,
    };
    let mut pixels = Vec::with_capacity(((tile.x1 - tile.x0) * (tile.y1 - tile.y0)) as usize);
    match *sampling {
        PixelSampling::Uniform { n } => {
            let inv = 1.0 / n as f32;
            for y in tile.y0..tile.y1 {
                for x in tile.x0..tile.x1 {
                    let mut sum = Rgb::ZERO;
                    for j in 0..n {
                        for i in 0..n {
                            let px = x as f32 + (i as f32 + 0.5) * inv;
                            let py = y as f32 + (j as f32 + 0.5) * inv;
                            let key = [x as u64, y as u64, (j * n + i) as u64];
                            sum += r.sample(px, py, &key).radiance;
                        }
                    }
                    pixels.push(sum * (inv * inv));
                }
            }
        }
        PixelSampling::Adaptive {
            threshold,
            max_depth,
        } => {
            let mut adaptive = Adaptive {
                renderer: r,
                threshold,
                max_depth,
                scale: 1 << max_depth,
                cache: FxHashMap::default(),
                small: small.in_rect(
                    tile.x0 as f32,
                    tile.y0 as f32,
                    tile.x1 as f32,
                    tile.y1 as f32,
                ),
            };
            for y in tile.y0..tile.y1 {
                for x in tile.x0..tile.x1 {
                    let s = adaptive.scale;
                    pixels.push(adaptive.square(x * s, y * s, s, 0));
                }
            }
            r = adaptive.renderer;
        }
    }
    TileOutput {
        pixels,
        rays: r.stats,
        samples: r.samples,
        invalid: r.invalid,
    }
}

/// Whitted's adaptive sampler. Sample points lie on a lattice `scale` = 2^max_depth times
/// finer than the pixels; a point's value depends only on its lattice position, so points
/// shared by neighbouring squares are traced once per tile, and results do not depend on
/// how the image is tiled.
struct Adaptive<'a> {
    renderer: TileRenderer<'a>,
    threshold: f32,
    max_depth: u32,
    scale: u32,
    cache: FxHashMap<(u32, u32), Sample>,
    /// The small objects whose discs overlap the tile.
    small: Vec<Disc>,
}

impl Adaptive<'_> {
    fn point(&mut self, lx: u32, ly: u32) -> Sample {
        if let Some(s) = self.cache.get(&(lx, ly)) {
            return *s;
        }
        let inv = 1.0 / self.scale as f32;
        let s = self.renderer.sample(
            lx as f32 * inv,
            ly as f32 * inv,
            &[lx as u64, ly as u64, u64::MAX],
        );
        self.cache.insert((lx, ly), s);
        s
    }

    /// The mean value over the square with lower corner (lx, ly) and side `size` (lattice units).
    fn square(&mut self, lx: u32, ly: u32, size: u32, level: u32) -> Rgb {
        let corners = [
            self.point(lx, ly),
            self.point(lx + size, ly),
            self.point(lx, ly + size),
            self.point(lx + size, ly + size),
        ];
        if level < self.max_depth
            && (self.differ(&corners) || self.hides_small_object(lx, ly, size, &corners))
        {
            let h = size / 2;
            return 0.25
                * (self.square(lx, ly, h, level + 1)
                    + self.square(lx + h, ly, h, level + 1)
                    + self.square(lx, ly + h, h, level + 1)
                    + self.square(lx + h, ly + h, h, level + 1));
        }
        corners.iter().map(|c| c.radiance).sum::<Rgb>() * 0.25
    }

    /// Whether a small object's disc overlaps the square though no corner sees the object:
    /// it may lie between the corners (Whitted's enlarged bounding spheres).
    fn hides_small_object(&self, lx: u32, ly: u32, size: u32, corners: &[Sample; 4]) -> bool {
        let inv = 1.0 / self.scale as f32;
        let (x0, y0, side) = (lx as f32 * inv, ly as f32 * inv, size as f32 * inv);
        self.small
            .iter()
            .any(|d| d.overlaps(x0, y0, side) && corners.iter().all(|c| c.object != d.object))
    }

    /// Whether the corner values are not "nearly equal": they see different objects, or some
    /// channel differs by more than the threshold after compressing highlights (x/(1+x)), so
    /// that contrast is judged as it will be displayed. Comparing first-hit objects finds
    /// silhouettes; objects smaller than a pixel are found by [`Self::hides_small_object`].
    fn differ(&self, corners: &[Sample; 4]) -> bool {
        let first = corners[0].object;
        if corners.iter().any(|c| c.object != first) {
            return true;
        }
        let compressed = corners.map(|c| c.radiance / (Rgb::ONE + c.radiance.max(Rgb::ZERO)));
        let lo = compressed
            .iter()
            .fold(Rgb::splat(f32::INFINITY), |a, c| a.min(*c));
        let hi = compressed
            .iter()
            .fold(Rgb::splat(f32::NEG_INFINITY), |a, c| a.max(*c));
        (hi - lo).max_element() > self.threshold
    }
}
