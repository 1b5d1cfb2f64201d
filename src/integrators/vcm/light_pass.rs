//! An iteration's light subpaths (one per pixel unless set otherwise), each from a light chosen by power and
//! continued by BSDF sampling for importance transport. Every vertex where the BSDF is not
//! purely specular is kept (for connections and merges) and connected to the camera (the
//! light tracing technique, splatted).
//!
//! Determinism: subpath `i` of an iteration draws from the stream of (seed, iteration, i)
//! alone; subpaths are traced in fixed chunks, in parallel, and their vertices and splats
//! are concatenated in chunk order, so the iteration is the same bits for any thread count.

use super::lights::of_emission;
use super::mis::{abs_cos, Subpath, Weights};
use crate::bsdf::{Bsdf, Transport};
use crate::integrators::camera_connection::camera_pdf_dir;
use crate::integrators::camera_connection::{lens_sample, project_to_camera};
use crate::integrators::light::emission_start;
use crate::math::sobol::Sampler;
use crate::math::spawn::Spot;
use crate::math::{Rgb, Vec3};
use crate::scene::camera::CameraBasis;
use crate::transport::driver::{drive_indexed, Merge};
use crate::transport::{Context, IterationStart, IterationWork, RayStats, Splat};

/// Subpaths a chunk traces.
const CHUNK: usize = 1024;
/// The key of the light subpaths' streams (apart from the camera samples').
const LIGHT_KEY: u64 = 0x7663_6d6c;

/// A light subpath's vertex kept for connections and merges.
#[derive(Clone, Copy, Debug)]
pub(super) struct LightVertex<'a> {
    pub at: Spot,
    /// Unit direction towards the vertex before it.
    pub wo: Vec3,
    pub bsdf: Bsdf<'a>,
    pub path: Subpath,
}

/// An iteration's light subpaths: every kept vertex, subpath by subpath.
pub(super) struct LightPaths<'a> {
    pub vertices: Vec<LightVertex<'a>>,
    /// Where each subpath's vertices start in `vertices` (one more than the subpaths).
    pub starts: Vec<u32>,
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

/// A chunk's output: its subpaths' vertices and their lengths, splats, rays, dropped.
struct Chunk<'a> {
    vertices: Vec<LightVertex<'a>>,
    counts: Vec<u32>,
    splats: Vec<Splat>,
    rays: RayStats,
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
        let chunks = n.div_ceil(CHUNK);
        let mut paths = LightPaths {
            vertices: Vec::new(),
            starts: vec![0],
        };
        let mut work = IterationWork::default();
        let driven = drive_indexed(
            chunks,
            threads,
            64,
            start.cancel,
            |c| self.chunk(ctx, start, c * CHUNK..((c + 1) * CHUNK).min(n)),
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
                Merge::Continue
            },
        );
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
        let (beta, mut ray) = emission_start(ctx, &es, 0.0);
        let w = self.weights;
        let d_vc = if lp.delta {
            0.0
        } else {
            lp.cos_at_light / lp.emission_pdf_w
        };
        let mut path = Subpath {
            beta,
            len: 1,
            d_vcm: lp.direct_pdf_a / lp.emission_pdf_w,
            d_vc,
            d_vm: d_vc * w.vc,
        };
        if !(path.beta.is_finite() && path.beta.max_element() > 0.0 && path.d_vcm.is_finite()) {
            return;
        }
        while let Some(sp) = ctx.intersect(&ray, &mut out.rays) {
            let wo = -ray.dir.normalize();
            let at = sp.spot();
            let dist = (sp.p - ray.origin).length();
            path.arrive(dist, abs_cos(at.n, wo), path.len == 1 && !lp.finite);
            let bsdf = ctx.scene.materials[sp.material].bsdf(&sp, wo);
            if bsdf.has_non_delta() {
                let v = LightVertex { at, wo, bsdf, path };
                out.vertices.push(v);
                if path.len < self.max_len {
                    self.to_camera(ctx, camera, &v, sampler, out);
                }
            }
            if path.len + 2 > self.max_len {
                break;
            }
            let Some(wi) = path.bounce(w, (&bsdf, wo, at.n), Transport::Importance, sampler) else {
                break;
            };
            ray = sp.spawn(wi);
        }
    }

    /// The light tracing technique: vertex `v` connected to the camera, splatted.
    fn to_camera(
        &self,
        ctx: &Context,
        camera: &CameraBasis,
        v: &LightVertex,
        sampler: &mut Sampler,
        out: &mut Chunk,
    ) {
        let lens = lens_sample(camera, sampler);
        let Some(c) = project_to_camera(camera, lens, v.at.p) else {
            return;
        };
        let f = v.bsdf.eval(v.wo, c.dir, Transport::Importance);
        if f == Rgb::ZERO {
            return;
        }
        let dist2 = (lens - v.at.p).length_squared();
        let camera_pdf_a = camera_pdf_dir(camera, lens, -c.dir) * abs_cos(v.at.n, c.dir) / dist2;
        let pdf_rev = v.bsdf.pdf(c.dir, v.wo);
        let p = &v.path;
        let w_light =
            camera_pdf_a * self.pixels_per_path * (self.weights.vm + p.d_vcm + p.d_vc * pdf_rev);
        let weight = 1.0 / (1.0 + w_light);
        let shadow = v.at.spawn_to(&Spot::exact(lens));
        if ctx.occluded(&shadow, &mut out.rays) {
            return;
        }
        out.splats.push(Splat {
            x: c.x,
            y: c.y,
            value: p.beta * f * (c.importance * weight * self.pixels_per_path),
        });
    }
}
