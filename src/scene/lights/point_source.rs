//! Lights at one point whose intensity varies with direction (point, spot, goniometric,
//! projection): each says where it is, its intensity towards a direction, its power and how
//! it emits light paths ([`PointSource`]); the light interface follows from that alone.

use super::{
    DirectionCone, EmissionSample, Illumination, LightBounds, LightModel, LightSample, World,
};
use crate::math::{Rgb, Vec2, Vec3};
use crate::spectrum::BlackbodyEmission;

/// What a point source is made of.
pub trait PointSource {
    fn position(&self) -> Vec3;

    /// Its blackbody spectrum, if it has one ([`LightModel::spectrum`]).
    fn blackbody(&self) -> Option<BlackbodyEmission> {
        None
    }

    /// Radiant intensity (W/sr) towards unit `w`, pointing away from the light.
    fn intensity(&self, w: Vec3) -> Rgb;

    /// The intensity a bidirectional light vertex carries before its direction is known
    /// (the light's scale; the direction's factor comes from [`PointSource::intensity`]).
    fn base_intensity(&self) -> Rgb;

    /// The light's power as light selection weighs it (the luminance of its flux).
    fn flux(&self) -> f32;

    /// A direction of emission from `u` and its solid-angle density.
    fn sample_direction(&self, u: Vec2) -> (Vec3, f32);

    /// The solid-angle density with which [`PointSource::sample_direction`] picks `w`.
    fn pdf_direction(&self, w: Vec3) -> f32;

    /// The cone the source emits in (axis, cosine of its full-intensity half-angle, cosine
    /// of the falloff beyond) and the power the light hierarchy weighs it by: every
    /// direction and its flux, unless the kind says otherwise.
    fn emission_cone(&self) -> (DirectionCone, f32, f32) {
        (DirectionCone::SPHERE, 0.0, self.flux())
    }
}

impl<T: PointSource> LightModel for T {
    fn power(&self, _world: &World) -> f32 {
        self.flux()
    }

    fn sample_li(&self, p: Vec3, _u: Vec2, choice: f32, _world: &World) -> Option<LightSample> {
        let position = self.position();
        let d = position - p;
        let dist2 = d.length_squared();
        let wi = d / dist2.sqrt();
        let intensity = self.intensity(-wi);
        if intensity == Rgb::ZERO {
            return None;
        }
        Some(LightSample::delta(intensity / dist2, wi, position, choice))
    }

    fn pdf_li(&self, _p: Vec3, _q: Vec3, _n: Vec3, _choice: f32) -> f32 {
        0.0
    }

    fn sample_le(
        &self,
        _u_pos: Vec2,
        u_dir: Vec2,
        choice: f32,
        _world: &World,
        light: usize,
    ) -> Option<EmissionSample> {
        let (dir, pdf_dir) = self.sample_direction(u_dir);
        Some(EmissionSample {
            p: self.position(),
            error: Vec3::ZERO,
            n: Vec3::ZERO,
            dir,
            radiance: self.intensity(dir),
            pdf_pos: choice,
            pdf_dir,
            delta_pos: true,
            delta_dir: false,
            light,
        })
    }

    fn is_infinite(&self) -> bool {
        false
    }

    fn bounds(&self, _world: &World) -> Option<LightBounds> {
        let p = self.position();
        let (normals, cos_theta_e, phi) = self.emission_cone();
        Some(LightBounds {
            lo: p,
            hi: p,
            phi,
            normals,
            cos_theta_e,
            two_sided: false,
        })
    }

    fn point_source(&self) -> Option<(Vec3, Rgb)> {
        Some((self.position(), self.base_intensity()))
    }

    fn intensity_towards(&self, w: Vec3) -> Rgb {
        self.intensity(w)
    }

    fn spectrum(&self) -> Option<BlackbodyEmission> {
        self.blackbody()
    }

    fn emission_direction(&self, u: Vec2) -> (Vec3, f32) {
        self.sample_direction(u)
    }

    fn pdf_emission_direction(&self, w: Vec3) -> f32 {
        self.pdf_direction(w)
    }

    fn illuminate(&self, p: Vec3) -> Option<Illumination> {
        let position = self.position();
        let to = position - p;
        let d2 = to.length_squared();
        let wi = to / d2.sqrt();
        let intensity = self.intensity(-wi);
        if intensity == Rgb::ZERO {
            return None;
        }
        Some(Illumination {
            wi,
            irradiance: intensity / d2,
            position: Some(position),
        })
    }
}
