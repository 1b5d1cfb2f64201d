//! The multiple importance sampling of vertex connection and merging, kept as three running
//! quantities per subpath (Georgiev et al. 2012's technical report, as SmallVCM computes
//! them, balance heuristic): `d_vcm`, `d_vc` and `d_vm` gather the ratios of the densities
//! of every other technique that could have made the subpath so far, so that a connection
//! or a merge finds its weight in constant time.

use crate::bsdf::{Bsdf, Transport};
use crate::integrators::path::russian_roulette;
use crate::math::sobol::Sampler;
use crate::math::{Rgb, Vec3};

/// The iteration's constants of the weights: η = π r² N (the merge radius's disk times the
/// light subpaths of the iteration), a merge's density relative to a connection's.
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
    /// For merge radius `radius` and `light_paths` light subpaths an iteration.
    pub fn new(radius: f32, light_paths: f32) -> Weights {
        let eta = std::f32::consts::PI * radius * radius * light_paths;
        Weights {
            vm: eta,
            vc: 1.0 / eta,
            vm_normalization: 1.0 / eta,
        }
    }
}

/// A subpath as it grows: its throughput, its length in segments and its MIS quantities.
#[derive(Clone, Copy, Debug)]
pub(super) struct Subpath {
    pub beta: Rgb,
    /// Segments from its start to its last vertex.
    pub len: u32,
    pub d_vcm: f32,
    pub d_vc: f32,
    pub d_vm: f32,
}

impl Subpath {
    /// Arriving at a surface after a segment of length `dist`, with |cos| `cos` between the
    /// segment and the surface's geometric normal: the densities become area densities.
    /// `from_infinity`: the segment came from a light at infinity (no distance).
    pub fn arrive(&mut self, dist: f32, cos: f32, from_infinity: bool) {
        if !from_infinity {
            self.d_vcm *= dist * dist;
        }
        let inv = 1.0 / cos.max(1e-12);
        self.d_vcm *= inv;
        self.d_vc *= inv;
        self.d_vm *= inv;
    }

    /// Leaving a surface along a direction sampled with solid-angle density `pdf` (for a
    /// delta lobe, `delta` and any `pdf`), `pdf_rev` the density of the reverse direction,
    /// `cos_out` |cos| between the new direction and the geometric normal.
    pub fn scatter(&mut self, w: &Weights, pdf: f32, pdf_rev: f32, cos_out: f32, delta: bool) {
        if delta {
            self.d_vcm = 0.0;
            self.d_vc *= cos_out;
            self.d_vm *= cos_out;
        } else {
            let g = cos_out / pdf;
            self.d_vc = g * (self.d_vc * pdf_rev + self.d_vcm + w.vm);
            self.d_vm = g * (self.d_vm * pdf_rev + self.d_vcm * w.vc + 1.0);
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
        mode: Transport,
        sampler: &mut Sampler,
    ) -> Option<Vec3> {
        let u_lobe = sampler.next_1d();
        let bs = bsdf.sample(wo, u_lobe, sampler.next_2d(), mode)?;
        let pdf_rev = if bs.delta { 0.0 } else { bsdf.pdf(bs.wi, wo) };
        self.scatter(w, bs.pdf, pdf_rev, abs_cos(n, bs.wi), bs.delta);
        self.beta *= bs.weight;
        if self.beta == Rgb::ZERO || !russian_roulette(&mut self.beta, self.len, sampler) {
            return None;
        }
        self.len += 1;
        Some(bs.wi)
    }
}

/// |cos| between unit `a` and `b`.
pub(super) fn abs_cos(a: Vec3, b: Vec3) -> f32 {
    a.dot(b).abs()
}
