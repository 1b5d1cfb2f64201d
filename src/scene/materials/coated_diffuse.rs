//! A diffuse base under a dielectric coat (pbrt-v4's `coateddiffuse`: paint, varnished
//! wood, plastic): light refracts into the coat, bounces between base and coat, and leaves
//! ([`crate::bsdf`]'s layered BSDF, pbrt-v4's `LayeredBxDF`).

use super::{Classic, SurfaceModel};
use crate::bsdf::{Bsdf, Coating};
use crate::math::Vec3;
use crate::scene::SurfacePoint;
use crate::scene::Texture;

/// A coated diffuse surface. The approximating techniques see the coat's mirror as
/// Fresnel-weighted specular over the diffuse kd (weighted by 1 − F on the way in and out).
#[derive(Clone, Debug, PartialEq)]
pub struct CoatedDiffuse {
    classic: Classic,
    coating: Coating,
}

impl CoatedDiffuse {
    /// `coating` over the base `base` (its kd, and its ks as the coat's mirror tint): the
    /// approximation takes the coat's index and roughness, Fresnel-weighted.
    pub fn new(base: Classic, coating: Coating) -> CoatedDiffuse {
        CoatedDiffuse {
            classic: Classic {
                ior: coating.ior,
                fresnel: true,
                roughness: coating.roughness,
                roughness_v: coating.roughness_v,
                ..base
            },
            coating,
        }
    }

    pub fn coating(&self) -> &Coating {
        &self.coating
    }
}

impl SurfaceModel for CoatedDiffuse {
    fn kind(&self) -> &'static str {
        "coateddiffuse"
    }

    fn bsdf<'a>(&'a self, sp: &SurfacePoint, wo: Vec3) -> Bsdf<'a> {
        self.classic.coated_bsdf(&self.coating, sp, wo)
    }

    fn approximation(&self) -> &Classic {
        &self.classic
    }

    fn diffuse_mut(&mut self) -> Option<&mut Texture> {
        Some(&mut self.classic.diffuse)
    }
}
