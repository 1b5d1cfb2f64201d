//! The values of a BSDF that are colours or vary with wavelength, read and replaced as a
//! whole: what a spectral render turns into values at a path's wavelengths
//! (`transport::spectral`).

use super::{Bsdf, Conductor, SpectralParts};
use crate::math::Rgb;

/// The values of a BSDF's lobes that are colours (or vary with wavelength): what a spectral
/// render replaces by their values at a path's wavelengths.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LobeColours {
    pub kd: Rgb,
    pub kdt: Rgb,
    pub ks: Rgb,
    pub kt: Rgb,
    pub ior: f32,
    pub conductor: Option<Conductor>,
}

impl<'a> Bsdf<'a> {
    /// The lobes' colours and index.
    pub fn colours(&self) -> LobeColours {
        LobeColours {
            kd: self.kd,
            kdt: self.kdt,
            ks: self.ks,
            kt: self.kt,
            ior: self.ior,
            conductor: self.conductor,
        }
    }

    /// The same BSDF with the lobes' colours and index `c`.
    pub fn with_colours(self, c: LobeColours) -> Bsdf<'a> {
        Bsdf {
            kd: c.kd,
            kdt: c.kdt,
            ks: c.ks,
            kt: c.kt,
            ior: c.ior,
            conductor: c.conductor,
            ..self
        }
    }

    /// What the surface varies with wavelength beyond its colours.
    pub fn spectral_parts(&self) -> SpectralParts {
        self.spectral
    }
}
