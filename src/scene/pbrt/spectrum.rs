//! Spectra as RGB. pbrt-v4 renders spectrally; raylink renders linear sRGB. RGB values pass
//! through unchanged (pbrt-v4 normalises an RGB illuminant so that RGB (1, 1, 1) is the
//! colour space's white of luminance 1). Named spectra come from small tables of RGB
//! approximations; sampled spectra and blackbodies are integrated against the CIE 1931
//! matching functions' tables.

use crate::math::Rgb;
use crate::scene::Conductor;
use crate::spectrum::{cie, ColorSpace};
use glam::DVec3;

/// What a spectrum stands for, which decides how it becomes RGB.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    /// A reflectance in [0, 1]: integrated, then adapted so that a constant 1 is white.
    Reflectance,
    /// An emitter: integrated and normalised to luminance 1 (pbrt-v4 divides light spectra
    /// by their luminance and applies `scale`).
    Illuminant,
    /// An index of refraction or absorption: sampled at one wavelength per channel.
    Unbounded,
}

/// Wavelengths (nm) standing for R, G and B when a spectrum is sampled per channel.
const RGB_WAVELENGTHS: [f64; 3] = [610.0, 550.0, 465.0];

/// Refractive indices (at the sodium d line) of pbrt-v4's named glasses.
const GLASSES: &[(&str, f32)] = &[
    ("BK7", 1.5168),
    ("BAF10", 1.6700),
    ("FK51A", 1.4866),
    ("LASF9", 1.8503),
    ("F5", 1.6034),
    ("SF5", 1.6727),
    ("F10", 1.7283),
    ("SF10", 1.7283),
    ("F11", 1.7847),
    ("SF11", 1.7847),
];

/// An RGB value for a named pbrt-v4 spectrum, and whether it is only an approximation worth
/// a warning. `None` for names raylink does not know.
pub fn named(name: &str) -> Option<(Rgb, bool)> {
    if let Some(rest) = name.strip_prefix("metal-") {
        let (metal, part) = rest.rsplit_once('-')?;
        let c = Conductor::named(metal)?;
        return match part {
            "eta" => Some((c.eta, false)),
            "k" => Some((c.k, false)),
            _ => None,
        };
    }
    if let Some(glass) = name.strip_prefix("glass-") {
        let &(_, ior) = GLASSES.iter().find(|g| g.0 == glass)?;
        return Some((Rgb::splat(ior), false));
    }
    match name {
        // sRGB's white is D65: RGB (1, 1, 1).
        "stdillum-D65" => Some((Rgb::ONE, false)),
        "stdillum-A" => Some((blackbody(2856.0), false)),
        n if n.starts_with("stdillum-") || n.starts_with("illum-") => Some((Rgb::ONE, true)),
        _ => None,
    }
}

/// pbrt-v4's default conductor: copper.
pub fn copper() -> (Rgb, Rgb) {
    let c = Conductor::named("Cu").expect("copper is a named metal");
    (c.eta, c.k)
}

/// A piecewise-linear spectrum given as (wavelength, value) pairs, as RGB.
pub fn sampled(pairs: &[f64], kind: Kind) -> Rgb {
    let pts: Vec<(f64, f64)> = pairs.chunks_exact(2).map(|p| (p[0], p[1])).collect();
    let eval = |l: f64| -> f64 {
        let Some(first) = pts.first() else { return 0.0 };
        if l <= first.0 {
            return first.1;
        }
        for w in pts.windows(2) {
            if l <= w[1].0 {
                let t = (l - w[0].0) / (w[1].0 - w[0].0).max(1e-12);
                return w[0].1 + t * (w[1].1 - w[0].1);
            }
        }
        pts.last().map_or(0.0, |p| p.1)
    };
    match kind {
        Kind::Unbounded => Rgb::from(RGB_WAVELENGTHS.map(|l| eval(l) as f32)),
        _ => integrate(eval, kind),
    }
}

/// A blackbody emitter of temperature `kelvin`, normalised to luminance 1.
pub fn blackbody(kelvin: f64) -> Rgb {
    let t = kelvin.max(1.0);
    integrate(
        |l| crate::spectrum::blackbody::planck(l, t),
        Kind::Illuminant,
    )
}

fn xyz_to_srgb(xyz: DVec3) -> [f64; 3] {
    ColorSpace::srgb().xyz_to_rgb(xyz).to_array()
}

/// XYZ of `f` over 360–830 nm (the CIE 1931 tables, every nanometre), scaled so that a
/// constant 1 has Y = 1.
fn xyz_of(f: impl Fn(f64) -> f64) -> DVec3 {
    cie::spectrum_to_xyz(f)
}

fn integrate(f: impl Fn(f64) -> f64, kind: Kind) -> Rgb {
    let xyz = xyz_of(f);
    let rgb = xyz_to_srgb(xyz);
    let out = match kind {
        Kind::Illuminant => {
            let y = xyz.y.max(1e-30);
            rgb.map(|c| c / y)
        }
        _ => {
            // Adapt from the equal-energy white to RGB (1, 1, 1).
            let white = xyz_to_srgb(xyz_of(|_| 1.0));
            [0, 1, 2].map(|i| rgb[i] / white[i])
        }
    };
    Rgb::from(out.map(|c| c.max(0.0) as f32))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_reflectance_is_white_and_blackbodies_have_unit_luminance() {
        let white = sampled(&[300.0, 0.5, 900.0, 0.5], Kind::Reflectance);
        assert!(
            (white - Rgb::splat(0.5)).abs().max_element() < 1e-4,
            "{white}"
        );
        for t in [2000.0, 6500.0, 10000.0] {
            let c = blackbody(t);
            let y = crate::math::luminance(c);
            assert!((y - 1.0).abs() < 0.03, "{t} K: {c} (Y {y})");
        }
        // The CIE tables, as the spectral renderer's blackbody emitters integrate them.
        for t in [2700.0, 6500.0] {
            let exact = crate::spectrum::BlackbodyEmission::new(t).unwrap().rgb();
            assert!((blackbody(t) - exact).abs().max_element() < 1e-5, "{t} K");
        }
        // Warm light is red-heavy, a hot one blue-heavy.
        assert!(blackbody(2000.0).x > blackbody(2000.0).z);
        assert!(blackbody(12000.0).z > blackbody(12000.0).x);
    }

    #[test]
    fn named_spectra() {
        let (eta, _) = named("metal-Au-eta").unwrap();
        assert!((eta.x - 0.143119).abs() < 1e-6);
        assert_eq!(named("glass-BK7").unwrap().0, Rgb::splat(1.5168));
        assert_eq!(named("stdillum-D65").unwrap().0, Rgb::ONE);
        assert!(named("metal-Unobtainium-eta").is_none());
        let eta = sampled(&[400.0, 1.0, 700.0, 2.0], Kind::Unbounded);
        assert!((eta.y - (1.0 + 150.0 / 300.0) as f32).abs() < 1e-5);
    }
}
