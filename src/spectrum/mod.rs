//! Spectral foundations: the wavelengths a path carries and a spectrum's values at them, the
//! CIE 1931 observer and standard illuminants, RGB colour spaces, RGB to spectrum (Jakob and
//! Hanika 2019), blackbodies, pbrt-v4's named spectra (measured metals, glasses,
//! illuminants), and [`Spectrum`], what a scene's spectrum parameter becomes ([`parse`]).
//!
//! A foundations module, as `math`: it imports nothing of the renderer. Wavelengths are in
//! nanometres throughout, from [`LAMBDA_MIN`] to [`LAMBDA_MAX`].

pub mod blackbody;
pub mod cie;
pub mod color_space;
pub mod named;
mod named_data;
mod parse;
pub mod rgb_to_spectrum;
pub mod sampled;

pub use blackbody::{Blackbody, BlackbodyEmission};
pub use cie::{Illuminant, LAMBDA_MAX, LAMBDA_MIN};
pub use color_space::ColorSpace;
pub use named::{named, Named};
pub use parse::{parse, ParseError, SpectrumUse, Values};
pub use rgb_to_spectrum::{RgbAlbedo, RgbIlluminant, RgbUnbounded, SigmoidPolynomial};
pub use sampled::{SampledSpectrum, SampledWavelengths, N_SAMPLES};

/// Measured values at increasing wavelengths, linear between them and zero outside (pbrt-v4's
/// `PiecewiseLinearSpectrum`).
#[derive(Clone, Debug, PartialEq)]
pub struct PiecewiseLinear {
    lambda: Vec<f32>,
    value: Vec<f32>,
}

impl PiecewiseLinear {
    /// The spectrum of the (wavelength nm, value) pairs `pairs`: at least two, wavelengths
    /// strictly increasing, everything finite.
    pub fn new(pairs: &[(f32, f32)]) -> Result<Self, String> {
        if pairs.len() < 2 {
            return Err(format!(
                "a sampled spectrum needs at least two (wavelength, value) pairs, not {}",
                pairs.len()
            ));
        }
        if let Some(p) = pairs.iter().find(|p| !p.0.is_finite() || !p.1.is_finite()) {
            return Err(format!(
                "sampled spectrum pair ({}, {}) is not finite",
                p.0, p.1
            ));
        }
        if let Some(w) = pairs.windows(2).find(|w| w[1].0 <= w[0].0) {
            return Err(format!(
                "sampled spectrum wavelengths must increase: {} follows {}",
                w[1].0, w[0].0
            ));
        }
        Ok(PiecewiseLinear {
            lambda: pairs.iter().map(|p| p.0).collect(),
            value: pairs.iter().map(|p| p.1).collect(),
        })
    }

    /// The value at `lambda` nm.
    pub fn eval(&self, lambda: f32) -> f32 {
        named::piecewise_linear(&self.lambda, &self.value, lambda)
    }

    /// The largest value.
    pub fn max_value(&self) -> f32 {
        self.value.iter().copied().fold(f32::NEG_INFINITY, f32::max)
    }
}

/// A spectrum as a scene describes it: a function of wavelength to sample along paths.
#[derive(Clone, Debug, PartialEq)]
pub enum Spectrum {
    /// The same value everywhere.
    Constant(f32),
    /// Measured values, linear between them.
    PiecewiseLinear(PiecewiseLinear),
    /// A blackbody emitter, peak 1.
    Blackbody(Blackbody),
    /// A reflectance given as RGB in [0, 1].
    RgbAlbedo(RgbAlbedo),
    /// A positive quantity of any size given as RGB.
    RgbUnbounded(RgbUnbounded),
    /// An emitter given as RGB, on the colour space's illuminant.
    RgbIlluminant(RgbIlluminant),
    /// One of pbrt-v4's named spectra.
    Named(Named),
}

impl Spectrum {
    /// The value at `lambda` nm.
    pub fn eval(&self, lambda: f32) -> f32 {
        match self {
            Spectrum::Constant(c) => *c,
            Spectrum::PiecewiseLinear(p) => p.eval(lambda),
            Spectrum::Blackbody(b) => b.eval(lambda),
            Spectrum::RgbAlbedo(s) => s.eval(lambda),
            Spectrum::RgbUnbounded(s) => s.eval(lambda),
            Spectrum::RgbIlluminant(s) => s.eval(lambda),
            Spectrum::Named(n) => n.eval(lambda),
        }
    }

    /// The values at a path's wavelengths.
    pub fn sample(&self, lambda: &SampledWavelengths) -> SampledSpectrum {
        match self {
            Spectrum::Constant(c) => SampledSpectrum::splat(*c),
            _ => SampledSpectrum(lambda.lambdas().map(|l| self.eval(l))),
        }
    }
}
