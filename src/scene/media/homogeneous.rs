//! A homogeneous medium: the same absorption, scattering and emission everywhere it fills
//! (pbrt-v4's `homogeneous`, Mitsuba 3's `homogeneous`).

use super::{check_coefficients, check_g, MediumModel, MediumPoint, MediumProblem, Segment};
use crate::math::{Ray, Rgb, Vec3};

#[derive(Clone, Debug, PartialEq)]
pub struct Homogeneous {
    point: MediumPoint,
}

impl Homogeneous {
    /// A medium of absorption `sigma_a` and scattering `sigma_s` per unit length, emitting
    /// `le` (radiance; the medium emits σa·Le per unit length) and scattering by the
    /// Henyey–Greenstein asymmetry `g`. The problem names the field out of range.
    pub fn new(sigma_a: Rgb, sigma_s: Rgb, le: Rgb, g: f32) -> Result<Homogeneous, MediumProblem> {
        check_coefficients(&[
            ("sigma_a", "sigma_a", sigma_a),
            ("sigma_s", "sigma_s", sigma_s),
            ("emission", "Le", le),
        ])?;
        check_g(g)?;
        Ok(Homogeneous {
            point: MediumPoint {
                sigma_a,
                sigma_s,
                le,
                g,
            },
        })
    }

    /// What the medium is at every point.
    pub fn point(&self) -> &MediumPoint {
        &self.point
    }
}

impl MediumModel for Homogeneous {
    fn kind(&self) -> &'static str {
        "homogeneous"
    }

    fn at(&self, _p: Vec3) -> MediumPoint {
        self.point
    }

    fn segments(&self, ray: &Ray, t_max: f32, visit: &mut dyn FnMut(Segment) -> bool) {
        let length = ray.dir.length();
        visit(Segment {
            t0: 0.0,
            t1: t_max,
            sigma_maj: (self.point.sigma_a + self.point.sigma_s) * length,
        });
    }

    fn emits(&self) -> bool {
        (self.point.le * self.point.sigma_a).max_element() > 0.0
    }

    fn colours(&self) -> Option<&MediumPoint> {
        Some(&self.point)
    }
}
