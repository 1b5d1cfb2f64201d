use super::mix::Mix;
use super::normal_detail::NormalDetail;
use super::texture::Texture;
use crate::math::{Rgb, Vec2, Vec3};
use crate::scene::tabulated::TabulatedBrdf;
use std::sync::Arc;

/// A surface in Whitted's model (eq. 2 of the paper): I = ka·Ia + kd Σ(N·Lj) + ks S + kt T,
/// with a Phong highlight for point lights, plus emission for area lights.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
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
    /// Emitted radiance; a shape with a non-zero emission is an area light. With
    /// `emission_map` it is the map's mean (for the illumination network).
    pub emission: Rgb,
    /// Emitted radiance varying over the surface, in place of `emission` at each point.
    pub emission_map: Option<Texture>,
    /// Emit on both sides of the surface (pbrt's `twosided` area lights), not only on the
    /// side the geometric normal faces.
    pub two_sided_emission: bool,
    /// A mix of two other materials, one chosen at each hit ([`Mix`]); the fields above are
    /// then those of the one with the larger weight.
    pub mix: Option<Mix>,
    /// A tabulated reflectance in place of the diffuse, specular and transmission lobes (an
    /// opaque surface reflecting on both sides).
    pub brdf: Option<Arc<TabulatedBrdf>>,
    /// A roughness that varies over the surface, in place of `roughness` and `roughness_v`
    /// for the Monte Carlo integrators (the other techniques use those, set to the map's
    /// largest value).
    pub roughness_map: Option<Arc<RoughnessMap>>,
    /// A normal map or bump map turning the shading normal.
    pub normal_detail: Option<NormalDetail>,
    /// A dielectric coat over the material's base: its diffuse kd, or its conductor (with
    /// `roughness`) when it has one. The Monte Carlo integrators then use the layered BSDF
    /// ([`Coating`]); the other fields stay what the approximating techniques read.
    pub coating: Option<Coating>,
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

impl Default for Material {
    fn default() -> Self {
        Material {
            name: String::new(),
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
            emission: Rgb::ZERO,
            emission_map: None,
            two_sided_emission: false,
            mix: None,
            brdf: None,
            roughness_map: None,
            normal_detail: None,
            coating: None,
        }
    }
}

impl Material {
    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }

    /// Whether the surface emits towards `wo` (pointing away from it), given its geometric
    /// normal `ng`.
    pub fn emits_towards(&self, wo: Vec3, ng: Vec3) -> bool {
        self.is_emissive() && (self.two_sided_emission || wo.dot(ng) > 0.0)
    }

    /// Emitted radiance at position `p`, surface coordinates `uv`, geometric normal `n`.
    pub fn emission_at(&self, p: Vec3, uv: Vec2, n: Vec3) -> Rgb {
        match &self.emission_map {
            Some(t) => t.eval(p, uv, n).max(Rgb::ZERO),
            None => self.emission,
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
    /// [`Material::specular_at_normal`]).
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
}

/// A dielectric coat over a base (pbrt-v4's `coateddiffuse` and `coatedconductor`): light
/// refracts into a slab of index `ior` and `thickness`, bounces between the base and the coat
/// (absorbed along the way, optionally scattered by a medium), and leaves through the coat.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coating {
    /// Index of refraction of the coat (outside is vacuum).
    pub ior: f32,
    /// GGX α of the coat's interface; 0 is smooth.
    pub roughness: f32,
    /// GGX α along the bitangent when it differs from `roughness`.
    pub roughness_v: Option<f32>,
    /// Thickness in units of the medium's mean free path: light crossing it at angle θ keeps
    /// exp(−thickness/|cos θ|).
    pub thickness: f32,
    /// Single-scattering albedo of the medium in the coat; 0 is an absorbing, non-scattering
    /// coat.
    pub albedo: Rgb,
    /// Henyey–Greenstein asymmetry of the medium's scattering.
    pub g: f32,
    /// Longest random walk through the layers.
    pub max_depth: u32,
    /// Random walks per evaluation.
    pub samples: u32,
}

impl Default for Coating {
    /// pbrt-v4's defaults: a smooth coat of index 1.5 and thickness 0.01.
    fn default() -> Self {
        Coating {
            ior: 1.5,
            roughness: 0.0,
            roughness_v: None,
            thickness: 0.01,
            albedo: Rgb::ZERO,
            g: 0.0,
            max_depth: 10,
            samples: 1,
        }
    }
}

impl Coating {
    /// GGX (α_x, α_y) of the coat.
    pub fn alphas(&self) -> (f32, f32) {
        (self.roughness, self.roughness_v.unwrap_or(self.roughness))
    }
}

/// A conductor's complex index of refraction η + ik, per colour channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conductor {
    pub eta: Rgb,
    pub k: Rgb,
}

/// RGB (η, k) of the named metals: the widely used reductions of the measured spectra that
/// pbrt-v4 ships as `metal-<name>-eta` / `metal-<name>-k` (the values of pbrt-v3's and
/// Mitsuba's RGB builds).
const METALS: &[(&str, [f32; 3], [f32; 3])] = &[
    (
        "Cu",
        [0.200438, 0.924033, 1.10221],
        [3.91295, 2.45285, 2.14219],
    ),
    (
        "Au",
        [0.143119, 0.374957, 1.44248],
        [3.98316, 2.38572, 1.60322],
    ),
    (
        "Ag",
        [0.155265, 0.116723, 0.138342],
        [4.82835, 3.12225, 2.14696],
    ),
    (
        "Al",
        [1.65746, 0.880369, 0.521229],
        [9.22387, 6.26952, 4.837],
    ),
    ("CuZn", [0.444, 0.527, 1.094], [3.695, 2.765, 1.829]),
    ("MgO", [1.732, 1.736, 1.745], [0.0, 0.0, 0.0]),
    ("TiO2", [2.557, 2.651, 2.811], [0.0, 0.0, 0.0]),
];

impl Conductor {
    /// A named metal ("Cu", "Au", "Ag", "Al", "CuZn", "MgO", "TiO2"), `None` if unknown.
    pub fn named(name: &str) -> Option<Conductor> {
        METALS
            .iter()
            .find(|m| m.0 == name)
            .map(|&(_, eta, k)| Conductor {
                eta: Rgb::from(eta),
                k: Rgb::from(k),
            })
    }

    /// The names [`Conductor::named`] knows.
    pub fn names() -> impl Iterator<Item = &'static str> {
        METALS.iter().map(|m| m.0)
    }

    /// The conductor with normal-incidence reflectance `r` and no other parameter: η = 1,
    /// k = 2√r / √(1 − r) (pbrt-v4's `ConductorMaterial` given a `reflectance`).
    pub fn from_reflectance(r: Rgb) -> Conductor {
        let k = |r: f32| {
            let r = r.clamp(0.0, 0.9999);
            2.0 * r.sqrt() / (1.0 - r).sqrt()
        };
        Conductor {
            eta: Rgb::ONE,
            k: Rgb::new(k(r.x), k(r.y), k(r.z)),
        }
    }

    /// Fresnel reflectance per channel at incidence cosine `cos`.
    pub fn reflectance(&self, cos: f32) -> Rgb {
        crate::math::optics::fresnel_conductor(cos, self.eta, self.k)
    }
}
