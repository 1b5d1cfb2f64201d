//! Lights: one interface ([`LightModel`]) and one file a kind of light, for every
//! technique. The scene's own lights ([`Light`]: point, spot, goniometric, directional,
//! projection) are listed in the scene; area lights ([`AreaLight`]) are made from emissive shapes and the
//! background ([`Background`]) from the scene's environment or constant background.
//! [`LightSet`] holds them all for the Monte Carlo techniques and chooses among them by
//! power.
//!
//! A kind of light answers, in its own file: its power, next-event samples towards a point
//! (`sample_li`, with `pdf_li` for multiple importance sampling), the start of a light path
//! (`sample_le`), and what Whitted's integrator takes of it (`illuminate`).
//!
//! Adding a kind of light: its own file here with a type implementing [`LightModel`] (or,
//! for a light at one point, [`PointSource`], from which the interface follows), a
//! variant of [`Light`] and its line in [`Light::model`], its readers and `convert`, its
//! tests and docs.

mod area;
mod background;
mod bounds;
mod directional;
mod env_facing;
mod goniometric;
mod point;
mod point_source;
mod portal_sampling;
mod projection;
mod set;
mod spot;
mod tree;

pub use area::{AreaLight, LightPoint};
pub use background::{Background, EnvironmentSampler};
pub use bounds::{DirectionCone, LightBounds};
pub use directional::DirectionalLight;
pub use goniometric::{GoniometricLight, GoniometricMap};
pub use point::PointLight;
pub use point_source::PointSource;
pub use projection::ProjectionLight;
pub use set::{Emitter, LightSet, Selection, SelectionKind};
pub use spot::{check_cone_width, spot_cosines, spot_falloff, spot_solid_angle, SpotLight};
pub use tree::LightTree;

use crate::math::spawn::Spot;
use crate::math::{Rgb, Vec2, Vec3};
use crate::spectrum::BlackbodyEmission;

/// The sphere bounding the scene (and the camera): infinite and directional lights emit
/// from its disk, and their shadow rays end beyond it.
#[derive(Clone, Copy, Debug)]
pub struct World {
    pub center: Vec3,
    pub radius: f32,
}

/// What every kind of light answers.
pub trait LightModel {
    /// The light's power as light selection weighs it (the luminance of its flux).
    fn power(&self, world: &World) -> f32;

    /// Light arriving at `p` (next-event estimation) from this light, chosen with
    /// probability `choice`; `u` picks the point or direction.
    fn sample_li(&self, p: Vec3, u: Vec2, choice: f32, world: &World) -> Option<LightSample>;

    /// The density (solid angle at `p`, times `choice`) with which `sample_li` picks the
    /// point `q` with normal `n` (for a background, the direction `q − p`); 0 for a light
    /// that no ray can hit.
    fn pdf_li(&self, p: Vec3, q: Vec3, n: Vec3, choice: f32) -> f32;

    /// The start of a light path from this light, chosen with probability `choice`:
    /// `u_pos` picks the point, `u_dir` the direction. `light` is its index in the set.
    fn sample_le(
        &self,
        u_pos: Vec2,
        u_dir: Vec2,
        choice: f32,
        world: &World,
        light: usize,
    ) -> Option<EmissionSample>;

    /// Whether the light is infinitely far away (directional, background).
    fn is_infinite(&self) -> bool;

    /// Where the light is, how it faces and its power, for the light hierarchy; `None` for
    /// lights at infinity.
    fn bounds(&self, _world: &World) -> Option<LightBounds> {
        None
    }

    /// A point source's position and its intensity for bidirectional light vertices;
    /// `None` for lights with area or at infinity.
    fn point_source(&self) -> Option<(Vec3, Rgb)> {
        None
    }

    /// A point source's intensity towards unit `w` (zero for other lights).
    fn intensity_towards(&self, _w: Vec3) -> Rgb {
        Rgb::ZERO
    }

    /// The blackbody spectrum of its light, if it is one (spectral renders emit Planck's
    /// law at its RGB's luminance); `None`: the spectrum of its RGB.
    fn spectrum(&self) -> Option<BlackbodyEmission> {
        None
    }

    /// A point source's direction of emission and its solid-angle density, from `u`.
    fn emission_direction(&self, _u: Vec2) -> (Vec3, f32) {
        (Vec3::ZERO, 0.0)
    }

    /// The solid-angle density with which a light path from a point source, or from the
    /// background, leaves along `w` (0 for other lights).
    fn pdf_emission_direction(&self, _w: Vec3) -> f32 {
        0.0
    }

    /// What Whitted's integrator takes of a point or directional light at `p`; `None`
    /// where the light sends nothing to `p` (or for lights it handles otherwise).
    fn illuminate(&self, _p: Vec3) -> Option<Illumination> {
        None
    }
}

/// A delta light's light at a point, as Whitted's integrator takes it.
#[derive(Clone, Copy, Debug)]
pub struct Illumination {
    /// Unit direction from the point to the light.
    pub wi: Vec3,
    /// Irradiance on a surface facing the light (intensity / d² for point sources).
    pub irradiance: Rgb,
    /// The light's position, `None` at infinity.
    pub position: Option<Vec3>,
}

/// A light given in the scene: the one list of the kinds a scene file names.
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    Point(PointLight),
    Spot(SpotLight),
    Goniometric(GoniometricLight),
    Directional(DirectionalLight),
    Projection(ProjectionLight),
}

impl Light {
    /// The kind's implementation of the interface.
    pub fn model(&self) -> &dyn LightModel {
        match self {
            Light::Point(l) => l,
            Light::Spot(l) => l,
            Light::Goniometric(l) => l,
            Light::Directional(l) => l,
            Light::Projection(l) => l,
        }
    }

    /// The position of a light that has one (all but directional lights).
    pub fn position(&self) -> Option<Vec3> {
        self.model().point_source().map(|(p, _)| p)
    }
}

/// A sample of incident light at a shaded point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Radiance arriving along `-wi` (for delta lights, the irradiance-like equivalent).
    pub radiance: Rgb,
    /// Unit direction from the shaded point to the light.
    pub wi: Vec3,
    /// The point on the light (for area and point lights) or a point far away along `wi`.
    pub p: Vec3,
    /// A bound of `p`'s rounding error along each axis (zero off surfaces).
    pub error: Vec3,
    /// The light's unit normal at `p` (zero where there is no surface).
    pub n: Vec3,
    /// Density in solid angle at the shaded point, including the choice of emitter; for delta
    /// lights the choice probability.
    pub pdf: f32,
    pub delta: bool,
}

impl LightSample {
    /// A sample of a delta light (a point or a direction): `radiance` arrives along `-wi`
    /// from `p`, off any surface, with the emitter's `choice` probability as its density.
    pub fn delta(radiance: Rgb, wi: Vec3, p: Vec3, choice: f32) -> LightSample {
        LightSample {
            radiance,
            wi,
            p,
            error: Vec3::ZERO,
            n: Vec3::ZERO,
            pdf: choice,
            delta: true,
        }
    }

    /// Where the shadow ray towards the light ends.
    pub fn spot(&self) -> Spot {
        Spot {
            p: self.p,
            error: self.error,
            n: self.n,
        }
    }
}

/// The start of a light path.
#[derive(Clone, Copy, Debug)]
pub struct EmissionSample {
    pub p: Vec3,
    /// A bound of `p`'s rounding error along each axis (zero off surfaces).
    pub error: Vec3,
    /// Surface normal at `p` (zero for point lights and for infinite lights the direction).
    pub n: Vec3,
    pub dir: Vec3,
    pub radiance: Rgb,
    /// Area density of `p` (including the choice of emitter); for a point light, the choice
    /// probability.
    pub pdf_pos: f32,
    /// Solid-angle density of `dir`; for a directional light 1.
    pub pdf_dir: f32,
    /// `p` is a single point (point lights).
    pub delta_pos: bool,
    /// `dir` is a single direction (directional lights).
    pub delta_dir: bool,
    /// Index of the emitter.
    pub light: usize,
}

impl EmissionSample {
    /// Where the light path leaves: the point, its error and its normal (for points off
    /// every surface, the error is zero and the point is not moved).
    pub fn spot(&self) -> Spot {
        Spot {
            p: self.p,
            error: self.error,
            n: self.n,
        }
    }
}
