//! A Lambertian reflector (pbrt-v4's `diffuse`): f = kd/π.

use super::{Classic, SurfaceModel};
use crate::bsdf::Bsdf;
use crate::math::Vec3;
use crate::scene::{SurfacePoint, Texture};

/// A Lambertian surface; Whitted's integrator, the cache and the network see its kd.
#[derive(Clone, Debug, PartialEq)]
pub struct Diffuse {
    classic: Classic,
}

impl Diffuse {
    /// The surface of diffuse reflectance `reflectance`.
    pub fn new(reflectance: Texture) -> Diffuse {
        Diffuse {
            classic: Classic {
                diffuse: reflectance,
                ..Classic::blank()
            },
        }
    }

    pub fn reflectance(&self) -> &Texture {
        &self.classic.diffuse
    }
}

impl SurfaceModel for Diffuse {
    fn kind(&self) -> &'static str {
        "diffuse"
    }

    fn bsdf<'a>(&'a self, sp: &SurfacePoint, wo: Vec3) -> Bsdf<'a> {
        self.classic.lobe_bsdf(sp, wo)
    }

    fn approximation(&self) -> &Classic {
        &self.classic
    }

    fn diffuse_mut(&mut self) -> Option<&mut Texture> {
        Some(&mut self.classic.diffuse)
    }
}
