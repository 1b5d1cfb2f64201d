//! Glass, water, any dielectric interface (pbrt-v4's `dielectric`): Fresnel-weighted
//! reflection and refraction, smooth or through GGX microfacets.

use super::{Classic, RoughnessMap, SurfaceModel};
use crate::bsdf::Bsdf;
use crate::math::{Rgb, Vec3};
use crate::scene::SurfacePoint;
use crate::scene::Texture;
use crate::spectrum::Named;
use std::sync::Arc;

/// A dielectric interface of index `ior` inside (the side opposite the geometric normal);
/// the approximating techniques see Fresnel-weighted ks = kt = 1.
#[derive(Clone, Debug, PartialEq)]
pub struct Dielectric {
    classic: Classic,
}

impl Dielectric {
    /// The interface of index `ior` with GGX (α_x, α_y), or a roughness map (then
    /// `alphas` are its largest).
    pub fn new(ior: f32, alphas: (f32, f32), roughness_map: Option<RoughnessMap>) -> Dielectric {
        let (ax, ay) = alphas;
        Dielectric {
            classic: Classic {
                specular: Rgb::ONE,
                transmission: Rgb::ONE,
                fresnel: true,
                ior,
                roughness: ax,
                roughness_v: (ay != ax).then_some(ay),
                roughness_map: roughness_map.map(Arc::new),
                ..Classic::blank()
            },
        }
    }

    /// The same interface, its index varying with wavelength as `glass`'s in spectral
    /// renders.
    pub fn with_dispersion(mut self, glass: Option<&'static Named>) -> Dielectric {
        self.classic.spectral.dispersion = glass;
        self
    }

    pub fn ior(&self) -> f32 {
        self.classic.ior
    }
}

impl SurfaceModel for Dielectric {
    fn kind(&self) -> &'static str {
        "dielectric"
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
