//! RGB colour spaces: primaries, a white point and the illuminant whose colour is RGB
//! (1, 1, 1), with their RGB↔XYZ matrices derived from the primaries (pbrt-v4's
//! `RGBColorSpace`).

use super::cie::Illuminant;
use glam::{DMat3, DVec2, DVec3};
use std::sync::LazyLock;

/// A linear RGB colour space.
#[derive(Clone, Debug, PartialEq)]
pub struct ColorSpace {
    /// Its name as pbrt-v4's `ColorSpace` statement gives it.
    pub name: &'static str,
    /// Chromaticities (x, y) of the red, green and blue primaries.
    pub primaries: [DVec2; 3],
    /// Chromaticity of the white point, RGB (1, 1, 1).
    pub white: DVec2,
    /// The illuminant an RGB emitter's spectrum is built on, of chromaticity `white`.
    pub illuminant: Illuminant,
    xyz_from_rgb: DMat3,
    rgb_from_xyz: DMat3,
}

/// XYZ of the chromaticity `xy` at luminance Y = 1.
fn xyz_of(xy: DVec2) -> DVec3 {
    DVec3::new(xy.x / xy.y, 1.0, (1.0 - xy.x - xy.y) / xy.y)
}

impl ColorSpace {
    /// The colour space of the primaries `r`, `g`, `b` and the white `white` (chromaticities),
    /// whose RGB (1, 1, 1) is `white` at Y = 1. The matrix is [R G B] · diag(S) with S the
    /// weights that make the primaries, at luminance 1 each, add up to the white (SMPTE RP
    /// 177).
    pub fn new(
        name: &'static str,
        [r, g, b]: [DVec2; 3],
        white: DVec2,
        illuminant: Illuminant,
    ) -> Self {
        let m = DMat3::from_cols(xyz_of(r), xyz_of(g), xyz_of(b));
        let s = m.inverse() * xyz_of(white);
        let xyz_from_rgb = m * DMat3::from_diagonal(s);
        ColorSpace {
            name,
            primaries: [r, g, b],
            white,
            illuminant,
            xyz_from_rgb,
            rgb_from_xyz: xyz_from_rgb.inverse(),
        }
    }

    /// The matrix taking linear RGB to CIE XYZ.
    pub fn xyz_from_rgb(&self) -> DMat3 {
        self.xyz_from_rgb
    }

    /// The matrix taking CIE XYZ to linear RGB.
    pub fn rgb_from_xyz(&self) -> DMat3 {
        self.rgb_from_xyz
    }

    /// XYZ of a linear RGB colour.
    pub fn rgb_to_xyz(&self, rgb: DVec3) -> DVec3 {
        self.xyz_from_rgb * rgb
    }

    /// The luminance (Y) of a linear RGB colour.
    pub fn luminance(&self, rgb: glam::Vec3) -> f32 {
        self.rgb_to_xyz(rgb.as_dvec3()).y as f32
    }

    /// Linear RGB of an XYZ colour.
    pub fn xyz_to_rgb(&self, xyz: DVec3) -> DVec3 {
        self.rgb_from_xyz * xyz
    }

    /// sRGB (IEC 61966-2-1) and Rec.709 primaries, D65 white.
    pub fn srgb() -> &'static ColorSpace {
        static S: LazyLock<ColorSpace> = LazyLock::new(|| {
            ColorSpace::new(
                "srgb",
                [
                    DVec2::new(0.64, 0.33),
                    DVec2::new(0.30, 0.60),
                    DVec2::new(0.15, 0.06),
                ],
                D65_WHITE,
                Illuminant::D65,
            )
        });
        &S
    }

    /// ITU-R BT.2020 primaries, D65 white.
    pub fn rec2020() -> &'static ColorSpace {
        static S: LazyLock<ColorSpace> = LazyLock::new(|| {
            ColorSpace::new(
                "rec2020",
                [
                    DVec2::new(0.708, 0.292),
                    DVec2::new(0.170, 0.797),
                    DVec2::new(0.131, 0.046),
                ],
                D65_WHITE,
                Illuminant::D65,
            )
        });
        &S
    }

    /// DCI-P3 primaries (SMPTE EG 432-1) with a D65 white (Display P3's gamut).
    pub fn dci_p3() -> &'static ColorSpace {
        static S: LazyLock<ColorSpace> = LazyLock::new(|| {
            ColorSpace::new(
                "dci-p3",
                [
                    DVec2::new(0.680, 0.320),
                    DVec2::new(0.265, 0.690),
                    DVec2::new(0.150, 0.060),
                ],
                D65_WHITE,
                Illuminant::D65,
            )
        });
        &S
    }

    /// ACES2065-1 (SMPTE ST 2065-1): the AP0 primaries, which enclose the spectral locus, and
    /// the ACES white (about D60).
    pub fn aces2065_1() -> &'static ColorSpace {
        static S: LazyLock<ColorSpace> = LazyLock::new(|| {
            ColorSpace::new(
                "aces2065-1",
                [
                    DVec2::new(0.7347, 0.2653),
                    DVec2::new(0.0, 1.0),
                    DVec2::new(0.0001, -0.0770),
                ],
                DVec2::new(0.32168, 0.33767),
                Illuminant::AcesD60,
            )
        });
        &S
    }

    /// Every colour space raylink knows.
    pub fn all() -> [&'static ColorSpace; 4] {
        [
            Self::srgb(),
            Self::rec2020(),
            Self::dci_p3(),
            Self::aces2065_1(),
        ]
    }

    /// The colour space of pbrt-v4's name ("srgb", "rec2020", "dci-p3", "aces2065-1").
    pub fn named(name: &str) -> Option<&'static ColorSpace> {
        Self::all().into_iter().find(|c| c.name == name)
    }
}

/// The D65 white point of sRGB, Rec.2020 and DCI-P3 (D65) as their standards give it.
const D65_WHITE: DVec2 = DVec2::new(0.3127, 0.3290);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::cie;

    #[test]
    fn srgb_matrix_is_the_published_one() {
        // IEC 61966-2-1:1999, the RGB to XYZ matrix (given to four decimals).
        let published = [
            [0.4124, 0.3576, 0.1805],
            [0.2126, 0.7152, 0.0722],
            [0.0193, 0.1192, 0.9505],
        ];
        let m = ColorSpace::srgb().xyz_from_rgb();
        for (r, row) in published.iter().enumerate() {
            for (c, &v) in row.iter().enumerate() {
                let got = m.col(c)[r];
                assert!((got - v).abs() < 1e-4, "[{r}][{c}] {got} against {v}");
            }
        }
    }

    #[test]
    fn white_is_one_and_primaries_are_their_chromaticities() {
        for cs in ColorSpace::all() {
            let w = cs.xyz_to_rgb(xyz_of(cs.white));
            assert!(
                (w - DVec3::ONE).abs().max_element() < 1e-12,
                "{}: {w}",
                cs.name
            );
            assert!((cs.rgb_to_xyz(DVec3::ONE).y - 1.0).abs() < 1e-12);
            for (i, p) in cs.primaries.iter().enumerate() {
                let xyz = cs.rgb_to_xyz(DVec3::AXES[i]);
                let (x, y) = cie::chromaticity(xyz);
                assert!((x - p.x).abs() < 1e-12 && (y - p.y).abs() < 1e-12);
            }
            let id = cs.rgb_from_xyz() * cs.xyz_from_rgb();
            assert!(id.abs_diff_eq(DMat3::IDENTITY, 1e-12));
            // The illuminant's spectrum is the white: RGB (1, 1, 1) to 1e-3.
            let ill = cs.illuminant;
            let rgb = cs.xyz_to_rgb(cie::spectrum_to_xyz(|l| ill.eval(l)));
            assert!(
                (rgb - DVec3::ONE).abs().max_element() < 1e-3,
                "{}: {rgb}",
                cs.name
            );
        }
    }

    #[test]
    fn names_are_pbrts() {
        for n in ["srgb", "rec2020", "dci-p3", "aces2065-1"] {
            assert_eq!(ColorSpace::named(n).unwrap().name, n);
        }
        assert!(ColorSpace::named("adobe-rgb").is_none());
    }
}
