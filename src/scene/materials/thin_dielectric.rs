//! A thin dielectric sheet (pbrt-v4's `thindielectric`: a window pane, a soap film): light
//! passes straight through, reflected by the sheet's reflectance R summed over the
//! bounces between its two faces; smooth.

use super::{Classic, SurfaceModel};
use crate::bsdf::Bsdf;
use crate::math::{Rgb, Vec3};
use crate::scene::SurfacePoint;
use crate::scene::Texture;

/// A thin sheet of index `ior`; the approximating techniques see ks = R, kt = 1 − R.
#[derive(Clone, Debug, PartialEq)]
pub struct ThinDielectric {
    classic: Classic,
}

impl ThinDielectric {
    pub fn new(ior: f32) -> ThinDielectric {
        ThinDielectric {
            classic: Classic {
                specular: Rgb::ONE,
                transmission: Rgb::ONE,
                fresnel: true,
                thin: true,
                ior,
                ..Classic::blank()
            },
        }
    }

    pub fn ior(&self) -> f32 {
        self.classic.ior
    }
}

impl SurfaceModel for ThinDielectric {
    fn kind(&self) -> &'static str {
        "thindielectric"
    }

    fn bsdf<'a>(&'a self, sp: &SurfacePoint, wo: Vec3) -> Bsdf<'a> {
        self.classic.lobe_bsdf(sp, wo)
    }

    fn approximation(&self) -> &Classic {
        &self.classic
    }

    fn diffuse_mut(&mut self) -> Option<&mut Texture> {
        None
    }
}
