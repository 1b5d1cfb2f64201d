//! Vectors (glam), rays, orthonormal frames and random streams.

pub mod optics;
mod random;
pub mod sobol;
pub mod spawn;
pub mod warp;
pub mod windowed;

pub use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};
pub use random::Rng;

/// Linear RGB radiance or reflectance.
pub type Rgb = Vec3;

/// A ray segment `origin + t * dir` for `t` in `[tmin, tmax]`. `dir` need not be unit length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
    pub tmin: f32,
    pub tmax: f32,
    /// When the ray travels, as a fraction of the shutter interval (0 at shutter open, 1 at
    /// close): moving shapes are met where they are then.
    pub time: f32,
}

impl Ray {
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Ray {
            origin,
            dir,
            tmin: 0.0,
            tmax: f32::INFINITY,
            time: 0.0,
        }
    }

    /// The same ray at shutter time `time` (rays spawned along a path keep the path's time).
    pub fn at_time(self, time: f32) -> Self {
        Ray { time, ..self }
    }

    /// The segment between two points off every surface (both exact); for a point on a
    /// surface, spawn from its [`spawn::Spot`] instead.
    pub fn segment(from: Vec3, to: Vec3) -> Self {
        spawn::Spot::exact(from).spawn_to(&spawn::Spot::exact(to))
    }

    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }
}

/// Luminance of linear Rec.709 RGB.
pub fn luminance(c: Rgb) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// An orthonormal basis whose z axis is `n` (Duff et al. 2017, branchless).
pub fn frame(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// Complementary error function (Numerical Recipes' erfcc, |error| < 1.2e-7).
pub(crate) fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let r = t
        * (-z * z - 1.265_512_23
            + t * (1.000_023_68
                + t * (0.374_091_96
                    + t * (0.096_784_18
                        + t * (-0.186_288_06
                            + t * (0.278_868_07
                                + t * (-1.135_203_98
                                    + t * (1.488_515_87
                                        + t * (-0.822_152_23 + t * 0.170_872_77)))))))))
            .exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}
