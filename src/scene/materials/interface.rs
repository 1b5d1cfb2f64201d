//! A surface that is only the boundary of a medium (pbrt-v4's `interface`): it neither
//! reflects nor bends light. The volumetric path tracer passes through it without counting
//! a bounce; the other techniques see a clear, index-matched sheet.

use super::{Classic, SurfaceModel};
use crate::bsdf::Bsdf;
use crate::math::{Rgb, Vec3};
use crate::scene::{SurfacePoint, Texture};

#[derive(Clone, Debug, PartialEq)]
pub struct Interface {
    classic: Classic,
}

impl Default for Interface {
    fn default() -> Self {
        Interface {
            classic: Classic {
                transmission: Rgb::ONE,
                ior: 1.0,
                ..Classic::blank()
            },
        }
    }
}

impl SurfaceModel for Interface {
    fn kind(&self) -> &'static str {
        "interface"
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
