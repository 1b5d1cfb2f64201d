//! Materials: how a surface scatters light, one interface ([`SurfaceModel`]) and one file a
//! kind of surface, all of them listed in [`Surface`].
//!
//! A kind of surface gives the Monte Carlo techniques its BSDF at a hit, and the other
//! techniques (Whitted's integrator, the irradiance cache's diffuse part, the illumination
//! network's lobes) its approximation in Whitted's classic terms ([`Classic`]), in the same
//! file, so that one file holds everything about it. A [`Material`] is a named surface
//! with what else a shape's material carries: its emission (an area light's radiance) and
//! a normal or bump map.
//!
//! Adding a kind of surface: its own file here with a type implementing [`SurfaceModel`],
//! a variant of [`Surface`] and its line in [`Surface::model`], its readers (native TOML,
//! pbrt) and writer (`convert`), its tests and docs (`docs/dev/architecture.md`).
//!
//! Batches: every method takes one point; a wavefront integrator evaluates a batch of hits
//! by sorting them by material index and calling [`Surface::model`] once per run of equal
//! indices (the variants are plain data: their lobes can be gathered into arrays per kind).

mod classic;
mod coated_conductor;
mod coated_diffuse;
mod conductor;
mod dielectric;
mod diffuse;
mod diffuse_transmission;
mod interface;
mod measured;
mod mix;
mod thin_dielectric;

pub use classic::{Classic, RoughnessMap};
pub use coated_conductor::CoatedConductor;
pub use coated_diffuse::CoatedDiffuse;
pub use conductor::Metal;
pub use dielectric::Dielectric;
pub use diffuse::Diffuse;
pub use diffuse_transmission::DiffuseTransmission;
pub use interface::Interface;
pub use measured::Measured;
pub use mix::Mix;
pub use thin_dielectric::ThinDielectric;

use super::{NormalDetail, SurfacePoint, Texture};
use crate::bsdf::{Bsdf, TabulatedBrdf};
use crate::math::{Rgb, Vec2, Vec3};
use crate::spectrum::BlackbodyEmission;
use std::sync::Arc;

/// What every kind of surface answers.
pub trait SurfaceModel {
    /// The kind's name, as the native format and pbrt-v4 call it (`"diffuse"`, ...).
    fn kind(&self) -> &'static str;

    /// The BSDF at `sp` for a path arriving from `wo` (pointing away from the surface).
    fn bsdf<'a>(&'a self, sp: &SurfacePoint, wo: Vec3) -> Bsdf<'a>;

    /// The surface in Whitted's classic terms, for the techniques that are not Monte Carlo:
    /// Whitted's integrator reads its reflection ks, transmission kt (with ior, Fresnel,
    /// thin sheet, metal) and Phong highlight; the irradiance cache its diffuse kd and kdt;
    /// the illumination network its kd and its directional ks, kt, kdt lobes.
    fn approximation(&self) -> &Classic;

    /// The diffuse reflectance kd that relighting recolours (the studio's material
    /// colours, the network's reflectance series); `None` for kinds without one.
    fn diffuse_mut(&mut self) -> Option<&mut Texture>;

    /// A tabulated reflectance that Whitted's integrator (in place of kd) and the
    /// illumination network (in place of the directional lobes) scatter by; `None` for
    /// every kind but a measured one.
    fn table(&self) -> Option<&Arc<TabulatedBrdf>> {
        None
    }
}

/// Every kind of surface raylink renders: the one list of them.
#[derive(Clone, Debug, PartialEq)]
pub enum Surface {
    /// Whitted's material with raylink's extensions: what the native format's plain keys
    /// describe.
    Classic(Classic),
    Diffuse(Diffuse),
    DiffuseTransmission(DiffuseTransmission),
    Conductor(Metal),
    Dielectric(Dielectric),
    ThinDielectric(ThinDielectric),
    CoatedDiffuse(CoatedDiffuse),
    CoatedConductor(CoatedConductor),
    Measured(Measured),
    Mix(Mix),
    /// The boundary of a medium, and nothing else.
    Interface(Interface),
}

impl Surface {
    /// The kind's implementation of the interface.
    pub fn model(&self) -> &dyn SurfaceModel {
        match self {
            Surface::Classic(s) => s,
            Surface::Diffuse(s) => s,
            Surface::DiffuseTransmission(s) => s,
            Surface::Conductor(s) => s,
            Surface::Dielectric(s) => s,
            Surface::ThinDielectric(s) => s,
            Surface::CoatedDiffuse(s) => s,
            Surface::CoatedConductor(s) => s,
            Surface::Measured(s) => s,
            Surface::Mix(s) => s,
            Surface::Interface(s) => s,
        }
    }

    /// [`Surface::model`], to change.
    pub fn model_mut(&mut self) -> &mut dyn SurfaceModel {
        match self {
            Surface::Classic(s) => s,
            Surface::Diffuse(s) => s,
            Surface::DiffuseTransmission(s) => s,
            Surface::Conductor(s) => s,
            Surface::Dielectric(s) => s,
            Surface::ThinDielectric(s) => s,
            Surface::CoatedDiffuse(s) => s,
            Surface::CoatedConductor(s) => s,
            Surface::Measured(s) => s,
            Surface::Mix(s) => s,
            Surface::Interface(s) => s,
        }
    }
}

/// A shape's material: a named surface, its emission and its normal detail.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    pub surface: Surface,
    /// Emitted radiance; a shape with a non-zero emission is an area light. With
    /// `emission_map` it is the map's mean (for the illumination network).
    pub emission: Rgb,
    /// Emitted radiance varying over the surface, in place of `emission` at each point.
    pub emission_map: Option<Texture>,
    /// The spectrum of the emission in spectral renders when it is a blackbody's (then
    /// `emission` is its RGB times the luminance, and there is no map); `None`: the
    /// spectrum of `emission`'s RGB.
    pub emission_spectrum: Option<BlackbodyEmission>,
    /// Emit on both sides of the surface (pbrt's `twosided` area lights), not only on the
    /// side the geometric normal faces.
    pub two_sided_emission: bool,
    /// A normal map or bump map turning the shading normal.
    pub normal_detail: Option<NormalDetail>,
}

impl Default for Material {
    /// A grey Lambertian classic surface that does not emit.
    fn default() -> Self {
        Material::new("", Surface::Classic(Classic::default()))
    }
}

impl Material {
    /// A material named `name` of surface `surface`, emitting nothing, without normal detail.
    pub fn new(name: impl Into<String>, surface: Surface) -> Material {
        Material {
            name: name.into(),
            surface,
            emission: Rgb::ZERO,
            emission_map: None,
            emission_spectrum: None,
            two_sided_emission: false,
            normal_detail: None,
        }
    }

    /// A classic material (Whitted's coefficients) named `name`.
    pub fn classic(name: impl Into<String>, classic: Classic) -> Material {
        Material::new(name, Surface::Classic(classic))
    }

    /// This material emitting `emission` from the front.
    pub fn emitting(self, emission: Rgb) -> Material {
        Material { emission, ..self }
    }

    /// The kind of surface's implementation of the interface.
    pub fn model(&self) -> &dyn SurfaceModel {
        self.surface.model()
    }

    /// The BSDF at `sp` for a path arriving from `wo` ([`SurfaceModel::bsdf`]).
    pub fn bsdf(&self, sp: &SurfacePoint, wo: Vec3) -> Bsdf<'_> {
        self.model().bsdf(sp, wo)
    }

    /// The surface in Whitted's terms ([`SurfaceModel::approximation`]).
    pub fn approximation(&self) -> &Classic {
        self.model().approximation()
    }

    /// The diffuse reflectance relighting recolours ([`SurfaceModel::diffuse_mut`]).
    pub fn diffuse_mut(&mut self) -> Option<&mut Texture> {
        self.surface.model_mut().diffuse_mut()
    }

    /// The mix, if the surface is one.
    pub fn mix(&self) -> Option<&Mix> {
        match &self.surface {
            Surface::Mix(m) => Some(m),
            _ => None,
        }
    }

    /// Whether the surface only bounds a medium (rays pass through it unchanged).
    pub fn is_interface(&self) -> bool {
        matches!(self.surface, Surface::Interface(_))
    }

    /// Whether light passes through the surface (orientation then tells inside from out).
    pub fn is_transmissive(&self) -> bool {
        self.approximation().is_transmissive()
    }

    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }

    /// Whether the surface emits towards `wo` (pointing away from it), given its geometric
    /// normal `ng`.
    pub(crate) fn emits_towards(&self, wo: Vec3, ng: Vec3) -> bool {
        self.is_emissive() && (self.two_sided_emission || wo.dot(ng) > 0.0)
    }

    /// Emitted radiance at position `p`, surface coordinates `uv`, geometric normal `n`.
    pub(crate) fn emission_at(&self, p: Vec3, uv: Vec2, n: Vec3) -> Rgb {
        match &self.emission_map {
            Some(t) => t.eval(p, uv, n).max(Rgb::ZERO),
            None => self.emission,
        }
    }
}
