//! A metal (pbrt-v4's `conductor`): mirror or GGX reflection weighted per channel by the
//! Fresnel reflectance of a complex index of refraction η + ik.

use super::{Classic, RoughnessMap, SurfaceModel};
use crate::bsdf::{Bsdf, Conductor};
use crate::math::{Rgb, Vec3};
use crate::scene::{SurfacePoint, Texture};
use crate::spectrum::Named;
use std::sync::Arc;

/// A metal; the approximating techniques see ks = 1 weighted by its Fresnel reflectance
/// (at normal incidence where they take no angle) and the GGX roughness as Whitted's
/// glossy spread.
#[derive(Clone, Debug, PartialEq)]
pub struct Metal {
    classic: Classic,
}

impl Metal {
    /// The metal of index `index`, or of the normal-incidence reflectance `reflectance`
    /// varying over the surface (then `index` is that of its largest value); GGX
    /// (α_x, α_y), or a roughness map (then `alphas` are its largest).
    pub fn new(
        index: Conductor,
        reflectance: Option<Texture>,
        alphas: (f32, f32),
        roughness_map: Option<RoughnessMap>,
    ) -> Metal {
        let (ax, ay) = alphas;
        Metal {
            classic: Classic {
                specular: Rgb::ONE,
                conductor: Some(index),
                reflectance_map: reflectance,
                roughness: ax,
                roughness_v: (ay != ax).then_some(ay),
                roughness_map: roughness_map.map(Arc::new),
                ..Classic::blank()
            },
        }
    }

    /// The same metal, reflecting by the measured η and k `spectra` in spectral renders.
    pub fn with_measured(mut self, spectra: Option<(&'static Named, &'static Named)>) -> Metal {
        self.classic.spectral.metal = spectra;
        self
    }

    /// The metal whose classic terms are `classic` (a native scene's plain keys with a
    /// `conductor`).
    pub fn from_classic(classic: Classic) -> Metal {
        Metal { classic }
    }
}

impl SurfaceModel for Metal {
    fn kind(&self) -> &'static str {
        "conductor"
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
