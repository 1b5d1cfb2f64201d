//! An iteration's light subpaths (one per pixel, or one in 32 pixels in a scene
//! without smooth surfaces or media, unless set otherwise), each from a light chosen by
//! power and continued by BSDF sampling for importance transport. Every vertex where the
//! BSDF is not purely specular is kept (for connections and merges) and connected to the
//! camera (the light tracing technique, splatted).
//!
//! Determinism: subpath `i` of an iteration draws from the stream of (seed, iteration, i)
//! alone; subpaths are traced in fixed chunks, in parallel, and their vertices and splats
//! are concatenated in chunk order, so the iteration is the same bits for any thread count.

use super::lights::of_emission;
use super::media::{advance, leave, link, Around, End, Leaving, Scatter, Spectral, Step};
use super::mis::{abs_cos, Subpath, Weights};
use crate::bsdf::{LambertianFrom, Transport};
use crate::integrators::camera_connection::camera_pdf_dir;
use crate::integrators::camera_connection::{lens_sample, project_to_camera};
use crate::integrators::light::emission_start;
use crate::integrators::volumetric::{hero_channel, Throughput};
use crate::integrators::volumetric_light::{arrive_from_infinity, medium_at};
use crate::math::sobol::Sampler;
use crate::math::spawn::Spot;
use crate::math::{luminance, Rgb, Vec3};
use crate::scene::camera::CameraBasis;
use crate::scene::lights::Emitter;
use crate::transport::driver::{drive_indexed, Merge};
use crate::transport::{Context, IterationStart, IterationWork, RayStats, Splat};

/// The most subpaths a chunk traces.
const CHUNK: usize = 128;
/// The fewest chunks an iteration's subpaths are split into (while a chunk keeps at least
/// [`MIN_CHUNK`]): a few hundred light subpaths, as a diffuse scene's small image has,
/// would otherwise leave a thread idle.
const MIN_CHUNKS: usize = 16;
/// The fewest subpaths a chunk traces.
const MIN_CHUNK: usize = 16;
/// The key of the light subpaths' streams (apart from the camera samples').
const LIGHT_KEY: u64 = 0x7663_6d6c;

/// A light subpath's vertex kept for connections and merges: at a surface or in a medium.
#[derive(Clone, Copy, Debug)]
pub(super) struct LightVertex<'a> {
    pub at: Spot,
    /// Unit direction towards the vertex before it.
    pub wo: Vec3,
    pub scatter: Scatter<'a>,
    pub path: Subpath,
    pub around: Around,
    /// The scatterer seen from `wo` when it is a Lambertian surface (connections evaluate
    /// it from the few numbers this keeps).
    pub lambertian: Option<LambertianFrom>,
}

/// An iteration's light subpaths: every kept vertex, subpath by subpath.
pub(super) struct LightPaths<'a> {
    pub vertices: Vec<LightVertex<'a>>,
    /// Where each subpath's vertices start in `vertices` (one more than the subpaths).
    pub starts: Vec<u32>,
    /// The image's mean luminance as the subpaths' connections to the camera estimate it
    /// alone (unweighted light tracing, blind to light seen through glass): the scale
    /// against which a camera vertex's connections are judged small.
    pub image_mean: f32,
}

impl LightVertex<'_> {
    /// The scatterer's f·|cos| towards unit `wi` and its densities (forward, reverse), for
    /// importance.
    #[inline(always)]
    pub fn eval_and_pdfs(&self, wi: Vec3) -> (Rgb, f32, f32) {
        match &self.lambertian {
            Some(l) => l.eval_and_pdfs(wi, Transport::Importance),
            None => self
                .scatter
                .eval_and_pdfs(self.wo, wi, Transport::Importance),
        }
    }
}

impl<'a> LightPaths<'a> {
    /// The kept vertices of subpath `i`, in order along it.
    pub fn of(&self, i: usize) -> &[LightVertex<'a>] {
        &self.vertices[self.starts[i] as usize..self.starts[i + 1] as usize]
    }
}

/// What traces an iteration's light subpaths.
pub(super) struct LightPass<'w> {
    pub weights: &'w Weights,
    /// The most segments a full path has.
    pub max_len: u32,
    /// Light subpaths an iteration.
    pub count: usize,
    /// The image's pixels over `count`: the film divides splats by the pixels, and the
    /// camera's density of a point is per pixel over the light subpaths that may reach it.
    pub pixels_per_path: f32,
}

/// A chunk's output: its subpaths' vertices and their lengths, splats, rays, and the sum
/// of its splats' luminance before their weights.
struct Chunk<'a> {
    vertices: Vec<LightVertex<'a>>,
    counts: Vec<u32>,
    splats: Vec<Splat>,
    rays: RayStats,
    unweighted: f64,
}

impl LightPass<'_> {
    /// The light subpaths of iteration `start.index` and what they splat; `None` if
    /// cancelled.
    pub fn run<'a>(
        &self,
        ctx: &Context<'a>,
        start: &IterationStart,
        threads: Option<usize>,
    ) -> Option<(LightPaths<'a>, IterationWork)> {
        let n = self.count;
        // A function of the count alone, not of the threads: the sums are the same bits.
        let size = (n / MIN_CHUNKS).clamp(MIN_CHUNK, CHUNK);
        let chunks = n.div_ceil(size);
        let mut paths = LightPaths {
            vertices: Vec::new(),
            starts: vec![0],
            image_mean: 0.0,
        };
        let mut unweighted = 0.0;
        let mut work = IterationWork::default();
        let driven = drive_indexed(
            chunks,
            threads,
            64,
            start.cancel,
            |c| self.chunk(ctx, start, c * size..((c + 1) * size).min(n)),
            |_, chunk: Chunk<'a>| {
                let mut at = paths.vertices.len() as u32;
                for count in chunk.counts {
                    at += count;
                    paths.starts.push(at);
                }
                paths.vertices.extend(chunk.vertices);
                work.splats.extend(
                    chunk
                        .splats
                        .into_iter()
                        .filter(|s| s.value.is_finite() && s.x.is_finite() && s.y.is_finite()),
                );
                work.rays.add(&chunk.rays);
                unweighted += chunk.unweighted;
                Merge::Continue
            },
        );
        // Each splat adds value / pixels to its pixel.
        let pixels = f64::from(self.pixels_per_path) * n as f64;
        paths.image_mean = (unweighted / (pixels * pixels)) as f32;
        (!driven.cancelled).then_some((paths, work))
    }

    fn chunk<'a>(
        &self,
        ctx: &Context<'a>,
        start: &IterationStart,
        range: std::ops::Range<usize>,
    ) -> Chunk<'a> {
        let mut out = Chunk {
            vertices: Vec::new(),
            counts: Vec::with_capacity(range.len()),
            splats: Vec::new(),
            rays: RayStats::default(),
            unweighted: 0.0,
        };
        for i in range {
            let i = i as u64;
            let mut sampler = Sampler::new(
                start.seed,
                &[LIGHT_KEY, start.index as u64, i >> 32],
                i as u32,
            );
            let before = out.vertices.len();
            self.subpath(ctx, start.camera, &mut sampler, &mut out);
            out.counts.push((out.vertices.len() - before) as u32);
        }
        out
    }

    /// One light subpath: SmallVCM's light loop.
    fn subpath<'a>(
        &self,
        ctx: &Context<'a>,
        camera: &CameraBasis,
        sampler: &mut Sampler,
        out: &mut Chunk<'a>,
    ) {
        let u_choose = sampler.next_1d();
        let u_pos = sampler.next_2d();
        let u_dir = sampler.next_2d();
        let Some(es) = ctx.lights.sample_le(u_choose, u_pos, u_dir) else {
            return;
        };
        if !(es.pdf_pos > 0.0 && es.pdf_dir > 0.0) {
            return;
        }
        let lp = of_emission(ctx, &es);
        let (mut beta, mut ray) = emission_start(ctx, &es, 0.0);
        let mut spectral = ctx.has_media().then(|| Spectral {
            hero: hero_channel(sampler),
            rng: sampler.stream(),
        });
        let mut r_u = Rgb::ONE;
        let mut medium = None;
        if let Some(Spectral { hero, .. }) = spectral {
            // The medium around the light: on the side it emits to of an emitter that bounds
            // media, else the camera's medium carried to it; light from infinity first
            // crosses what of it lies beyond the scene.
            let interface = match &ctx.lights.emitters[es.light] {
                Emitter::Area(a) => ctx.scene.shapes[a.shape]
                    .media
                    .map(|i| (i, a.sample(u_pos).n)),
                _ => None,
            };
            medium = match interface {
                Some((i, n)) => i.towards(es.dir, n),
                None => medium_at(ctx, es.p, 0.0, &mut out.rays),
            };
            if let (Some(m), false) = (medium, lp.finite) {
                let model = ctx.scene.media[m as usize].model();
                let mut tp = Throughput {
                    beta,
                    r_u,
                    r_l: Rgb::ONE,
                };
                let Some(start) = arrive_from_infinity(model, es.p, es.dir, (hero, &mut tp)) else {
                    return;
                };
                (beta, r_u) = (tp.beta, tp.r_u);
                ray = Spot::exact(start).spawn(es.dir);
            }
        }
        let w = self.weights;
        let d_vc = if lp.delta {
            0.0
        } else {
            lp.cos_at_light / lp.emission_pdf_w
        };
        let mut path = Subpath {
            beta,
            r_u,
            len: 1,
            d_vcm: lp.direct_pdf_a / lp.emission_pdf_w,
            d_vc,
            d_vm: d_vc * w.vc,
        };
        if !(path.beta.is_finite() && path.beta.max_element() > 0.0 && path.d_vcm.is_finite()) {
            return;
        }
        let media = spectral.is_some();
        loop {
            let from_infinity = path.len == 1 && !lp.finite;
            let origin = ray.origin;
            let step = advance(
                ctx,
                &ray,
                &mut medium,
                spectral.as_ref(),
                &mut path,
                (sampler, &mut out.rays),
                None,
            );
            let wo = -ray.dir.normalize();
            let (sp, at, scatter, around) = match step {
                (Step::Ended | Step::Escaped, _) => break,
                (Step::Surface(sp), grey) => {
                    let at = sp.spot();
                    path.arrive(
                        (sp.p - origin).length(),
                        abs_cos(at.n, wo),
                        from_infinity,
                        grey,
                    );
                    let bsdf = ctx.scene.materials[sp.material].bsdf(&sp, wo);
                    let around = if media {
                        Around::surface(ctx, &sp, medium)
                    } else {
                        Around::default()
                    };
                    (Some(sp), at, Scatter::Surface(bsdf), around)
                }
                (Step::Medium { p, g }, grey) => {
                    path.arrive((p - origin).length(), 1.0, from_infinity, grey);
                    let around = Around {
                        medium,
                        interface: None,
                    };
                    (None, Spot::exact(p), Scatter::Medium { g }, around)
                }
            };
            if scatter.connectible() {
                let v = LightVertex {
                    at,
                    wo,
                    scatter,
                    path,
                    around,
                    lambertian: scatter.lambertian_from(wo),
                };
                out.vertices.push(v);
                if path.len < self.max_len {
                    self.to_camera(ctx, camera, &v, (sampler, spectral.as_mut()), out);
                }
            }
            if path.len + 2 > self.max_len {
                break;
            }
            let v = Leaving {
                at,
                scatter: &scatter,
                sp: sp.as_ref(),
                around,
                wo,
            };
            let mode = (Transport::Importance, media);
            let Some(next) = leave(&mut path, w, v, mode, &mut medium, sampler) else {
                break;
            };
            ray = next;
        }
    }

    /// The light tracing technique: vertex `v` connected to the camera, splatted.
    fn to_camera(
        &self,
        ctx: &Context,
        camera: &CameraBasis,
        v: &LightVertex,
        (sampler, spectral): (&mut Sampler, Option<&mut Spectral>),
        out: &mut Chunk,
    ) {
        let lens = lens_sample(camera, sampler);
        let Some(c) = project_to_camera(camera, lens, v.at.p) else {
            return;
        };
        let (f, _, pdf_rev) = v.eval_and_pdfs(c.dir);
        if f == Rgb::ZERO {
            return;
        }
        let p = &v.path;
        let from = (&v.at, v.around.towards(c.dir, v.at.n));
        let lens_spot = Spot::exact(lens);
        let Some((through, grey)) = link(
            ctx,
            from,
            End::At(&lens_spot),
            p.r_u,
            spectral,
            &mut out.rays,
        ) else {
            return;
        };
        let dist2 = (lens - v.at.p).length_squared();
        let camera_pdf_a =
            camera_pdf_dir(camera, lens, -c.dir) * v.scatter.cos(v.at.n, c.dir) / dist2 * grey;
        let vm = if v.scatter.mergeable() {
            self.weights.vm
        } else {
            0.0
        };
        let w_light = camera_pdf_a * self.pixels_per_path * (vm + p.d_vcm + p.d_vc * pdf_rev);
        let weight = 1.0 / (1.0 + w_light);
        let value = p.beta * f * (c.importance * self.pixels_per_path) * through;
        if value.is_finite() {
            out.unweighted += f64::from(luminance(value));
        }
        out.splats.push(Splat {
            x: c.x,
            y: c.y,
            value: value * weight,
        });
    }
}
