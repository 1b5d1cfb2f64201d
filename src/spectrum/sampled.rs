//! Three wavelengths per path and a spectrum's values at them (pbrt-v4's
//! `SampledWavelengths` and `SampledSpectrum`), and the Monte Carlo estimate of a sampled
//! spectrum's colour.

use super::cie::{self, LAMBDA_MAX, LAMBDA_MIN};
use super::color_space::ColorSpace;
use glam::{DVec3, Vec3};
use std::ops::{Add, AddAssign, Div, DivAssign, Index, IndexMut, Mul, MulAssign, Neg, Sub};

/// How many wavelengths a path carries: three, pbrt-v4 carries four. A path's values ride in
/// the renderer's three-channel carrier (`math::Rgb`), so spectral mode costs no wider
/// arithmetic anywhere in the transport.
pub const N_SAMPLES: usize = 3;

/// A spectrum's values at the [`SampledWavelengths`] of a path.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SampledSpectrum(pub [f32; N_SAMPLES]);

impl SampledSpectrum {
    /// The same value at every wavelength.
    pub const fn splat(v: f32) -> Self {
        SampledSpectrum([v; N_SAMPLES])
    }

    /// Zero at every wavelength.
    pub const ZERO: Self = Self::splat(0.0);
    /// One at every wavelength.
    pub const ONE: Self = Self::splat(1.0);

    /// Applies `f` to every value.
    pub fn map(self, f: impl Fn(f32) -> f32) -> Self {
        SampledSpectrum(self.0.map(f))
    }

    /// Whether every value is zero.
    pub fn is_black(&self) -> bool {
        self.0.iter().all(|&v| v == 0.0)
    }

    /// The largest value.
    pub fn max_value(&self) -> f32 {
        self.0.iter().copied().fold(f32::NEG_INFINITY, f32::max)
    }

    /// The smallest value.
    pub fn min_value(&self) -> f32 {
        self.0.iter().copied().fold(f32::INFINITY, f32::min)
    }

    /// The mean of the values.
    pub fn average(&self) -> f32 {
        self.0.iter().sum::<f32>() / N_SAMPLES as f32
    }

    /// Whether any value is NaN.
    pub fn has_nan(&self) -> bool {
        self.0.iter().any(|v| v.is_nan())
    }

    /// `self / d` with 0 where `d` is 0 (a terminated wavelength's pdf).
    pub fn safe_div(self, d: SampledSpectrum) -> Self {
        let mut r = self;
        for i in 0..N_SAMPLES {
            r.0[i] = if d.0[i] != 0.0 {
                self.0[i] / d.0[i]
            } else {
                0.0
            };
        }
        r
    }

    /// The Monte Carlo estimate of the colour (CIE XYZ) of this spectrum, given as radiance at
    /// the wavelengths `lambda` drawn with their pdf: the mean over the wavelengths of
    /// cmf(λ) s(λ) / p(λ), divided by ∫ȳ (pbrt-v4's `SampledSpectrum::ToXYZ`). Its expectation
    /// is [`cie::spectrum_to_xyz`] of the spectrum.
    pub fn to_xyz(&self, lambda: &SampledWavelengths) -> Vec3 {
        let mut sum = DVec3::ZERO;
        for i in 0..N_SAMPLES {
            let pdf = lambda.pdf[i];
            if pdf != 0.0 {
                let l = lambda.lambda[i] as f64;
                sum += cie::cmf_xyz(l) * (self.0[i] as f64 / pdf as f64);
            }
        }
        (sum / (N_SAMPLES as f64 * cie::y_integral())).as_vec3()
    }

    /// Luminance (Y) alone, as [`to_xyz`](Self::to_xyz).
    pub fn y(&self, lambda: &SampledWavelengths) -> f32 {
        let mut sum = 0.0;
        for i in 0..N_SAMPLES {
            let pdf = lambda.pdf[i];
            if pdf != 0.0 {
                sum += cie::cmf_y(lambda.lambda[i] as f64) * (self.0[i] as f64 / pdf as f64);
            }
        }
        (sum / (N_SAMPLES as f64 * cie::y_integral())) as f32
    }

    /// The estimate of [`to_xyz`](Self::to_xyz) in the linear RGB of `space`.
    pub fn to_rgb(&self, lambda: &SampledWavelengths, space: &ColorSpace) -> Vec3 {
        space.xyz_to_rgb(self.to_xyz(lambda).as_dvec3()).as_vec3()
    }
}

impl Index<usize> for SampledSpectrum {
    type Output = f32;
    fn index(&self, i: usize) -> &f32 {
        &self.0[i]
    }
}

impl IndexMut<usize> for SampledSpectrum {
    fn index_mut(&mut self, i: usize) -> &mut f32 {
        &mut self.0[i]
    }
}

macro_rules! elementwise {
    ($tr:ident, $f:ident, $tra:ident, $fa:ident, $op:tt) => {
        impl $tr for SampledSpectrum {
            type Output = Self;
            fn $f(self, o: Self) -> Self {
                let mut r = self;
                for i in 0..N_SAMPLES {
                    r.0[i] = self.0[i] $op o.0[i];
                }
                r
            }
        }
        impl $tr<f32> for SampledSpectrum {
            type Output = Self;
            fn $f(self, o: f32) -> Self {
                self.map(|v| v $op o)
            }
        }
        impl $tra for SampledSpectrum {
            fn $fa(&mut self, o: Self) {
                *self = *self $op o;
            }
        }
        impl $tra<f32> for SampledSpectrum {
            fn $fa(&mut self, o: f32) {
                *self = *self $op o;
            }
        }
    };
}

elementwise!(Add, add, AddAssign, add_assign, +);
elementwise!(Mul, mul, MulAssign, mul_assign, *);
elementwise!(Div, div, DivAssign, div_assign, /);

impl Sub for SampledSpectrum {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        self + -o
    }
}

impl Neg for SampledSpectrum {
    type Output = Self;
    fn neg(self) -> Self {
        self.map(|v| -v)
    }
}

impl Mul<SampledSpectrum> for f32 {
    type Output = SampledSpectrum;
    fn mul(self, s: SampledSpectrum) -> SampledSpectrum {
        s * self
    }
}

/// The wavelengths (nm) a path carries and the probability density each was drawn with.
///
/// The first is the hero wavelength: when a path meets a dispersive surface, the others are
/// terminated ([`terminate_secondary`](Self::terminate_secondary)) and the hero goes on
/// alone.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampledWavelengths {
    lambda: [f32; N_SAMPLES],
    pdf: [f32; N_SAMPLES],
}

/// The density (1/nm) [`SampledWavelengths::sample_visible`] draws a wavelength with: pbrt-v4's
/// `VisibleWavelengthsPDF`, a sech² lobe around 538 nm fitted to the luminous efficiency,
/// zero outside 360 to 830 nm.
pub fn visible_wavelengths_pdf(lambda: f32) -> f32 {
    if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&lambda) {
        return 0.0;
    }
    let c = (0.0072 * (lambda - 538.0)).cosh();
    0.003_939_804 / (c * c)
}

/// The wavelength whose [`visible_wavelengths_pdf`] CDF is `u` in [0, 1).
pub fn sample_visible_wavelength(u: f32) -> f32 {
    538.0 - 138.888_89 * (0.856_910_6 - 1.827_501_9 * u).atanh()
}

/// The u at which [`sample_visible_wavelength`] gives `lambda` nm (its inverse).
pub fn visible_wavelengths_cdf(lambda: f32) -> f32 {
    ((0.856_910_6 - ((538.0 - lambda) / 138.888_89).tanh()) / 1.827_501_9).clamp(0.0, 1.0)
}

impl SampledWavelengths {
    /// [`N_SAMPLES`] wavelengths stratified uniformly over [`lambda_min`, `lambda_max`]: the
    /// first at `u`, the others 1/[`N_SAMPLES`] of the range apart, wrapping around.
    pub fn sample_uniform_in(u: f32, lambda_min: f32, lambda_max: f32) -> Self {
        let mut lambda = [0.0; N_SAMPLES];
        lambda[0] = lambda_min + u * (lambda_max - lambda_min);
        let delta = (lambda_max - lambda_min) / N_SAMPLES as f32;
        for i in 1..N_SAMPLES {
            lambda[i] = lambda[i - 1] + delta;
            if lambda[i] > lambda_max {
                lambda[i] = lambda_min + (lambda[i] - lambda_max);
            }
        }
        SampledWavelengths {
            lambda,
            pdf: [1.0 / (lambda_max - lambda_min); N_SAMPLES],
        }
    }

    /// [`sample_uniform_in`](Self::sample_uniform_in) over 360 to 830 nm.
    pub fn sample_uniform(u: f32) -> Self {
        Self::sample_uniform_in(u, LAMBDA_MIN, LAMBDA_MAX)
    }

    /// [`N_SAMPLES`] wavelengths drawn from [`visible_wavelengths_pdf`] at `u`, `u + 1/n`,
    /// … (wrapped): pbrt-v4's `SampleVisible`, which puts the samples where the eye is
    /// sensitive.
    pub fn sample_visible(u: f32) -> Self {
        let mut lambda = [0.0; N_SAMPLES];
        let mut pdf = [0.0; N_SAMPLES];
        for i in 0..N_SAMPLES {
            let mut up = u + i as f32 / N_SAMPLES as f32;
            if up > 1.0 {
                up -= 1.0;
            }
            lambda[i] = sample_visible_wavelength(up);
            pdf[i] = visible_wavelengths_pdf(lambda[i]);
        }
        SampledWavelengths { lambda, pdf }
    }

    /// The `i`th wavelength (nm).
    pub fn lambda(&self, i: usize) -> f32 {
        self.lambda[i]
    }

    /// All the wavelengths (nm).
    pub fn lambdas(&self) -> [f32; N_SAMPLES] {
        self.lambda
    }

    /// The density each wavelength was drawn with (zero for a terminated one).
    pub fn pdf(&self) -> SampledSpectrum {
        SampledSpectrum(self.pdf)
    }

    /// Keeps the hero wavelength alone (a dispersive event): the others get pdf 0 and the
    /// hero's pdf is divided by [`N_SAMPLES`], so that estimates stay unbiased. Idempotent.
    pub fn terminate_secondary(&mut self) {
        if self.secondary_terminated() {
            return;
        }
        for p in &mut self.pdf[1..] {
            *p = 0.0;
        }
        self.pdf[0] /= N_SAMPLES as f32;
    }

    /// Whether [`terminate_secondary`](Self::terminate_secondary) has run.
    pub fn secondary_terminated(&self) -> bool {
        self.pdf[1..].iter().all(|&p| p == 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::cie::Illuminant;

    #[test]
    fn the_visible_pdf_is_the_derivative_of_its_sampling() {
        // Inverse-CDF sampling: dλ/du = 1 / p(λ(u)), by central differences.
        for k in 1..100 {
            let u = k as f64 / 100.0;
            let h = 1e-4;
            let l = |u: f64| sample_visible_wavelength(u as f32) as f64;
            let dl_du = (l(u + h) - l(u - h)) / (2.0 * h);
            let p = visible_wavelengths_pdf(l(u) as f32) as f64;
            assert!((dl_du * p - 1.0).abs() < 2e-3, "u {u}: {}", dl_du * p);
        }
        // The ends of [0, 1) land at the ends of the visible range.
        assert!((sample_visible_wavelength(0.0) - 360.0).abs() < 0.5);
        assert!((sample_visible_wavelength(1.0) - 830.0).abs() < 0.5);
        // The density integrates to one over 360 to 830 nm.
        let total: f64 = (0..47000)
            .map(|i| visible_wavelengths_pdf(360.0 + (i as f32 + 0.5) * 0.01) as f64 * 0.01)
            .sum();
        assert!((total - 1.0).abs() < 1e-3, "{total}");
    }

    #[test]
    fn uniform_wavelengths_are_stratified_and_wrap() {
        let w = SampledWavelengths::sample_uniform(0.9);
        let l = w.lambdas();
        assert!((l[0] - (360.0 + 0.9 * 470.0)).abs() < 1e-3);
        for i in 1..N_SAMPLES {
            let d = (l[i] - l[i - 1]).rem_euclid(470.0);
            assert!((d - 470.0 / N_SAMPLES as f32).abs() < 1e-3, "{l:?}");
            assert!((360.0..=830.0).contains(&l[i]));
        }
        assert_eq!(w.pdf(), SampledSpectrum::splat(1.0 / 470.0));
    }

    #[test]
    fn terminating_secondaries_keeps_the_hero_with_its_share_of_the_pdf() {
        let mut w = SampledWavelengths::sample_visible(0.3);
        let p0 = w.pdf()[0];
        assert!(!w.secondary_terminated());
        w.terminate_secondary();
        assert!(w.secondary_terminated());
        assert_eq!(w.pdf().0, [p0 / 3.0, 0.0, 0.0]);
        w.terminate_secondary();
        assert_eq!(w.pdf()[0], p0 / 3.0);
    }

    #[test]
    fn arithmetic_is_per_wavelength() {
        let a = SampledSpectrum([1.0, 2.0, 4.0]);
        let b = SampledSpectrum([2.0, 0.0, 8.0]);
        assert_eq!((a + b).0, [3.0, 2.0, 12.0]);
        assert_eq!((a - b).0, [-1.0, 2.0, -4.0]);
        assert_eq!((a * b).0, [2.0, 0.0, 32.0]);
        assert_eq!(a.safe_div(b).0, [0.5, 0.0, 0.5]);
        assert_eq!((2.0 * a / 2.0), a);
        assert_eq!(a.average(), 7.0 / 3.0);
        assert_eq!((a.min_value(), a.max_value()), (1.0, 4.0));
        assert!(SampledSpectrum::ZERO.is_black() && !a.is_black());
    }

    /// The mean of `to_xyz` over stratified wavelength samples of D65.
    fn estimate(sample: impl Fn(f32) -> SampledWavelengths, terminate: bool) -> DVec3 {
        let n = 4000;
        let mut sum = DVec3::ZERO;
        for k in 0..n {
            let mut w = sample((k as f32 + 0.5) / n as f32);
            if terminate {
                w.terminate_secondary();
            }
            let s = SampledSpectrum(w.lambdas().map(|l| Illuminant::D65.eval(l as f64) as f32));
            sum += s.to_xyz(&w).as_dvec3();
        }
        sum / n as f64
    }

    #[test]
    fn the_xyz_estimate_converges_to_the_integral() {
        let exact = cie::spectrum_to_xyz(|l| Illuminant::D65.eval(l));
        for (name, xyz) in [
            (
                "visible",
                estimate(SampledWavelengths::sample_visible, false),
            ),
            (
                "uniform",
                estimate(SampledWavelengths::sample_uniform, false),
            ),
            (
                "hero only",
                estimate(SampledWavelengths::sample_visible, true),
            ),
        ] {
            let err = (xyz - exact).abs().max_element();
            assert!(err < 2e-3, "{name}: {xyz} against {exact}");
        }
    }
}
