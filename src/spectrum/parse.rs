//! A pbrt-v4 spectrum parameter, already split into its type and values, as a [`Spectrum`]:
//! `"rgb Kd" [r g b]`, `"spectrum Kd" [λ₀ v₀ λ₁ v₁ …]`, `"spectrum eta" "glass-BK7"`,
//! `"blackbody L" [T]` and `"float eta" [v]`.

use super::color_space::ColorSpace;
use super::rgb_to_spectrum::{RgbAlbedo, RgbIlluminant, RgbUnbounded};
use super::{named, Blackbody, PiecewiseLinear, Spectrum};

/// What a spectrum parameter describes, which decides how RGB becomes a spectrum (pbrt-v4's
/// `SpectrumType`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpectrumUse {
    /// A reflectance or transmittance in [0, 1].
    Albedo,
    /// Any positive quantity (an index of refraction, a scattering coefficient).
    Unbounded,
    /// Emission.
    Illuminant,
}

/// A parameter's values as the tokeniser gives them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Values<'a> {
    /// Numbers.
    Numbers(&'a [f64]),
    /// Quoted strings.
    Strings(&'a [String]),
}

/// Why a parameter is not a spectrum.
#[derive(Clone, Debug, PartialEq)]
pub enum ParseError {
    /// A `spectrum` string that names no known spectrum: in pbrt-v4, the name of a file of
    /// (wavelength, value) pairs, which the scene reader reads and hands back as numbers.
    NotNamed(String),
    /// Anything else, said in one line.
    Invalid(String),
}

impl std::fmt::Display for ParseError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ParseError::NotNamed(n) => write!(f, "\"{n}\" is not a named spectrum"),
            ParseError::Invalid(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for ParseError {}

fn invalid(m: impl Into<String>) -> ParseError {
    ParseError::Invalid(m.into())
}

fn numbers<'a>(ty: &str, values: Values<'a>) -> Result<&'a [f64], ParseError> {
    match values {
        Values::Numbers(v) => Ok(v),
        Values::Strings(_) => Err(invalid(format!("a \"{ty}\" parameter takes numbers"))),
    }
}

/// The spectrum of a parameter of type `ty` ("rgb", "spectrum", "blackbody" or "float")
/// with `values`, used as `usage`, RGB being in `space`.
pub fn parse(
    ty: &str,
    values: Values,
    usage: SpectrumUse,
    space: &ColorSpace,
) -> Result<Spectrum, ParseError> {
    match ty {
        "rgb" => {
            let v = numbers(ty, values)?;
            let &[r, g, b] = v else {
                return Err(invalid(format!(
                    "an rgb value takes 3 numbers, not {}",
                    v.len()
                )));
            };
            let rgb = [r as f32, g as f32, b as f32];
            if rgb.iter().any(|c| !c.is_finite() || *c < 0.0) {
                return Err(invalid(format!(
                    "rgb ({r}, {g}, {b}) has a negative or non-finite component"
                )));
            }
            Ok(match usage {
                SpectrumUse::Albedo => Spectrum::RgbAlbedo(
                    RgbAlbedo::new(space, rgb).map_err(|e| invalid(e.to_string()))?,
                ),
                SpectrumUse::Unbounded => Spectrum::RgbUnbounded(RgbUnbounded::new(space, rgb)),
                SpectrumUse::Illuminant => Spectrum::RgbIlluminant(RgbIlluminant::new(space, rgb)),
            })
        }
        "blackbody" => {
            let v = numbers(ty, values)?;
            match *v {
                [t] if t.is_finite() && t > 0.0 => Ok(Spectrum::Blackbody(Blackbody::new(t))),
                [t] => Err(invalid(format!(
                    "blackbody temperature {t} K is not positive"
                ))),
                _ => Err(invalid(format!(
                    "a blackbody takes 1 temperature, not {} numbers",
                    v.len()
                ))),
            }
        }
        "float" => {
            let v = numbers(ty, values)?;
            match *v {
                [c] if c.is_finite() => Ok(Spectrum::Constant(c as f32)),
                _ => Err(invalid("a float spectrum takes 1 finite number")),
            }
        }
        "spectrum" => match values {
            Values::Strings([name]) => named(name)
                .map(Spectrum::Named)
                .ok_or_else(|| ParseError::NotNamed(name.clone())),
            Values::Strings(s) => Err(invalid(format!("a spectrum takes 1 name, not {}", s.len()))),
            Values::Numbers(v) => {
                if v.len() % 2 != 0 {
                    return Err(invalid(format!(
                        "a sampled spectrum takes (wavelength, value) pairs: {} numbers is odd",
                        v.len()
                    )));
                }
                let pairs: Vec<(f32, f32)> = v
                    .chunks_exact(2)
                    .map(|p| (p[0] as f32, p[1] as f32))
                    .collect();
                if usage == SpectrumUse::Albedo {
                    if let Some(p) = pairs.iter().find(|p| !(0.0..=1.0).contains(&p.1)) {
                        return Err(invalid(format!(
                            "reflectance {} at {} nm is outside [0, 1]",
                            p.1, p.0
                        )));
                    }
                }
                PiecewiseLinear::new(&pairs)
                    .map(Spectrum::PiecewiseLinear)
                    .map_err(invalid)
            }
        },
        _ => Err(invalid(format!(
            "\"{ty}\" is not a spectrum type (rgb, spectrum, blackbody)"
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::{SampledSpectrum, SampledWavelengths};

    fn p(ty: &str, v: &[f64], usage: SpectrumUse) -> Result<Spectrum, ParseError> {
        parse(ty, Values::Numbers(v), usage, ColorSpace::srgb())
    }

    fn s(name: &str) -> Result<Spectrum, ParseError> {
        let names = [name.to_string()];
        parse(
            "spectrum",
            Values::Strings(&names),
            SpectrumUse::Unbounded,
            ColorSpace::srgb(),
        )
    }

    #[test]
    fn every_form_parses_to_its_kind() {
        use SpectrumUse::*;
        assert!(matches!(
            p("rgb", &[0.2, 0.4, 0.6], Albedo),
            Ok(Spectrum::RgbAlbedo(_))
        ));
        assert!(matches!(
            p("rgb", &[2.0, 0.4, 0.6], Unbounded),
            Ok(Spectrum::RgbUnbounded(_))
        ));
        assert!(matches!(
            p("rgb", &[2.0, 0.4, 0.6], Illuminant),
            Ok(Spectrum::RgbIlluminant(_))
        ));
        assert!(matches!(
            p("blackbody", &[3000.0], Illuminant),
            Ok(Spectrum::Blackbody(_))
        ));
        assert_eq!(p("float", &[1.5], Unbounded), Ok(Spectrum::Constant(1.5)));
        let Ok(Spectrum::PiecewiseLinear(pl)) = p("spectrum", &[400.0, 0.2, 600.0, 0.6], Albedo)
        else {
            panic!("a sampled spectrum");
        };
        assert!((pl.eval(500.0) - 0.4).abs() < 1e-6);
        assert_eq!(pl.eval(300.0), 0.0);
        assert!(matches!(s("metal-Au-k"), Ok(Spectrum::Named(n)) if n.name == "metal-Au-k"));
    }

    #[test]
    fn bad_values_are_one_line_errors() {
        use SpectrumUse::*;
        let bad = [
            p("rgb", &[0.2, 0.4], Albedo),
            p("rgb", &[0.2, 1.4, 0.1], Albedo),
            p("rgb", &[0.2, -1.0, 0.1], Illuminant),
            p("blackbody", &[-5.0], Illuminant),
            p("blackbody", &[3000.0, 1.0], Illuminant),
            p("spectrum", &[400.0, 0.2, 600.0], Unbounded),
            p("spectrum", &[600.0, 0.2, 400.0, 0.3], Unbounded),
            p("spectrum", &[400.0, 0.2, 600.0, 1.3], Albedo),
            p("spectrum", &[400.0, 0.2], Unbounded),
            p("point3", &[1.0, 2.0, 3.0], Unbounded),
        ];
        for r in bad {
            let e = r.expect_err("refused");
            let m = e.to_string();
            assert!(!m.is_empty() && !m.contains('\n'), "{m}");
        }
        assert_eq!(
            s("spds/lamp.spd"),
            Err(ParseError::NotNamed("spds/lamp.spd".into()))
        );
    }

    #[test]
    fn sampling_evaluates_each_wavelength() {
        let w = SampledWavelengths::sample_visible(0.37);
        for sp in [
            p("rgb", &[0.7, 0.2, 0.1], SpectrumUse::Albedo).unwrap(),
            p("blackbody", &[4000.0], SpectrumUse::Illuminant).unwrap(),
            s("glass-BK7").unwrap(),
            p(
                "spectrum",
                &[360.0, 1.0, 830.0, 2.0],
                SpectrumUse::Unbounded,
            )
            .unwrap(),
        ] {
            let v = sp.sample(&w);
            let want = SampledSpectrum(w.lambdas().map(|l| sp.eval(l)));
            assert_eq!(v, want);
            assert!(v.min_value() > 0.0);
        }
        assert_eq!(
            Spectrum::Constant(2.0).sample(&w),
            SampledSpectrum::splat(2.0)
        );
    }
}
