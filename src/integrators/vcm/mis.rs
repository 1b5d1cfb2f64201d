//! The multiple importance sampling of vertex connection and merging, kept as three running
//! quantities per subpath (Georgiev et al. 2012's technical report, as SmallVCM computes
//! them, balance heuristic): `d_vcm`, `d_vc` and `d_vm` gather the ratios of the densities
//! of every other technique that could have made the subpath so far, so that a connection
//! or a merge finds its weight in constant time.

use crate::bsdf::{phase, Bsdf, Transport};
use crate::integrators::path::{russian_roulette, RR_START_DEPTH};
use crate::integrators::volumetric::{self, average};
use crate::math::sobol::Sampler;
use crate::math::{Rgb, Vec3};

/// The iteration's constants of the weights: η = π r² N (the merge radius's disk times the
/// light subpaths of the iteration), a merge's density relative to a connection's; 0 when
/// the render does not merge (the weights are then bidirectional tracing's).
#[derive(Clone, Copy, Debug)]
pub(super) struct Weights {
    /// η: what a merge counts relative to a connection.
    pub vm: f32,
    /// 1 / η.
    pub vc: f32,
    /// 1 / (π r² N): what a merge's sum is multiplied by (the density estimate's kernel
    /// over the iteration's light subpaths).
    pub vm_normalization: f32,
}

impl Weights {
    /// For merge radius `radius` and `light_paths` light subpaths an iteration; `merges`:
    /// whether the camera subpaths merge.
    pub fn new(radius: f32, light_paths: f32, merges: bool) -> Weights {
        let eta = std::f32::consts::PI * radius * radius * light_paths;
        Weights {
            vm: if merges { eta } else { 0.0 },
            vc: 1.0 / eta,
            vm_normalization: 1.0 / eta,
        }
    }
}

/// A subpath as it grows: its throughput, its length in segments and its MIS quantities.
#[derive(Clone, Copy, Debug)]
pub(super) struct Subpath {
    pub beta: Rgb,
    /// Each channel's density of the subpath over its hero channel's (all ones without
    /// media).
    pub r_u: Rgb,
    /// Segments from its start to its last vertex.
    pub len: u32,
    pub d_vcm: f32,
    pub d_vc: f32,
    pub d_vm: f32,
}

impl Subpath {
    /// Arriving at a surface after a segment of length `dist`, with |cos| `cos` between the
    /// segment and the surface's geometric normal (1 at a point in a medium), through grey
    /// transmittance `grey` (1 without media): the densities become area (or volume)
    /// densities, the distance sampling's included. `from_infinity`: the segment came from
    /// a light at infinity (no distance).
    pub fn arrive(&mut self, dist: f32, cos: f32, from_infinity: bool, grey: f32) {
        if !from_infinity {
            self.d_vcm *= dist * dist;
        }
        if grey != 1.0 {
            self.d_vcm /= grey;
        }
        let inv = 1.0 / cos.max(1e-12);
        self.d_vcm *= inv;
        self.d_vc *= inv;
        self.d_vm *= inv;
    }

    /// Leaving a vertex along a direction sampled with solid-angle density `pdf`, `pdf_rev`
    /// the density of the reverse direction,
    /// `cos_out` |cos| between the new direction and the geometric normal (1 in a medium);
    /// `kind`: the vertex's scatterer (a delta lobe: any `pdf`).
    pub fn scatter(&mut self, w: &Weights, (pdf, pdf_rev): (f32, f32), cos_out: f32, kind: Kind) {
        if kind == Kind::Delta {
            self.d_vcm = 0.0;
            self.d_vc *= cos_out;
            self.d_vm *= cos_out;
        } else {
            // A vertex in a medium has no merge: its terms drop out.
            let (vm, one) = match kind {
                Kind::Medium => (0.0, 0.0),
                _ => (w.vm, 1.0),
            };
            let g = cos_out / pdf;
            self.d_vc = g * (self.d_vc * pdf_rev + self.d_vcm + vm);
            self.d_vm = g * (self.d_vm * pdf_rev + self.d_vcm * w.vc + one);
            self.d_vcm = 1.0 / pdf;
        }
    }
}

impl Subpath {
    /// The next direction from a surface with geometric normal `n`, reached along `-wo`:
    /// sampled from `bsdf` for `mode`, the quantities and throughput updated, Russian
    /// roulette played and the length counted; `None` where the subpath ends.
    pub fn bounce(
        &mut self,
        w: &Weights,
        (bsdf, wo, n): (&Bsdf, Vec3, Vec3),
        (mode, media): (Transport, bool),
        sampler: &mut Sampler,
    ) -> Option<Vec3> {
        let u_lobe = sampler.next_1d();
        let bs = bsdf.sample(wo, u_lobe, sampler.next_2d(), mode)?;
        let pdf_rev = if bs.delta { 0.0 } else { bsdf.pdf(bs.wi, wo) };
        let kind = if bs.delta { Kind::Delta } else { Kind::Surface };
        self.scatter(w, (bs.pdf, pdf_rev), abs_cos(n, bs.wi), kind);
        self.beta *= bs.weight;
        if self.beta == Rgb::ZERO || !self.roulette(media, sampler) {
            return None;
        }
        self.len += 1;
        Some(bs.wi)
    }

    /// The next direction from a point in a medium with asymmetry `g`, reached along
    /// `-wo`: as [`bounce`](Self::bounce), by the phase function (its own density, and
    /// symmetric: the throughput keeps its value).
    pub fn bounce_in_medium(
        &mut self,
        w: &Weights,
        (g, wo): (f32, Vec3),
        sampler: &mut Sampler,
    ) -> Option<Vec3> {
        let (wi, pdf) = phase::sample_hg(wo, g, sampler.next_2d());
        if !volumetric::positive(pdf) {
            return None;
        }
        self.scatter(w, (pdf, pdf), 1.0, Kind::Medium);
        if !self.roulette(true, sampler) {
            return None;
        }
        self.len += 1;
        Some(wi)
    }

    /// Russian roulette: by the throughput over the average channel ratio in a scene with
    /// `media`, as the volumetric tracers play it.
    fn roulette(&mut self, media: bool, sampler: &mut Sampler) -> bool {
        if media {
            let on = self.len >= RR_START_DEPTH;
            volumetric::russian_roulette(&mut self.beta, self.r_u, on, sampler)
        } else {
            russian_roulette(&mut self.beta, self.len, sampler)
        }
    }

    /// The throughput over the average of its channel ratios: the subpath's contribution
    /// under spectral MIS (the throughput itself without media).
    pub fn weighted(&self) -> Rgb {
        self.beta / average(self.r_u)
    }
}

/// What a vertex scatters by, for the weights.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Kind {
    /// A surface's lobe that is not a delta: merges happen there.
    Surface,
    /// A delta lobe: neither connections nor merges.
    Delta,
    /// A phase function: connections, but no merges.
    Medium,
}

/// |cos| between unit `a` and `b`.
pub(super) fn abs_cos(a: Vec3, b: Vec3) -> f32 {
    a.dot(b).abs()
}
