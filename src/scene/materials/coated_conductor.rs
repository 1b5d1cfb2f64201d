//! A metal under a dielectric coat (pbrt-v4's `coatedconductor`: lacquered or anodised
//! metal): light refracts into the coat, bounces between the metal and the coat, and
//! leaves ([`crate::bsdf`]'s layered BSDF).

use super::{Classic, SurfaceModel};
use crate::bsdf::{Bsdf, Coating};
use crate::math::Vec3;
use crate::scene::SurfacePoint;
use crate::scene::Texture;

/// A coated metal. The approximating techniques see the bare metal (its Fresnel-weighted
/// ks and roughness); the coat is for the Monte Carlo techniques only.
#[derive(Clone, Debug, PartialEq)]
pub struct CoatedConductor {
    classic: Classic,
    coating: Coating,
}

impl CoatedConductor {
    /// `coating` over the metal `metal` (classic terms with a `conductor`).
    pub fn new(metal: Classic, coating: Coating) -> CoatedConductor {
        CoatedConductor {
            classic: metal,
            coating,
        }
    }

    pub fn coating(&self) -> &Coating {
        &self.coating
    }
}

impl SurfaceModel for CoatedConductor {
    fn kind(&self) -> &'static str {
        "coatedconductor"
    }

    fn bsdf<'a>(&'a self, sp: &SurfacePoint, wo: Vec3) -> Bsdf<'a> {
        self.classic.coated_bsdf(&self.coating, sp, wo)
    }

    fn approximation(&self) -> &Classic {
        &self.classic
    }

    fn diffuse_mut(&mut self) -> Option<&mut Texture> {
        None
    }
}
