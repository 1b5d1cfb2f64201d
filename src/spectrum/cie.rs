//! The CIE 1931 2° standard observer and the standard illuminants the colour spaces need.
//!
//! The colour matching functions are the CIE's 5 nm table (CIE 15:2004, Table T.4; 360 to
//! 830 nm) as the `colorbox` crate publishes it, linearly interpolated between its entries.
//! Integrals over wavelength are sums at 1 nm from 360 to 830 nm, as pbrt-v4's, and an
//! emission spectrum's XYZ is divided by [`y_integral`] (the sum of ȳ at the same 1 nm
//! steps), so that a spectrum of constant 1 has Y = 1.

use colorbox::tables::cie_1931_xyz as cmf;
use glam::DVec3;
use std::sync::OnceLock;

/// The shortest wavelength (nm) a spectrum is sampled at.
pub const LAMBDA_MIN: f32 = 360.0;
/// The longest wavelength (nm) a spectrum is sampled at.
pub const LAMBDA_MAX: f32 = 830.0;

/// Linear interpolation in a table of values every 5 nm from 360 nm; zero outside it.
fn lerp_5nm(table: &[f32], lambda: f64) -> f64 {
    let x = (lambda - 360.0) / 5.0;
    if !(0.0..=(table.len() - 1) as f64).contains(&x) {
        return 0.0;
    }
    let i = (x as usize).min(table.len() - 2);
    let t = x - i as f64;
    (1.0 - t) * table[i] as f64 + t * table[i + 1] as f64
}

/// The CIE 1931 2° colour matching functions x̄, ȳ, z̄ at `lambda` nm (zero outside 360 to
/// 830 nm).
pub fn cmf_xyz(lambda: f64) -> DVec3 {
    DVec3::new(
        lerp_5nm(cmf::X, lambda),
        lerp_5nm(cmf::Y, lambda),
        lerp_5nm(cmf::Z, lambda),
    )
}

/// ȳ alone at `lambda` nm.
pub fn cmf_y(lambda: f64) -> f64 {
    lerp_5nm(cmf::Y, lambda)
}

/// The 1 nm wavelengths of every integral: 360, 361, …, 830.
pub fn integration_wavelengths() -> impl Iterator<Item = f64> {
    (LAMBDA_MIN as u32..=LAMBDA_MAX as u32).map(f64::from)
}

/// Σ ȳ(λ) over [`integration_wavelengths`] (pbrt-v4's `CIE_Y_integral`, 106.857 for the 1 nm
/// table; this table's interpolation gives nearly the same).
pub fn y_integral() -> f64 {
    static Y: OnceLock<f64> = OnceLock::new();
    *Y.get_or_init(|| integration_wavelengths().map(cmf_y).sum())
}

/// The XYZ of an emission spectrum `s` (a function of nm): Σ cmf(λ) s(λ) / [`y_integral`],
/// so that a constant 1 has Y = 1.
pub fn spectrum_to_xyz(s: impl Fn(f64) -> f64) -> DVec3 {
    integration_wavelengths()
        .map(|l| cmf_xyz(l) * s(l))
        .sum::<DVec3>()
        / y_integral()
}

/// The standard illuminants, each scaled to luminance Y = 1 (as pbrt-v4 normalises its
/// named illuminants).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Illuminant {
    /// CIE standard illuminant D65 (average daylight, 6504 K): the white of sRGB, Rec.2020
    /// and DCI-P3 (D65).
    D65,
    /// The ACES white: the CIE daylight series at 6000 K (ACES 2065-1's "D60").
    AcesD60,
    /// CIE standard illuminant A (an incandescent lamp: Planck's law at 2856 K with the CIE's
    /// second radiation constant 1.435e-2 m·K).
    A,
}

impl Illuminant {
    /// Relative spectral power at `lambda` nm before normalisation (100 at 560 nm).
    fn raw(self, lambda: f64) -> f64 {
        match self {
            Illuminant::D65 => lerp_5nm(&D65, lambda),
            Illuminant::AcesD60 => lerp_5nm(&ACES_D60, lambda),
            Illuminant::A => {
                // CIE 15:2004, eq. 3.1 (the definition of illuminant A).
                let c2: f64 = 1.435e7; // nm·K
                let t: f64 = 2848.0; // the 1931 temperature with the old c2: 2856 K today
                100.0 * (560.0 / lambda).powi(5) * ((c2 / (t * 560.0)).exp() - 1.0)
                    / ((c2 / (t * lambda)).exp() - 1.0)
            }
        }
    }

    /// The illuminant's spectral power at `lambda` nm, scaled so that its Y is 1.
    pub fn eval(self, lambda: f64) -> f64 {
        static SCALE: [OnceLock<f64>; 3] = [OnceLock::new(), OnceLock::new(), OnceLock::new()];
        let scale = *SCALE[self as usize].get_or_init(|| {
            let y = spectrum_to_xyz(|l| self.raw(l)).y;
            1.0 / y
        });
        self.raw(lambda) * scale
    }
}

/// CIE standard illuminant D65, relative spectral power every 5 nm from 360 to 830 nm
/// (CIE 15:2004, Table T.1; ISO 11664-2). The same table pbrt-v4 holds (`CIE_Illum_D6500`).
#[rustfmt::skip]
const D65: [f32; 95] = [
    46.6383, 49.3637, 52.0891, 51.0323, 49.9755, 52.3118, 54.6482, 68.7015, 82.7549, 87.1204,
    91.4860, 92.4589, 93.4318, 90.0570, 86.6823, 95.7736, 104.865, 110.936, 117.008, 117.410,
    117.812, 116.336, 114.861, 115.392, 115.923, 112.367, 108.811, 109.082, 109.354, 108.578,
    107.802, 106.296, 104.790, 106.239, 107.689, 106.047, 104.405, 104.225, 104.046, 102.023,
    100.000, 98.1671, 96.3342, 96.0611, 95.7880, 92.2368, 88.6856, 89.3459, 90.0062, 89.8026,
    89.5991, 88.6489, 87.6987, 85.4936, 83.2886, 83.4939, 83.6992, 81.8630, 80.0268, 80.1207,
    80.2146, 81.2462, 82.2778, 80.2810, 78.2842, 74.0027, 69.7213, 70.6652, 71.6091, 72.9790,
    74.3490, 67.9765, 61.6040, 65.7448, 69.8856, 72.4863, 75.0870, 69.3398, 63.5927, 55.0054,
    46.4182, 56.6118, 66.8054, 65.0941, 63.3828, 63.8434, 64.3040, 61.8779, 59.4519, 55.7054,
    51.9590, 54.6998, 57.4406, 58.8765, 60.3125,
];

/// The ACES white, every 5 nm from 360 to 830 nm: the CIE daylight series (CIE 15:2004,
/// eq. 3.2–3.4 with Table T.2's S0, S1, S2) at a correlated colour temperature of 6000 K, as
/// the Academy's reference computation gives it and pbrt-v4 tabulates it (`ACES_Illum_D60`).
#[rustfmt::skip]
const ACES_D60: [f32; 95] = [
    38.3813, 40.6445, 42.9077, 42.05735, 41.207, 43.8121, 46.4172, 59.26285, 72.1085, 76.1756,
    80.2427, 81.4878, 82.7329, 80.13505, 77.5372, 86.5577, 95.5782, 101.72045, 107.8627,
    108.67115, 109.4796, 108.5873, 107.695, 108.6598, 109.6246, 106.6426, 103.6606, 104.42795,
    105.1953, 104.7974, 104.3995, 103.45635, 102.5132, 104.2813, 106.0494, 104.67885, 103.3083,
    103.4228, 103.5373, 101.76865, 100.0, 98.3769, 96.7538, 96.73515, 96.7165, 93.3013,
    89.8861, 90.91705, 91.948, 91.98965, 92.0313, 91.3008, 90.5703, 88.5077, 86.4451, 86.9551,
    87.4651, 85.6558, 83.8465, 84.20755, 84.5686, 85.9432, 87.3178, 85.3068, 83.2958, 78.66005,
    74.0243, 75.23535, 76.4464, 77.67465, 78.9029, 72.12575, 65.3486, 69.6609, 73.9732,
    76.6802, 79.3872, 73.28855, 67.1899, 58.18595, 49.182, 59.9723, 70.7626, 68.9039, 67.0452,
    67.5469, 68.0486, 65.4631, 62.8776, 58.88595, 54.8943, 57.8066, 60.7189, 62.2491, 63.7793,
];

/// The chromaticity (x, y) of an XYZ colour.
pub fn chromaticity(xyz: DVec3) -> (f64, f64) {
    let s = xyz.x + xyz.y + xyz.z;
    (xyz.x / s, xyz.y / s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_tables_cover_360_to_830_nm_every_5_nm() {
        for t in [cmf::X, cmf::Y, cmf::Z] {
            assert_eq!(t.len(), 95);
        }
        assert_eq!(cmf::MIN_WAVELENGTH, LAMBDA_MIN);
        assert_eq!(cmf::MAX_WAVELENGTH, LAMBDA_MAX);
        // ȳ is the photopic luminous efficiency: 1 at 555 nm.
        assert!((cmf_y(555.0) - 1.0).abs() < 1e-6);
        assert_eq!(cmf_xyz(359.0), DVec3::ZERO);
        assert_eq!(cmf_xyz(831.0), DVec3::ZERO);
    }

    #[test]
    fn the_y_integral_is_pbrts() {
        // pbrt-v4's CIE_Y_integral (the CIE's 1 nm table summed): 106.856895. The 5 nm table
        // interpolated linearly gives the same to 0.1 %.
        assert!(
            (y_integral() / 106.856895 - 1.0).abs() < 1e-3,
            "{}",
            y_integral()
        );
    }

    #[test]
    fn illuminant_chromaticities_are_the_published_white_points() {
        // CIE 15:2004 Table T.3 (2° observer): D65 (0.31272, 0.32903), A (0.44757, 0.40745);
        // the ACES white (SMPTE ST 2065-1): (0.32168, 0.33767).
        for (ill, x, y, tol) in [
            (Illuminant::D65, 0.31272, 0.32903, 2e-4),
            (Illuminant::A, 0.44757, 0.40745, 2e-4),
            (Illuminant::AcesD60, 0.32168, 0.33767, 3e-4),
        ] {
            let xyz = spectrum_to_xyz(|l| ill.eval(l));
            assert!((xyz.y - 1.0).abs() < 1e-9, "{ill:?} Y = {}", xyz.y);
            let (cx, cy) = chromaticity(xyz);
            assert!(
                (cx - x).abs() < tol && (cy - y).abs() < tol,
                "{ill:?}: ({cx}, {cy}) against ({x}, {y})"
            );
        }
    }
}
