//! The light passes of a Monte Carlo image (`crate::transport::light_passes`): the job's
//! camera samples taken again, each recording what its value is made of, and averaged over
//! each pixel as the image averages them (the same filter, the same reconstruction, the same
//! clamp, the same dropped samples), so that the passes recompose the image:
//! (DiffDir + DiffInd)·DiffCol + (GlossDir + GlossInd)·GlossCol + (TransDir + TransInd)·
//! TransCol + Emit + Env, and the light groups sum to the image less Emit and Env.

use super::film::{for_each_reached, weighted_value};
use super::{tiles, tiles_in, Tile, MERGE_WINDOW};
use crate::control::Control;
use crate::error::{Error, Result};
use crate::image::filter::{FilterWeights, Reconstruction};
use crate::image::Image;
use crate::math::Rgb;
use crate::transport::camera_sample::{camera_sample, view_basis, PixelJitter};
use crate::transport::driver::drive;
use crate::transport::light_passes::{PassSample, LOBE_PASSES};
use crate::transport::{Context, MonteCarlo, ProgressiveOptions, RayStats};

/// Bytes per pixel and pass the accumulation holds (a sum in f64), and per pixel (the
/// filter's weights).
pub(crate) const BYTES_PER_PASS: u64 = 24;
const BYTES_PER_PIXEL: u64 = 8;

/// The light passes of `region` of the image `options` describe (all `options.spp`
/// samples, no time limit nor adaptive sampling), with `groups` light groups: images in the
/// order of [`LOBE_PASSES`] (Dir and Ind divided by their colour), then the groups. `None`
/// if cancelled; [`Error::Invalid`] if the integrator has no light passes.
pub(crate) fn render_light_passes(
    ctx: &Context,
    integrator: &dyn MonteCarlo,
    options: &ProgressiveOptions,
    region: &Tile,
    groups: usize,
    control: &Control,
) -> Result<Option<Vec<Image>>> {
    let count = LOBE_PASSES.len() + groups;
    control.budget.check(
        &format!("{count} light passes"),
        region.pixels() * (count as u64 * BYTES_PER_PASS + BYTES_PER_PIXEL),
    )?;
    let camera = view_basis(ctx.scene, options);
    let jitter = PixelJitter::new(options.filter, options.reconstruction);
    let moving = ctx.scene.moves();
    let splatting = jitter.splatting();
    let tiles: Vec<Tile> = match splatting {
        None => tiles_in(region),
        Some(s) => {
            let whole = Tile::whole(options.view.width, options.view.height);
            let reaching = region.grown(s.reach, &whole);
            tiles(options.view.width, options.view.height)
                .iter()
                .filter_map(|t| t.intersection(&reaching))
                .collect()
        }
    };
    let mut film = Sums::try_over(*region, count)?;
    let spp = options.spp;
    let clamp = options.max_component_value;
    let phase = control.phase(
        "light passes",
        Some(region.pixels() * spp as u64),
        "samples",
    );
    let mut unsupported = false;
    let driven = drive(
        &tiles,
        options.view.threads,
        MERGE_WINDOW,
        &control.cancel,
        |t| {
            let mut part = match splatting {
                Some(s) => Sums::new(t.grown(s.reach, region), count),
                None => Sums {
                    rect: *t,
                    count,
                    sums: Vec::with_capacity(t.pixels() as usize * count),
                    weights: Vec::new(),
                },
            };
            let mut stats = RayStats::default();
            let mut pass = PassSample::new(groups);
            let mut sums = vec![[0.0f64; 3]; count];
            for y in t.y0..t.y1 {
                for x in t.x0..t.x1 {
                    sums.fill([0.0; 3]);
                    for i in 0..spp {
                        let (mut sampler, ray, at) =
                            camera_sample(&camera, options.view.seed, &jitter, moving, (x, y), i);
                        pass.clear();
                        let l = integrator.sample_passes(
                            ctx,
                            &camera,
                            &ray,
                            &mut sampler,
                            &mut stats,
                            &mut pass,
                        )?;
                        let valid = l.is_finite() && pass.values.iter().all(|v| v.is_finite());
                        if valid {
                            // The image's clamp scales the whole sample: every light pass
                            // with it.
                            if let Some(m) = clamp.filter(|m| l.max_element() > *m) {
                                let scale = m / l.max_element();
                                for (k, v) in pass.values.iter_mut().enumerate() {
                                    if PassSample::is_light(k) {
                                        *v *= scale;
                                    }
                                }
                            }
                        }
                        match splatting {
                            Some(s) => part.add(&s.weights, at, valid.then_some(&pass.values)),
                            None if valid => {
                                for (sum, v) in sums.iter_mut().zip(&pass.values) {
                                    sum[0] += v.x as f64;
                                    sum[1] += v.y as f64;
                                    sum[2] += v.z as f64;
                                }
                            }
                            None => {}
                        }
                    }
                    if splatting.is_none() {
                        part.sums.extend_from_slice(&sums);
                    }
                }
            }
            Some(part)
        },
        |i, part| {
            let Some(part) = part else {
                unsupported = true;
                return;
            };
            film.absorb(&part);
            let t = &tiles[i];
            let inside = t.intersection(region).map_or(0, |r| r.pixels());
            phase.advance(spp as u64 * inside);
        },
    );
    phase.end("");
    if unsupported {
        return Err(Error::Invalid(
            "this technique has no light passes (the path tracer on surfaces has)".into(),
        ));
    }
    if driven.cancelled {
        return Ok(None);
    }
    let mean = |k: usize, p: usize| match options.reconstruction {
        Reconstruction::Splat => {
            weighted_value(film.sums[p * count + k], film.weights[p], [0.0; 3], 0.0)
        }
        Reconstruction::Importance => {
            let s = film.sums[p * count + k];
            let n = spp.max(1) as f64;
            Rgb::new((s[0] / n) as f32, (s[1] / n) as f32, (s[2] / n) as f32)
        }
    };
    let mut images = Vec::with_capacity(count);
    for _ in 0..count {
        images.push(Image::try_new(region.width(), region.height())?);
    }
    for p in 0..region.pixels() as usize {
        let values: Vec<Rgb> = (0..count).map(|k| mean(k, p)).collect();
        for (k, v) in values.iter().enumerate() {
            images[k].pixels[p] = *v;
        }
        for kind in 0..3 {
            let (dir, ind, col) = (values[3 * kind], values[3 * kind + 1], values[3 * kind + 2]);
            let (d, i, c) = divided(dir, ind, col);
            images[3 * kind].pixels[p] = d;
            images[3 * kind + 1].pixels[p] = i;
            images[3 * kind + 2].pixels[p] = c;
        }
    }
    Ok(Some(images))
}

/// Direct and indirect light of one kind of lobe divided by its colour, channel by channel,
/// and the colour; where the colour is zero and the light is not (a coat's reflection over
/// a black base), the colour is 1 and the light stays as it is, so that (direct +
/// indirect)·colour is always the light.
fn divided(dir: Rgb, ind: Rgb, col: Rgb) -> (Rgb, Rgb, Rgb) {
    let one = |d: f32, i: f32, c: f32| {
        if c > 0.0 {
            (d / c, i / c, c)
        } else if d != 0.0 || i != 0.0 {
            (d, i, 1.0)
        } else {
            (0.0, 0.0, c)
        }
    };
    let (x, y, z) = (
        one(dir.x, ind.x, col.x),
        one(dir.y, ind.y, col.y),
        one(dir.z, ind.z, col.z),
    );
    (
        Rgb::new(x.0, y.0, z.0),
        Rgb::new(x.1, y.1, z.1),
        Rgb::new(x.2, y.2, z.2),
    )
}

/// Samples splatted into the pixels of `rect`, `count` values each: per pixel (row-major)
/// the weighted sums of its values, one after the other, and one sum of weights; samples
/// counted in their own pixel have no weights.
struct Sums {
    rect: Tile,
    count: usize,
    sums: Vec<[f64; 3]>,
    weights: Vec<f64>,
}

impl Sums {
    fn new(rect: Tile, count: usize) -> Sums {
        let pixels = rect.pixels() as usize;
        Sums {
            rect,
            count,
            sums: vec![[0.0; 3]; pixels * count],
            weights: vec![0.0; pixels],
        }
    }

    /// [`Sums::new`], or [`Error::OutOfMemory`] if it cannot be allocated.
    fn try_over(rect: Tile, count: usize) -> Result<Sums> {
        let pixels = rect.pixels() as usize;
        let what = || {
            format!(
                "the light passes of a {}x{} image",
                rect.width(),
                rect.height()
            )
        };
        Ok(Sums {
            rect,
            count,
            sums: crate::platform::try_vec(pixels * count, [0.0; 3], what)?,
            weights: crate::platform::try_vec(pixels, 0.0, what)?,
        })
    }

    /// Adds a sample at raster position `at` with `values` to every pixel of `rect` whose
    /// centre its filter reaches, as the film's footprints add the image's samples; a
    /// dropped sample (no values) adds its weights alone.
    fn add(&mut self, filter: &FilterWeights, at: (f32, f32), values: Option<&[Rgb]>) {
        let count = self.count;
        for_each_reached(filter, at, &self.rect, |i, wt| {
            self.weights[i] += wt;
            if let Some(values) = values {
                let px = &mut self.sums[i * count..(i + 1) * count];
                for (sum, v) in px.iter_mut().zip(values) {
                    sum[0] += wt * v.x as f64;
                    sum[1] += wt * v.y as f64;
                    sum[2] += wt * v.z as f64;
                }
            }
        });
    }

    /// Adds `part`'s sums (and weights, if it has them) to the pixels they cover, which
    /// must lie within `self.rect`.
    fn absorb(&mut self, part: &Sums) {
        let w = part.rect.width();
        for k in 0..part.rect.pixels() as usize {
            let (x, y) = (part.rect.x0 + k as u32 % w, part.rect.y0 + k as u32 / w);
            let i = ((y - self.rect.y0) * self.rect.width() + x - self.rect.x0) as usize;
            let (from, to) = (k * self.count, i * self.count);
            for j in 0..self.count {
                let (a, b) = (&mut self.sums[to + j], part.sums[from + j]);
                a[0] += b[0];
                a[1] += b[1];
                a[2] += b[2];
            }
            if let Some(weight) = part.weights.get(k) {
                self.weights[i] += weight;
            }
        }
    }
}
