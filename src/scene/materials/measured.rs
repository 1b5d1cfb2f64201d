//! A measured or tabulated reflectance ([`TabulatedBrdf`]: raylink's table format and
//! MERL's binary files): an opaque surface reflecting on both sides by the table,
//! importance-sampled from it mixed with the cosine.

use super::{Classic, SurfaceModel};
use crate::bsdf::{Bsdf, TabulatedBrdf};
use crate::math::Vec3;
use crate::scene::SurfacePoint;
use crate::scene::Texture;
use std::sync::Arc;

/// A tabulated reflectance. Its approximation in Whitted's terms is black: Whitted's
/// integrator takes the table in place of kd for direct light, the illumination network
/// scatters by the table itself ([`SurfaceModel::table`]), and the irradiance cache caches
/// no diffuse part (the table's light is its glossy part).
#[derive(Clone, Debug, PartialEq)]
pub struct Measured {
    table: Arc<TabulatedBrdf>,
    classic: Classic,
}

impl Measured {
    pub fn new(table: Arc<TabulatedBrdf>) -> Measured {
        Measured {
            table,
            classic: Classic::blank(),
        }
    }
}

impl SurfaceModel for Measured {
    fn kind(&self) -> &'static str {
        "measured"
    }

    fn bsdf<'a>(&'a self, sp: &SurfacePoint, wo: Vec3) -> Bsdf<'a> {
        let (n, ng) = Bsdf::facing(false, sp.ns, sp.ng, wo);
        Bsdf::tabulated(&self.table, n, ng)
    }

    fn approximation(&self) -> &Classic {
        &self.classic
    }

    fn diffuse_mut(&mut self) -> Option<&mut Texture> {
        None
    }

    fn table(&self) -> Option<&Arc<TabulatedBrdf>> {
        Some(&self.table)
    }
}
