//! Whitted's classic material (eq. 2 of the paper): I = ka·Ia + kd Σ(N·Lj) + ks S + kt T,
//! with a Phong highlight for point lights, extended by the coefficients the other
//! techniques share: Lambertian transmission, GGX roughness, Fresnel weighting, thin
//! sheets and metals. It is what the native format's plain material keys describe, and the
//! approximation every other material gives the techniques that are not Monte Carlo
//! (Whitted's integrator, the irradiance cache's diffuse part, the illumination network's
//! lobes): [`SurfaceModel::approximation`].
//!
//! Its BSDF for the Monte Carlo techniques interprets the coefficients as the lobes of
//! [`crate::bsdf`]: kd/π, kdt/π, ks mirror or GGX reflection, kt smooth or GGX refraction.

use super::SurfaceModel;
use crate::bsdf::{Bsdf, Coating, Conductor, Lobes, SpectralParts};
use crate::math::{Rgb, Vec2, Vec3};
use crate::scene::{SurfacePoint, Texture};
use std::sync::Arc;

/// Whitted's material with raylink's extensions (see the module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct Classic {
    /// kd: diffuse reflectance.
    pub diffuse: Texture,
    /// ka: ambient reflectance; `None` means "the diffuse colour", the usual choice.
    pub ambient: Option<Rgb>,
    /// ks: specular (mirror) reflection coefficient; also scales the Phong highlight. With
    /// `specular_map` it is the map's largest value (for the illumination network).
    pub specular: Rgb,
    /// A ks varying over the surface, in place of `specular` where a ray hits.
    pub specular_map: Option<Texture>,
    /// kt: transmission coefficient.
    pub transmission: Rgb,
    /// Lambertian transmission to the other side (a thin translucent sheet: paper, leaves,
    /// a lampshade), kdt/π; pbrt's `diffusetransmission`. The Monte Carlo integrators and
    /// the irradiance cache use it.
    pub diffuse_transmission: Texture,
    /// Index of refraction of the material's inside (outside is vacuum, 1).
    pub ior: f32,
    /// Exponent n of the Phong highlight.
    pub phong_exponent: f32,
    /// Microfacet roughness, GGX α: the Monte Carlo integrators use GGX reflection (and
    /// refraction, for a transmissive material) lobes;
    /// Whitted's integrator draws the normal of each reflected or refracted ray from the GGX
    /// distribution (glossy reflection, frosted transmission). 0 is a perfect mirror or
    /// clear glass.
    pub roughness: f32,
    /// GGX α along the shading frame's bitangent when it differs from `roughness` (then α
    /// along the tangent): an anisotropic lobe. `None` is isotropic.
    pub roughness_v: Option<f32>,
    /// When true, ks and kt are weighted by the Fresnel reflectance at the hit.
    pub fresnel: bool,
    /// A thin sheet (a window pane, a soap film; pbrt's `thindielectric`): both sides are
    /// outside, kt passes light straight through without bending it (no refraction, no η²),
    /// and with `fresnel` ks and kt are weighted by the sheet's reflectance R and 1 − R,
    /// which sum the light bouncing between its two faces. The sheet is smooth: roughness is
    /// ignored.
    pub thin: bool,
    /// A metal: ks is weighted by the conductor Fresnel reflectance of this complex index
    /// (instead of the dielectric one or none).
    pub conductor: Option<Conductor>,
    /// A conductor given by its normal-incidence reflectance varying over the surface
    /// (pbrt's textured `reflectance`): at each hit, [`Conductor::from_reflectance`] of the
    /// map's value in place of `conductor` (which is that of the map's largest value).
    pub reflectance_map: Option<Texture>,
    /// A roughness that varies over the surface, in place of `roughness` and `roughness_v`
    /// for the Monte Carlo integrators (the other techniques use those, set to the map's
    /// largest value).
    pub roughness_map: Option<Arc<RoughnessMap>>,
    /// A glass's dispersion and a metal's measured index, for spectral renders.
    pub spectral: SpectralParts,
}

/// A roughness given by textures (pbrt's textured `roughness`, `uroughness`, `vroughness`).
#[derive(Clone, Debug, PartialEq)]
pub struct RoughnessMap {
    /// The roughness along the tangent, and along the bitangent too when `v` is `None`.
    pub u: Texture,
    pub v: Option<Texture>,
    /// The textures give pbrt's roughness r, and GGX α = √r (pbrt's `remaproughness`);
    /// otherwise they give α.
    pub remap: bool,
}

impl RoughnessMap {
    /// GGX (α_x, α_y) at position `p`, texture coordinates `uv`, geometric normal `n`.
    pub fn alphas(&self, p: Vec3, uv: Vec2, n: Vec3) -> (f32, f32) {
        let alpha = |t: &Texture| {
            let r = t.eval_float(p, uv, n).max(0.0);
            if self.remap {
                r.sqrt()
            } else {
                r
            }
        };
        let ax = alpha(&self.u);
        (ax, self.v.as_ref().map_or(ax, alpha))
    }

    /// The largest α the map gives (for the techniques that take one roughness).
    pub fn max_alpha(&self) -> f32 {
        let top = |t: &Texture| {
            let r = t.max_value().x.max(0.0);
            if self.remap {
                r.sqrt()
            } else {
                r
            }
        };
        top(&self.u).max(self.v.as_ref().map_or(0.0, top))
    }
}

impl Default for Classic {
    fn default() -> Self {
        Classic {
            diffuse: Texture::Constant(Rgb::splat(0.5)),
            ambient: None,
            specular: Rgb::ZERO,
            specular_map: None,
            transmission: Rgb::ZERO,
            diffuse_transmission: Texture::Constant(Rgb::ZERO),
            ior: 1.5,
            phong_exponent: 50.0,
            roughness: 0.0,
            roughness_v: None,
            fresnel: false,
            thin: false,
            conductor: None,
            reflectance_map: None,
            roughness_map: None,
            spectral: SpectralParts::default(),
        }
    }
}

impl Classic {
    /// A surface with no lobe (black): the base the other kinds set their lobes on.
    pub fn blank() -> Classic {
        Classic {
            diffuse: Texture::Constant(Rgb::ZERO),
            ..Classic::default()
        }
    }

    /// ks at position `p`, surface coordinates `uv`, geometric normal `n`.
    pub fn specular_at(&self, p: Vec3, uv: Vec2, n: Vec3) -> Rgb {
        match &self.specular_map {
            Some(t) => t.eval(p, uv, n),
            None => self.specular,
        }
    }

    /// The conductor at position `p`, surface coordinates `uv`, geometric normal `n`.
    pub fn conductor_at(&self, p: Vec3, uv: Vec2, n: Vec3) -> Option<Conductor> {
        match &self.reflectance_map {
            Some(t) => Some(Conductor::from_reflectance(t.eval(p, uv, n))),
            None => self.conductor,
        }
    }

    pub fn is_transmissive(&self) -> bool {
        self.transmission.max_element() > 0.0
    }

    /// GGX (α_x, α_y).
    pub fn alphas(&self) -> (f32, f32) {
        (self.roughness, self.roughness_v.unwrap_or(self.roughness))
    }

    /// ks with a conductor's (or a thin sheet's) Fresnel reflectance at normal incidence
    /// folded in: the specular coefficient for the techniques that have no angular Fresnel.
    pub fn specular_at_normal(&self) -> Rgb {
        match self.conductor {
            Some(c) => self.specular * c.reflectance(1.0),
            None if self.thin_fresnel() => self.specular * self.thin_reflectance(1.0),
            None => self.specular,
        }
    }

    /// kt with a thin sheet's Fresnel transmittance at normal incidence folded in (as
    /// [`Classic::specular_at_normal`]).
    pub fn transmission_at_normal(&self) -> Rgb {
        if self.thin_fresnel() {
            self.transmission * (1.0 - self.thin_reflectance(1.0))
        } else {
            self.transmission
        }
    }

    fn thin_fresnel(&self) -> bool {
        self.thin && self.fresnel
    }

    /// The thin sheet's reflectance R at incidence cosine `cos` (either side).
    pub fn thin_reflectance(&self, cos: f32) -> f32 {
        crate::math::optics::fresnel_thin_dielectric(cos, self.ior)
    }

    /// Whether only the Lambertian lobe is anywhere on the surface.
    pub fn is_lambertian(&self) -> bool {
        !self.fresnel
            && self.specular.max_element() <= 0.0
            && self.transmission.max_element() <= 0.0
            && self.diffuse_transmission.max_value().max_element() <= 0.0
    }

    /// The BSDF's lobes at `sp`: the textures evaluated there.
    pub fn lobes_at(&self, sp: &SurfacePoint) -> Lobes {
        let alphas = match &self.roughness_map {
            Some(map) => map.alphas(sp.p, sp.uv, sp.ng),
            None => self.alphas(),
        };
        Lobes {
            kd: self.diffuse.eval(sp.p, sp.uv, sp.ng),
            kdt: self.diffuse_transmission.eval(sp.p, sp.uv, sp.ng),
            ks: self.specular_at(sp.p, sp.uv, sp.ng),
            kt: self.transmission,
            ior: self.ior,
            alphas,
            fresnel: self.fresnel,
            thin: self.thin,
            conductor: self.conductor_at(sp.p, sp.uv, sp.ng),
            lambertian: self.is_lambertian(),
            spectral: self.spectral,
        }
    }

    /// The lobes' BSDF at `sp` for a path arriving from `wo`.
    pub fn lobe_bsdf(&self, sp: &SurfacePoint, wo: Vec3) -> Bsdf<'static> {
        let (n, ng) = Bsdf::facing(self.is_transmissive(), sp.ns, sp.ng, wo);
        Bsdf::of_lobes(&self.lobes_at(sp), n, ng)
    }

    /// The BSDF of `coating` over these lobes at `sp` for a path arriving from `wo`.
    pub fn coated_bsdf<'a>(&self, coating: &'a Coating, sp: &SurfacePoint, wo: Vec3) -> Bsdf<'a> {
        let (n, ng) = Bsdf::facing(self.is_transmissive(), sp.ns, sp.ng, wo);
        Bsdf::coated(&self.lobes_at(sp), coating, n, ng)
    }
}

impl SurfaceModel for Classic {
    fn kind(&self) -> &'static str {
        "classic"
    }

    fn bsdf<'a>(&'a self, sp: &SurfacePoint, wo: Vec3) -> Bsdf<'a> {
        self.lobe_bsdf(sp, wo)
    }

    fn approximation(&self) -> &Classic {
        self
    }

    fn diffuse_mut(&mut self) -> Option<&mut Texture> {
        Some(&mut self.diffuse)
    }
}
