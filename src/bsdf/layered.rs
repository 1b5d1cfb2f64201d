//! A dielectric coat over a base (pbrt-v4's `LayeredBxDF`, as its `CoatedDiffuseBxDF` and
//! `CoatedConductorBxDF`): light refracts into a slab of the given thickness, bounces between
//! the base and the underside of the coat (absorbed along the way by Tr = exp(−d/|cos θ|),
//! optionally scattered by a medium of single-scattering albedo `albedo` with a
//! Henyey–Greenstein phase function), and leaves through the coat. No closed form covers the
//! light that bounces inside, so f and the density are estimated by short random walks
//! (Guo et al. 2018, "Position-free Monte Carlo simulation for arbitrary layered BSDFs"),
//! and sampling is a random walk whose weight is exact in expectation.
//!
//! One departure from pbrt-v4: where the evaluation's walk leaves through a rough coat, the
//! MIS weight of the direction sampled inside compares its density with that of wis's
//! strategy for the same inside direction (sampling into the coat from wi). pbrt-v4 takes
//! the density of the opposite event (wi sampled from inside), so its weights do not sum to
//! one and its f of a rough coat is off its own sampling by several percent
//! (`cargo test --release --lib layered::sampling` measures the agreement).
//!
//! The walks draw their numbers from streams keyed by the directions (and for sampling by the
//! sample's numbers), as pbrt-v4 keys them by `Hash(wo), Hash(wi)`: the same query always
//! gives the same estimate, so a render stays a function of scene, settings and seed.
//!
//! Directions are in the local frame, +z out of the coat; the stack is two-sided (seen from
//! below, both directions are mirrored), and opaque: nothing is transmitted.

use super::layer::{Layer, LayerSample, Lobes};
use super::phase::{hg, sample_hg};
use super::Coating;
use super::Conductor;
use super::{Ggx, Transport};
use crate::math::warp::power_heuristic;
use crate::math::{Rgb, Rng, Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Keys of the random streams of evaluation, density and sampling.
const EVAL_KEY: u64 = 0x6c61_7965_7266;
const PDF_KEY: u64 = 0x6c61_7965_7270;
const SAMPLE_KEY: u64 = 0x6c61_7965_7273;

/// The coat and its base.
#[derive(Clone, Copy, Debug)]
pub struct Layered {
    top: Layer,
    bottom: Layer,
    thickness: f32,
    albedo: Rgb,
    g: f32,
    max_depth: u32,
    samples: u32,
}

/// The layered walk's sample: the direction, f·|cos θi|/pdf, the walk's probability density
/// (proportional to the marginal density, not equal to it) and whether every step was a
/// delta.
#[derive(Clone, Copy, Debug)]
pub struct WalkSample {
    pub wi: Vec3,
    pub weight: Rgb,
    pub pdf: f32,
    pub specular: bool,
}

/// Transmittance through a slab of thickness `dz` along `w` (attenuation coefficient 1).
fn tr(dz: f32, w: Vec3) -> f32 {
    if dz.abs() <= f32::MIN_POSITIVE {
        return 1.0;
    }
    (-(dz / w.z).abs()).exp()
}

/// Bits of a direction for keying a random stream.
fn key(v: Vec3) -> [u64; 2] {
    [
        (v.x.to_bits() as u64) << 32 | v.y.to_bits() as u64,
        v.z.to_bits() as u64,
    ]
}

/// The next uniform number of `rng` (in [0, 1)).
fn next(rng: &mut Rng) -> f32 {
    rng.uniform()
}

fn next2(rng: &mut Rng) -> Vec2 {
    let x = rng.uniform();
    Vec2::new(x, rng.uniform())
}

fn flip(mode: Transport) -> Transport {
    match mode {
        Transport::Radiance => Transport::Importance,
        Transport::Importance => Transport::Radiance,
    }
}

impl Layered {
    /// `coating` over a Lambertian base of reflectance `kd`, or over `conductor` (its index
    /// relative to vacuum) with GGX `base_ggx` when there is one.
    pub fn new(
        coating: &Coating,
        kd: Rgb,
        conductor: Option<Conductor>,
        base_ggx: Option<Ggx>,
    ) -> Layered {
        let (ax, ay) = coating.alphas();
        let (ax, ay) = (ax.clamp(0.0, 1.0), ay.clamp(0.0, 1.0));
        let coat_ggx = (ax.max(ay) >= 1e-3).then_some(Ggx {
            alpha_x: ax,
            alpha_y: ay,
        });
        let bottom = match conductor {
            // Under the coat the metal meets the coat's medium: its index relative to it.
            Some(c) => Layer::Conductor {
                c: Conductor {
                    eta: c.eta / coating.ior,
                    k: c.k / coating.ior,
                },
                ggx: base_ggx,
            },
            None => Layer::Diffuse(kd),
        };
        Layered {
            top: Layer::Dielectric {
                ior: coating.ior,
                ggx: coat_ggx,
            },
            bottom,
            thickness: coating.thickness.max(f32::MIN_POSITIVE),
            albedo: coating.albedo,
            g: coating.g,
            max_depth: coating.max_depth,
            samples: coating.samples.max(1),
        }
    }

    /// Whether some path through the stack is not a chain of deltas.
    pub fn has_non_delta(&self) -> bool {
        !self.top.specular() || !self.bottom.specular() || self.has_medium()
    }

    fn has_medium(&self) -> bool {
        self.albedo.max_element() > 0.0
    }

    /// The estimate of f(wo, wi) (no cosine) for local directions on one side.
    pub fn f(&self, wo: Vec3, wi: Vec3, mode: Transport) -> Rgb {
        let (wo, wi) = if wo.z < 0.0 { (-wo, -wi) } else { (wo, wi) };
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        let (top, bottom) = (&self.top, &self.bottom);
        let n = self.samples;
        // Light enters and leaves through the top: the exit is at z = thickness.
        let exit_z = self.thickness;
        let mut f = top.f(wo, wi, mode) * n as f32;
        let [a, b] = key(wo);
        let [c, d] = key(wi);
        let mut rng = Rng::for_key(EVAL_KEY, &[a, b, c, d]);
        for _ in 0..n {
            let uc = next(&mut rng);
            let Some(wos) = top.sample(wo, uc, next2(&mut rng), mode, Lobes::Transmission) else {
                continue;
            };
            // The light's end: a virtual light from wi, sampled into the coat.
            let uc = next(&mut rng);
            let wis = top.sample(wi, uc, next2(&mut rng), flip(mode), Lobes::Transmission);
            let Some(wis) = wis else {
                continue;
            };
            let mut beta = wos.f * wos.wi.z.abs() / wos.pdf;
            let mut z = self.thickness;
            let mut w = wos.wi;
            for depth in 0..self.max_depth {
                if depth > 3 && beta.max_element() < 0.25 {
                    let q = (1.0 - beta.max_element()).max(0.0);
                    if next(&mut rng) < q {
                        break;
                    }
                    beta /= 1.0 - q;
                }
                if !self.has_medium() {
                    z = if z == self.thickness {
                        0.0
                    } else {
                        self.thickness
                    };
                    beta *= tr(self.thickness, w);
                } else {
                    let dz = -(1.0 - next(&mut rng)).ln() * w.z.abs();
                    let zp = if w.z > 0.0 { z + dz } else { z - dz };
                    if zp == z {
                        continue;
                    }
                    if 0.0 < zp && zp < self.thickness {
                        // Scattering in the medium: next-event estimation through the exit
                        // along wis, then a new direction from the phase function.
                        let wt = if top.specular() {
                            1.0
                        } else {
                            power_heuristic(wis.pdf, hg(-w, -wis.wi, self.g))
                        };
                        f += beta
                            * self.albedo
                            * hg(-w, -wis.wi, self.g)
                            * wt
                            * tr(zp - exit_z, wis.wi)
                            * wis.f
                            / wis.pdf;
                        let (wp, pp) = sample_hg(-w, self.g, next2(&mut rng));
                        if pp == 0.0 || wp.z == 0.0 {
                            continue;
                        }
                        // p/pdf = 1 for an exactly sampled phase function.
                        beta *= self.albedo;
                        w = wp;
                        z = zp;
                        if z < exit_z && w.z > 0.0 && !top.specular() {
                            let f_exit = top.f(-w, wi, mode);
                            if f_exit.max_element() > 0.0 {
                                let exit_pdf = top.pdf(wi, -w, Lobes::Transmission);
                                let wt = power_heuristic(pp, exit_pdf);
                                f += beta * tr(zp - exit_z, wp) * f_exit * wt;
                            }
                        }
                        continue;
                    }
                    z = zp.clamp(0.0, self.thickness);
                }
                if z == exit_z {
                    // Reflection back down at the underside of the coat.
                    let uc = next(&mut rng);
                    let bs = top.sample(-w, uc, next2(&mut rng), mode, Lobes::Reflection);
                    let Some(bs) = bs else {
                        break;
                    };
                    beta *= bs.f * bs.wi.z.abs() / bs.pdf;
                    w = bs.wi;
                    continue;
                }
                // At the base: next-event estimation along wis, then a reflection.
                if !bottom.specular() {
                    let wt = if top.specular() {
                        1.0
                    } else {
                        power_heuristic(wis.pdf, bottom.pdf(-w, -wis.wi, Lobes::All))
                    };
                    f += beta
                        * bottom.f(-w, -wis.wi, mode)
                        * wis.wi.z.abs()
                        * wt
                        * tr(self.thickness, wis.wi)
                        * wis.f
                        / wis.pdf;
                }
                let uc = next(&mut rng);
                let bs = bottom.sample(-w, uc, next2(&mut rng), mode, Lobes::Reflection);
                let Some(bs) = bs else {
                    break;
                };
                beta *= bs.f * bs.wi.z.abs() / bs.pdf;
                w = bs.wi;
                if !top.specular() {
                    let f_exit = top.f(-w, wi, mode);
                    if f_exit.max_element() > 0.0 {
                        // The other strategy's density of the same inside direction:
                        // sampled from wi into the coat, as wis is.
                        let wt = if bottom.specular() {
                            1.0
                        } else {
                            power_heuristic(bs.pdf, top.pdf(wi, -w, Lobes::Transmission))
                        };
                        f += beta * tr(self.thickness, bs.wi) * f_exit * wt;
                    }
                }
            }
        }
        f / n as f32
    }

    /// The estimate of the density with which [`Layered::sample`] produces `wi` from `wo`,
    /// mixed with a uniform density (one tenth) as pbrt-v4 does, which keeps it positive.
    pub fn pdf(&self, wo: Vec3, wi: Vec3, mode: Transport) -> f32 {
        let (wo, wi) = if wo.z < 0.0 { (-wo, -wi) } else { (wo, wi) };
        if wi.z <= 0.0 || wo.z <= 0.0 || !self.has_non_delta() {
            return 0.0;
        }
        let (top, bottom) = (&self.top, &self.bottom);
        let n = self.samples;
        let [a, b] = key(wi);
        let [c, d] = key(wo);
        let mut rng = Rng::for_key(PDF_KEY, &[a, b, c, d]);
        let mut sum = n as f32 * top.pdf(wo, wi, Lobes::Reflection);
        for _ in 0..n {
            // Transmission down, reflection at the base, transmission up (TRT).
            let uc = next(&mut rng);
            let wos = top.sample(wo, uc, next2(&mut rng), mode, Lobes::Transmission);
            let uc = next(&mut rng);
            let wis = top.sample(wi, uc, next2(&mut rng), flip(mode), Lobes::Transmission);
            let (Some(wos), Some(wis)) = (wos, wis) else {
                continue;
            };
            if top.specular() {
                sum += bottom.pdf(-wos.wi, -wis.wi, Lobes::All);
                continue;
            }
            let uc = next(&mut rng);
            let rs = bottom.sample(-wos.wi, uc, next2(&mut rng), mode, Lobes::All);
            let Some(rs) = rs else {
                continue;
            };
            if bottom.specular() {
                sum += top.pdf(-rs.wi, wi, Lobes::All);
            } else {
                let r_pdf = bottom.pdf(-wos.wi, -wis.wi, Lobes::All);
                sum += power_heuristic(wis.pdf, r_pdf) * r_pdf;
                let t_pdf = top.pdf(-rs.wi, wi, Lobes::All);
                sum += power_heuristic(rs.pdf, t_pdf) * t_pdf;
            }
        }
        0.1 * 0.25 * FRAC_1_PI + 0.9 * sum / n as f32
    }

    /// A direction from `wo` by a random walk through the stack: `uc` and `u` choose the
    /// first scattering at the coat, and key the stream of the rest.
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2, mode: Transport) -> Option<WalkSample> {
        let side = if wo.z < 0.0 { -1.0 } else { 1.0 };
        let wo = wo * side;
        let bs = self.top.sample(wo, uc, u, mode, Lobes::All)?;
        if bs.wi.z > 0.0 {
            return Some(WalkSample {
                wi: bs.wi * side,
                weight: bs.f * bs.wi.z / bs.pdf,
                pdf: bs.pdf,
                specular: bs.specular,
            });
        }
        let [a, b] = key(wo);
        let mut rng = Rng::for_key(
            SAMPLE_KEY,
            &[
                a,
                b,
                uc.to_bits() as u64,
                (u.x.to_bits() as u64) << 32 | u.y.to_bits() as u64,
            ],
        );
        let mut specular = bs.specular;
        let mut f = bs.f * bs.wi.z.abs();
        let mut pdf = bs.pdf;
        let mut z = self.thickness;
        let mut w = bs.wi;
        for depth in 0..self.max_depth {
            let rr_beta = f.max_element() / pdf;
            if depth > 3 && rr_beta < 0.25 {
                let q = (1.0 - rr_beta).max(0.0);
                if next(&mut rng) < q {
                    return None;
                }
                pdf *= 1.0 - q;
            }
            if w.z == 0.0 {
                return None;
            }
            if self.has_medium() {
                let dz = -(1.0 - next(&mut rng)).ln() * w.z.abs();
                let zp = if w.z > 0.0 { z + dz } else { z - dz };
                if zp == z {
                    return None;
                }
                if 0.0 < zp && zp < self.thickness {
                    let (wp, pp) = sample_hg(-w, self.g, next2(&mut rng));
                    if pp == 0.0 || wp.z == 0.0 {
                        return None;
                    }
                    f *= self.albedo * pp;
                    pdf *= pp;
                    specular = false;
                    w = wp;
                    z = zp;
                    continue;
                }
                z = zp.clamp(0.0, self.thickness);
            } else {
                z = if z == self.thickness {
                    0.0
                } else {
                    self.thickness
                };
                f *= tr(self.thickness, w);
            }
            let interface = if z == 0.0 { &self.bottom } else { &self.top };
            let uc = next(&mut rng);
            let bs: LayerSample = interface.sample(-w, uc, next2(&mut rng), mode, Lobes::All)?;
            let transmitted = -w.z * bs.wi.z < 0.0;
            f *= bs.f;
            pdf *= bs.pdf;
            specular &= bs.specular;
            w = bs.wi;
            if transmitted {
                // Out through the coat.
                return Some(WalkSample {
                    wi: w * side,
                    weight: f * w.z.abs() / pdf,
                    pdf,
                    specular,
                });
            }
            f *= bs.wi.z.abs();
        }
        None
    }
}
