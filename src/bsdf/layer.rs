//! The two interfaces of a layered BSDF ([`super::layered`]) as pbrt-v4's `LayeredBxDF`
//! drives them: each evaluates, gives the density of and samples its own scattering from
//! either side, optionally restricted to reflection or to transmission (pbrt's
//! `BxDFReflTransFlags`). The top is a dielectric coat, smooth or GGX (the rough case is
//! [`RoughInterface`]); the base is a Lambertian reflector or a conductor, smooth or GGX.
//!
//! Directions are in the layer's local frame (+z up, out of the coat), pointing away from
//! the interface; `wo` may be on either side.

use super::dielectric::RoughInterface;
use super::Conductor;
use super::{mirror, Ggx, Transport};
use crate::math::optics::{fresnel_dielectric, refract};
use crate::math::warp::{cosine_hemisphere, cosine_hemisphere_pdf};
use crate::math::{Rgb, Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Which of an interface's lobes a sample or a density covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Lobes {
    All,
    Reflection,
    Transmission,
}

impl Lobes {
    fn reflects(self) -> bool {
        self != Lobes::Transmission
    }

    fn transmits(self) -> bool {
        self != Lobes::Reflection
    }
}

/// A direction sampled at an interface: f (no cosine), its density (for a delta lobe, the
/// probability of choosing it) and whether it is a delta.
#[derive(Clone, Copy, Debug)]
pub(super) struct LayerSample {
    pub f: Rgb,
    pub wi: Vec3,
    pub pdf: f32,
    pub specular: bool,
}

impl LayerSample {
    /// Whether the sample is usable (pbrt's `!bs || !bs->f || bs->pdf == 0 || wi.z == 0`).
    fn valid(self) -> Option<LayerSample> {
        (self.f.max_element() > 0.0 && self.pdf > 0.0 && self.wi.z != 0.0).then_some(self)
    }
}

/// One interface of the stack.
#[derive(Clone, Copy, Debug)]
pub(super) enum Layer {
    /// A dielectric of index `ior` below (inside the coat) and 1 above.
    Dielectric { ior: f32, ggx: Option<Ggx> },
    /// Lambertian reflection r/π on both sides.
    Diffuse(Rgb),
    /// A metal of complex index relative to the medium above it.
    Conductor { c: Conductor, ggx: Option<Ggx> },
}

impl Layer {
    /// Whether the interface scatters only in delta directions.
    pub fn specular(&self) -> bool {
        match self {
            Layer::Dielectric { ggx, .. } | Layer::Conductor { ggx, .. } => ggx.is_none(),
            Layer::Diffuse(_) => false,
        }
    }

    /// The rough dielectric seen from `wo`'s side (flipped to the upper side), with the lobes
    /// `lobes` allows.
    fn rough_dielectric(ior: f32, ggx: Ggx, wo: Vec3, lobes: Lobes) -> RoughInterface {
        let on = |b: bool| if b { Rgb::ONE } else { Rgb::ZERO };
        RoughInterface {
            ggx,
            ks: on(lobes.reflects()),
            kt: on(lobes.transmits()),
            fresnel: true,
            eta: if wo.z > 0.0 { 1.0 / ior } else { ior },
        }
    }

    /// f(wo, wi) of the non-delta lobes, no cosine.
    pub fn f(&self, wo: Vec3, wi: Vec3, mode: Transport) -> Rgb {
        let s = if wo.z < 0.0 { -1.0 } else { 1.0 };
        let (lo, li) = (wo * s, wi * s);
        match *self {
            Layer::Dielectric {
                ior,
                ggx: Some(ggx),
            } => Self::rough_dielectric(ior, ggx, wo, Lobes::All).eval(lo, li, mode),
            Layer::Diffuse(r) if li.z > 0.0 => r * FRAC_1_PI,
            Layer::Conductor { c, ggx: Some(ggx) } if li.z > 0.0 && lo.z > 0.0 => {
                let h = (lo + li).normalize();
                c.reflectance(lo.dot(h).abs()) * (ggx.d(h) * ggx.g(lo, li) / (4.0 * lo.z * li.z))
            }
            _ => Rgb::ZERO,
        }
    }

    /// Density of [`Layer::sample`] with `lobes` producing `wi` through a non-delta lobe
    /// (the same in both transport modes).
    pub fn pdf(&self, wo: Vec3, wi: Vec3, lobes: Lobes) -> f32 {
        let s = if wo.z < 0.0 { -1.0 } else { 1.0 };
        let (lo, li) = (wo * s, wi * s);
        match *self {
            Layer::Dielectric {
                ior,
                ggx: Some(ggx),
            } => Self::rough_dielectric(ior, ggx, wo, lobes).pdf(lo, li, 1.0),
            Layer::Diffuse(_) if li.z > 0.0 && lobes.reflects() => cosine_hemisphere_pdf(li.z),
            Layer::Conductor { ggx: Some(ggx), .. }
                if li.z > 0.0 && lo.z > 0.0 && lobes.reflects() =>
            {
                let h = (lo + li).normalize();
                ggx.visible_pdf(lo, h) / (4.0 * lo.dot(h).abs())
            }
            _ => 0.0,
        }
    }

    /// A direction from `wo` among `lobes`: `uc` chooses between reflection and
    /// transmission, `u` the direction.
    pub fn sample(
        &self,
        wo: Vec3,
        uc: f32,
        u: Vec2,
        mode: Transport,
        lobes: Lobes,
    ) -> Option<LayerSample> {
        let s = if wo.z < 0.0 { -1.0 } else { 1.0 };
        let lo = wo * s;
        if lo.z == 0.0 {
            return None;
        }
        let flip = |x: LayerSample| LayerSample { wi: x.wi * s, ..x };
        let sample = match *self {
            Layer::Dielectric { ior, ggx: None } => {
                let eta = if wo.z > 0.0 { 1.0 / ior } else { ior };
                smooth_dielectric(eta, lo, uc, mode, lobes)?
            }
            Layer::Dielectric {
                ior,
                ggx: Some(ggx),
            } => {
                let chosen = Self::rough_dielectric(ior, ggx, wo, lobes);
                let li = chosen.sample(lo, uc, u)?;
                LayerSample {
                    f: Self::rough_dielectric(ior, ggx, wo, Lobes::All).eval(lo, li, mode),
                    wi: li,
                    pdf: chosen.pdf(lo, li, 1.0),
                    specular: false,
                }
            }
            _ if !lobes.reflects() => return None,
            Layer::Diffuse(r) => {
                let li = cosine_hemisphere(u);
                LayerSample {
                    f: r * FRAC_1_PI,
                    wi: li,
                    pdf: cosine_hemisphere_pdf(li.z),
                    specular: false,
                }
            }
            Layer::Conductor { c, ggx: None } => {
                let li = mirror(lo);
                LayerSample {
                    f: c.reflectance(lo.z) / li.z,
                    wi: li,
                    pdf: 1.0,
                    specular: true,
                }
            }
            Layer::Conductor { ggx: Some(ggx), .. } => {
                let h = ggx.sample_visible(lo, u);
                let li = 2.0 * lo.dot(h) * h - lo;
                if li.z <= 0.0 {
                    return None;
                }
                LayerSample {
                    f: self.f(lo, li, mode),
                    wi: li,
                    pdf: self.pdf(lo, li, lobes),
                    specular: false,
                }
            }
        };
        sample.valid().map(flip)
    }
}

/// A smooth dielectric's mirror reflection (probability F) or refraction (1 − F), among
/// `lobes`, from `lo` flipped to the upper side with `eta` = n_wo / n_other; the
/// (n_wo/n_other)² radiance scaling of refraction in radiance transport.
fn smooth_dielectric(
    eta: f32,
    lo: Vec3,
    uc: f32,
    mode: Transport,
    lobes: Lobes,
) -> Option<LayerSample> {
    let r = fresnel_dielectric(lo.z, eta);
    let pr = if lobes.reflects() { r } else { 0.0 };
    let pt = if lobes.transmits() { 1.0 - r } else { 0.0 };
    if pr + pt <= 0.0 {
        return None;
    }
    if uc < pr / (pr + pt) {
        let li = mirror(lo);
        return Some(LayerSample {
            f: Rgb::splat(r / li.z),
            wi: li,
            pdf: pr / (pr + pt),
            specular: true,
        });
    }
    let li = refract(-lo, Vec3::Z, eta)?;
    let mut ft = (1.0 - r) / li.z.abs();
    if mode == Transport::Radiance {
        ft *= eta * eta;
    }
    Some(LayerSample {
        f: Rgb::splat(ft),
        wi: li,
        pdf: pt / (pr + pt),
        specular: true,
    })
}
