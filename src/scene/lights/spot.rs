//! pbrt-v4's spot light: intensity I·falloff(cos θ) (W/sr) from a point, with θ the angle
//! to its axis; no light beyond `cone_angle` (degrees from the axis), full intensity within
//! `cone_angle` − `cone_delta`, a smooth step between ([`spot_falloff`]).

use super::{DirectionCone, PointSource};
use crate::math::warp::{uniform_cone, uniform_cone_pdf};
use crate::math::{frame, luminance, Rgb, Vec2, Vec3};
use crate::spectrum::BlackbodyEmission;

#[derive(Clone, Debug, PartialEq)]
pub struct SpotLight {
    pub position: Vec3,
    /// The axis, as the scene gives it.
    pub direction: Vec3,
    pub intensity: Rgb,
    /// A blackbody's spectrum, when `intensity` is its colour times the luminance.
    pub spectrum: Option<BlackbodyEmission>,
    /// Degrees from the axis to the cone's edge.
    pub cone_angle: f32,
    /// Degrees over which the falloff runs, inside the edge.
    pub cone_delta: f32,
    /// The axis, unit length.
    axis: Vec3,
    /// Cosines of the falloff's start and of the cone's edge.
    cos_start: f32,
    cos_end: f32,
}

impl SpotLight {
    pub fn new(
        position: Vec3,
        direction: Vec3,
        intensity: Rgb,
        cone_angle: f32,
        cone_delta: f32,
    ) -> SpotLight {
        let (cos_start, cos_end) = spot_cosines(cone_angle, cone_delta);
        SpotLight {
            position,
            direction,
            intensity,
            spectrum: None,
            cone_angle,
            cone_delta,
            axis: direction.normalize(),
            cos_start,
            cos_end,
        }
    }
}

impl PointSource for SpotLight {
    fn position(&self) -> Vec3 {
        self.position
    }

    fn blackbody(&self) -> Option<BlackbodyEmission> {
        self.spectrum
    }

    fn intensity(&self, w: Vec3) -> Rgb {
        self.intensity * spot_falloff(w.dot(self.axis), self.cos_start, self.cos_end)
    }

    fn base_intensity(&self) -> Rgb {
        self.intensity
    }

    fn flux(&self) -> f32 {
        spot_solid_angle(self.cos_start, self.cos_end) * luminance(self.intensity)
    }

    /// Uniform over the cone, as pbrt-v4 does.
    fn sample_direction(&self, u: Vec2) -> (Vec3, f32) {
        let (t, b) = frame(self.axis);
        let l = uniform_cone(u, self.cos_end);
        let dir = (t * l.x + b * l.y + self.axis * l.z).normalize();
        (dir, uniform_cone_pdf(self.cos_end))
    }

    fn pdf_direction(&self, w: Vec3) -> f32 {
        if w.dot(self.axis) >= self.cos_end {
            uniform_cone_pdf(self.cos_end)
        } else {
            0.0
        }
    }

    /// pbrt-v4's bounds: full intensity within the falloff's start, the falloff beyond,
    /// weighed by the intensity over the whole sphere.
    fn emission_cone(&self) -> (DirectionCone, f32, f32) {
        let theta_e = self.cos_end.clamp(-1.0, 1.0).acos() - self.cos_start.clamp(-1.0, 1.0).acos();
        let cone = DirectionCone {
            w: self.axis,
            cos_theta: self.cos_start,
        };
        (
            cone,
            theta_e.cos(),
            4.0 * std::f32::consts::PI * luminance(self.intensity),
        )
    }
}

/// pbrt-v4's spot falloff: SmoothStep(cos_end, cos_start, cos θ), 0 outside the cone, 1
/// inside the inner cone, a cubic Hermite step between.
pub fn spot_falloff(cos: f32, cos_start: f32, cos_end: f32) -> f32 {
    if cos_start == cos_end {
        return if cos < cos_end { 0.0 } else { 1.0 };
    }
    let t = ((cos - cos_end) / (cos_start - cos_end)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The spot light of pbrt-v4's `coneangle` and `conedelta` (degrees): (cos of the falloff's
/// start, cos of the cone's edge).
pub fn spot_cosines(cone_angle: f32, cone_delta: f32) -> (f32, f32) {
    (
        (cone_angle - cone_delta).to_radians().cos(),
        cone_angle.to_radians().cos(),
    )
}

/// Whether a cone of `cone_angle` degrees is wide enough to sample in single precision: the
/// cosine of a narrower one rounds to 1, its solid angle to 0 and its sampling density to
/// infinity. Else why not (to follow the field's name).
pub fn check_cone_width(cone_angle: f32) -> Result<(), String> {
    let (_, cos_end) = spot_cosines(cone_angle, 0.0);
    if crate::math::warp::uniform_cone_pdf(cos_end).is_finite() {
        Ok(())
    } else {
        Err(format!(
            "is too narrow to sample, got {cone_angle:?} degrees (a cone's solid angle must not \
             round to zero)"
        ))
    }
}

/// The total power of a spot light per unit intensity: 2π((1 − cos_start) + (cos_start −
/// cos_end)/2), pbrt-v4's k_e (what `power` divides by).
pub fn spot_solid_angle(cos_start: f32, cos_end: f32) -> f32 {
    std::f32::consts::TAU * ((1.0 - cos_start) + 0.5 * (cos_start - cos_end))
}
