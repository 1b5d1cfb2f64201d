//! A thin translucent sheet (pbrt-v4's `diffusetransmission`: paper, leaves, a lampshade):
//! R/π on the side light arrives from, T/π through to the other side.

use super::{Classic, SurfaceModel};
use crate::bsdf::Bsdf;
use crate::math::Vec3;
use crate::scene::{SurfacePoint, Texture};

/// Lambertian reflection and transmission; the approximating techniques see kd = R and
/// kdt = T (Whitted's integrator has no diffuse transmission and shows only R).
#[derive(Clone, Debug, PartialEq)]
pub struct DiffuseTransmission {
    classic: Classic,
}

impl DiffuseTransmission {
    /// The sheet reflecting `reflectance` and transmitting `transmittance`.
    pub fn new(reflectance: Texture, transmittance: Texture) -> DiffuseTransmission {
        DiffuseTransmission {
            classic: Classic {
                diffuse: reflectance,
                diffuse_transmission: transmittance,
                ..Classic::blank()
            },
        }
    }

    pub fn reflectance(&self) -> &Texture {
        &self.classic.diffuse
    }

    pub fn transmittance(&self) -> &Texture {
        &self.classic.diffuse_transmission
    }
}

impl SurfaceModel for DiffuseTransmission {
    fn kind(&self) -> &'static str {
        "diffusetransmission"
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
