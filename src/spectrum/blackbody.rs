//! Blackbody emission (Planck's law), normalised as pbrt-v4's `BlackbodySpectrum`: a peak of 1.

use super::cie;
use super::color_space::ColorSpace;
use super::sampled::{SampledSpectrum, SampledWavelengths};
use glam::Vec3;

/// Planck's constant (J·s), exact in the SI since 2019.
const H: f64 = 6.626_070_15e-34;
/// The speed of light (m/s).
const C: f64 = 299_792_458.0;
/// Boltzmann's constant (J/K).
const KB: f64 = 1.380_649e-23;
/// Wien's displacement constant (m·K).
const WIEN: f64 = 2.897_771_955e-3;

/// Spectral radiance (W·sr⁻¹·m⁻³) of a blackbody at `kelvin` at the wavelength `lambda` nm;
/// zero for a temperature that is not positive.
pub fn planck(lambda: f64, kelvin: f64) -> f64 {
    if kelvin <= 0.0 {
        return 0.0;
    }
    let l = lambda * 1e-9;
    2.0 * H * C * C / (l.powi(5) * ((H * C / (l * KB * kelvin)).exp_m1()))
}

/// A blackbody's spectrum divided by its peak (at Wien's wavelength), so its largest value
/// is 1 whatever its temperature.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blackbody {
    kelvin: f64,
    normalisation: f64,
}

impl Blackbody {
    /// The blackbody of temperature `kelvin` (positive).
    pub fn new(kelvin: f64) -> Self {
        let peak = WIEN / kelvin * 1e9;
        Blackbody {
            kelvin,
            normalisation: 1.0 / planck(peak, kelvin),
        }
    }

    /// Its temperature (K).
    pub fn kelvin(&self) -> f64 {
        self.kelvin
    }

    /// The value at `lambda` nm.
    pub fn eval(&self, lambda: f32) -> f32 {
        (planck(lambda as f64, self.kelvin) * self.normalisation) as f32
    }

    /// The values at the sampled wavelengths.
    pub fn sample(&self, lambda: &SampledWavelengths) -> SampledSpectrum {
        SampledSpectrum(lambda.lambdas().map(|l| self.eval(l)))
    }
}

/// A blackbody emitter's spectrum scaled to luminance Y = 1, as pbrt-v4 scales a light's
/// spectrum (`scale / SpectrumToPhotometric`): an emitter of this colour and luminance `s`
/// emits `s` times it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlackbodyEmission {
    body: Blackbody,
    /// 1 / Y of `body`, folded into its values.
    per_luminance: f32,
    /// The linear sRGB of the luminance-1 spectrum.
    rgb: Vec3,
}

/// The temperatures a blackbody emitter may have (K): below, the visible part of its light
/// underflows; above, it is bluish white whatever the temperature.
pub const KELVIN_RANGE: (f64, f64) = (500.0, 1.0e6);

impl BlackbodyEmission {
    /// The emitter of temperature `kelvin`, within [`KELVIN_RANGE`], or why not.
    pub fn new(kelvin: f64) -> Result<Self, String> {
        let (lo, hi) = KELVIN_RANGE;
        if !(lo..=hi).contains(&kelvin) {
            return Err(format!(
                "a blackbody's temperature must be from {lo} to {hi} K, got {kelvin}"
            ));
        }
        let body = Blackbody::new(kelvin);
        let xyz = cie::spectrum_to_xyz(|l| body.eval(l as f32) as f64);
        let rgb = ColorSpace::srgb().xyz_to_rgb(xyz / xyz.y);
        Ok(BlackbodyEmission {
            body,
            per_luminance: (1.0 / xyz.y) as f32,
            rgb: rgb.as_vec3(),
        })
    }

    /// Its temperature (K).
    pub fn kelvin(&self) -> f64 {
        self.body.kelvin()
    }

    /// The linear sRGB of its light at luminance 1 (what RGB renders emit; components may be
    /// slightly negative for the hottest, outside sRGB's gamut, and are clamped to 0).
    pub fn rgb(&self) -> Vec3 {
        self.rgb.max(Vec3::ZERO)
    }

    /// The values at `lambda` of its light at luminance `luminance`.
    pub fn sample(&self, lambda: &SampledWavelengths, luminance: f32) -> SampledSpectrum {
        SampledSpectrum(
            lambda
                .lambdas()
                .map(|l| self.body.eval(l) * self.per_luminance * luminance),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::cie;

    fn xy(kelvin: f64) -> (f64, f64) {
        let b = Blackbody::new(kelvin);
        cie::chromaticity(cie::spectrum_to_xyz(|l| b.eval(l as f32) as f64))
    }

    /// The Planckian locus by Kim et al.'s cubic splines ("Design of advanced color
    /// temperature control system for HDTV applications", J. Korean Physical Society 41(6),
    /// 865–871, 2002), valid from 1667 K to 25000 K.
    fn kim(t: f64) -> (f64, f64) {
        let (t1, t2, t3) = (1e3 / t, 1e6 / (t * t), 1e9 / (t * t * t));
        let x = if t <= 4000.0 {
            -0.266_123_9 * t3 - 0.234_358_9 * t2 + 0.877_695_6 * t1 + 0.179_910
        } else {
            -3.025_846_9 * t3 + 2.107_037_9 * t2 + 0.222_634_7 * t1 + 0.240_390
        };
        let y = if t <= 2222.0 {
            -1.106_381_4 * x.powi(3) - 1.348_110_20 * x * x + 2.185_558_32 * x - 0.202_196_83
        } else if t <= 4000.0 {
            -0.954_947_6 * x.powi(3) - 1.374_185_93 * x * x + 2.091_370_15 * x - 0.167_488_67
        } else {
            3.081_758_0 * x.powi(3) - 5.873_386_70 * x * x + 3.751_129_97 * x - 0.370_014_83
        };
        (x, y)
    }

    #[test]
    fn chromaticities_lie_on_the_planckian_locus() {
        // The published locus at 2700 K and 6500 K (CIE 1931 2°): (0.4599, 0.4106) and
        // (0.3135, 0.3237); and Kim et al.'s fit over the range.
        for (t, want) in [(2700.0, (0.4599, 0.4106)), (6500.0, (0.3135, 0.3237))] {
            let (x, y) = xy(t);
            assert!(
                (x - want.0).hypot(y - want.1) < 0.002,
                "{t} K: ({x}, {y}) against {want:?}"
            );
        }
        for t in [1800.0, 2700.0, 3500.0, 5000.0, 6500.0, 10000.0] {
            let (x, y) = xy(t);
            let (kx, ky) = kim(t);
            assert!(
                (x - kx).hypot(y - ky) < 0.002,
                "{t} K: ({x}, {y}) against ({kx}, {ky})"
            );
        }
    }

    #[test]
    fn the_peak_is_one() {
        for t in [2000.0, 5500.0, 9000.0] {
            let b = Blackbody::new(t);
            let peak = (WIEN / t * 1e9) as f32;
            assert!((b.eval(peak) - 1.0).abs() < 1e-5);
            assert!(b.eval(peak - 20.0) < 1.0 && b.eval(peak + 20.0) < 1.0);
        }
        assert_eq!(planck(500.0, 0.0), 0.0);
    }

    #[test]
    fn an_emitter_has_luminance_one_and_the_locus_colour() {
        for t in [2700.0, 6500.0] {
            let e = BlackbodyEmission::new(t).unwrap();
            let xyz = ColorSpace::srgb().rgb_to_xyz(e.rgb().as_dvec3());
            assert!((xyz.y - 1.0).abs() < 1e-5, "{t} K: Y = {}", xyz.y);
            let (x, y) = cie::chromaticity(xyz);
            let (px, py) = xy(t);
            assert!((x - px).hypot(y - py) < 1e-5, "{t} K");
            // Sampled at wavelengths, its values estimate the luminance asked for (the Monte
            // Carlo estimate over stratified wavelengths), and follow Planck's law.
            let n = 4096;
            let mean_y: f64 = (0..n)
                .map(|i| {
                    let lambda = SampledWavelengths::sample_visible((i as f32 + 0.5) / n as f32);
                    e.sample(&lambda, 2.0).to_xyz(&lambda).y as f64
                })
                .sum::<f64>()
                / n as f64;
            assert!((mean_y - 2.0).abs() < 0.01, "{t} K: Y = {mean_y}");
            let lambda = SampledWavelengths::sample_visible(0.3);
            let v = e.sample(&lambda, 1.0);
            let [a, b, _] = lambda.lambdas();
            let ratio = planck(a as f64, t) / planck(b as f64, t);
            assert!(
                (v[0] as f64 / v[1] as f64 - ratio).abs() < 1e-4 * ratio,
                "{t} K"
            );
        }
        assert!(BlackbodyEmission::new(100.0).is_err());
        assert!(BlackbodyEmission::new(f64::NAN).is_err());
    }
}
