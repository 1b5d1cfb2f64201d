//! SPPM's photon pass: photons leave the lights (chosen by power; lights at infinity from
//! the scene's bounding disk, as the light tracer starts its paths), bounce by BSDF
//! sampling for importance transport with pbrt-v4's Russian roulette, and at every surface
//! after the first (direct light is the camera pass's) add their power, weighed by each
//! visible point's BSDF, to the visible points whose radius holds the hit.
//!
//! Determinism: photon `i` of an iteration draws from the stream of (seed, iteration, i)
//! alone. Photons are traced in fixed chunks of [`CHUNK`], in parallel; each chunk lists
//! its deposits in photon order, and the lists are summed (in f64) in chunk order, so the
//! sums are the same bits for any thread count or schedule.

use super::media::{self, Targets};
use crate::bsdf::Transport;
use crate::control::CancelToken;
use crate::integrators::light::emission_start;
use crate::math::sobol::Sampler;
use crate::math::Rgb;
use crate::transport::{Context, RayStats};
use rayon::prelude::*;

/// Photons a chunk traces.
const CHUNK: u64 = 4096;
/// Chunks traced before their deposits are summed (bounds the deposits held at once).
const WAVE: u64 = 64;
/// The key of the photons' streams (apart from the camera samples').
const PHOTON_KEY: u64 = 0x7370_706d;

/// A chunk's deposits (visible point, β_vp·f·power), in photon order, and its rays.
type Chunk = (Vec<(u32, Rgb)>, RayStats);

/// What the photons of one iteration brought to the visible points.
pub(super) struct Arrivals {
    /// Per visible point (those on surfaces, then those in media): Σ β_vp · f · power, per
    /// channel.
    pub phi: Vec<[f64; 3]>,
    /// Per visible point: the photons counted.
    pub m: Vec<u32>,
    pub rays: RayStats,
}

/// The photon pass of one iteration.
pub(super) struct PhotonPass<'p, 'a> {
    /// The visible points, on surfaces and in media, and their grids.
    pub targets: Targets<'p, 'a>,
    pub seed: u64,
    pub max_depth: u32,
}

impl PhotonPass<'_, '_> {
    /// Traces `photons` photons of `iteration`; `None` if cancelled.
    pub fn run(
        &self,
        ctx: &Context,
        iteration: u32,
        photons: u64,
        cancel: &CancelToken,
    ) -> Option<Arrivals> {
        let points = self.targets.surface.len() + self.targets.medium.len();
        let mut out = Arrivals {
            phi: vec![[0.0; 3]; points],
            m: vec![0; points],
            rays: RayStats::default(),
        };
        let chunks = photons.div_ceil(CHUNK);
        let mut first = 0;
        while first < chunks {
            let last = (first + WAVE).min(chunks);
            let wave: Vec<Option<Chunk>> = (first..last)
                .into_par_iter()
                .map(|c| {
                    if cancel.is_cancelled() {
                        return None;
                    }
                    let photon_range = c * CHUNK..((c + 1) * CHUNK).min(photons);
                    Some(self.chunk(ctx, iteration, photon_range))
                })
                .collect();
            for chunk in wave {
                let (deposits, rays) = chunk?;
                out.rays.add(&rays);
                for (k, v) in deposits {
                    let k = k as usize;
                    for ch in 0..3 {
                        out.phi[k][ch] += v[ch] as f64;
                    }
                    out.m[k] += 1;
                }
            }
            first = last;
        }
        Some(out)
    }

    /// The deposits (visible point, β_vp·f·power) of photons `range`, in order.
    fn chunk(&self, ctx: &Context, iteration: u32, range: std::ops::Range<u64>) -> Chunk {
        let mut deposits = Vec::new();
        let mut stats = RayStats::default();
        for i in range {
            let mut sampler = Sampler::new(
                self.seed,
                &[PHOTON_KEY, iteration as u64, i >> 32],
                i as u32,
            );
            if ctx.scene.media.is_empty() {
                self.photon(ctx, &mut sampler, &mut stats, &mut deposits);
            } else {
                let to = &self.targets;
                media::photon(
                    ctx,
                    to,
                    self.max_depth,
                    &mut sampler,
                    &mut stats,
                    &mut deposits,
                );
            }
        }
        (deposits, stats)
    }

    /// One photon's path: pbrt-v4's loop over at most `max_depth` surfaces.
    fn photon(
        &self,
        ctx: &Context,
        sampler: &mut Sampler,
        stats: &mut RayStats,
        deposits: &mut Vec<(u32, Rgb)>,
    ) {
        let u_choose = sampler.next_2d();
        let u_pos = sampler.next_2d();
        let u_dir = sampler.next_2d();
        let Some(es) = ctx.lights.sample_le(u_choose.x, u_pos, u_dir) else {
            return;
        };
        let (mut beta, mut ray) = emission_start(ctx, &es, 0.0);
        if !(beta.is_finite() && beta.max_element() > 0.0) {
            return;
        }
        for depth in 0..self.max_depth {
            let Some(sp) = ctx.intersect(&ray, stats) else {
                break;
            };
            let wo = -ray.dir;
            if depth > 0 {
                self.targets.surface_grid.query(sp.p, |k| {
                    let v = self.targets.surface[k].weigh(wo, beta);
                    if v.is_finite() && v != Rgb::ZERO {
                        deposits.push((k as u32, v));
                    }
                });
            }
            let bsdf = ctx.scene.materials[sp.material].bsdf(&sp, wo);
            let u_lobe = sampler.next_1d();
            let Some(bs) = bsdf.sample(wo, u_lobe, sampler.next_2d(), Transport::Importance) else {
                break;
            };
            let next = beta * bs.weight;
            // pbrt-v4's photon roulette: survive with the ratio of the new throughput to
            // the old (at most 1), reweighted.
            let q = (1.0 - next.max_element() / beta.max_element()).max(0.0);
            if sampler.next_1d() < q {
                break;
            }
            beta = next / (1.0 - q);
            if !(beta.is_finite() && beta.max_element() > 0.0) {
                break;
            }
            ray = sp.spawn(bs.wi);
        }
    }
}
