//! pbrt-v4's named spectra (`"metal-Cu-eta"`, `"glass-BK7"`, `"stdillum-D65"`, …) and the
//! dispersion models behind them: measured tables, Sellmeier and Cauchy glasses, and
//! Lorentz–Drude metals.

use super::cie::Illuminant;
use super::named_data::*;
use super::sampled::{SampledSpectrum, SampledWavelengths};

/// A glass's index of refraction by Sellmeier's equation:
/// n² = 1 + Σ Bᵢ λ² / (λ² − Cᵢ), λ in micrometres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sellmeier {
    /// B₁, B₂, B₃.
    pub b: [f64; 3],
    /// C₁, C₂, C₃ (µm²).
    pub c: [f64; 3],
}

impl Sellmeier {
    /// The index of refraction at `lambda` nm.
    pub fn eta(&self, lambda: f64) -> f64 {
        let l2 = (lambda * 1e-3).powi(2);
        let s: f64 = (0..3).map(|i| self.b[i] * l2 / (l2 - self.c[i])).sum();
        (1.0 + s).sqrt()
    }
}

/// A glass's index of refraction by Cauchy's equation: n = A + B / λ², λ in micrometres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cauchy {
    /// A.
    pub a: f64,
    /// B (µm²).
    pub b: f64,
}

impl Cauchy {
    /// The index of refraction at `lambda` nm.
    pub fn eta(&self, lambda: f64) -> f64 {
        self.a + self.b / (lambda * 1e-3).powi(2)
    }
}

/// A metal's permittivity by the Lorentz–Drude model of A. D. Rakić, A. B. Djurišić, J. M.
/// Elazar and M. L. Majewski, "Optical properties of metallic films for vertical-cavity
/// optoelectronic devices", Applied Optics 37(22), 5271–5283 (1998), Table 1 (energies in
/// eV), fitted there to the measurements of Palik's handbook over 0.1 to 6 eV:
/// ε(ω) = 1 − f₀ωₚ² / (ω(ω + iΓ₀)) + Σⱼ fⱼωₚ² / (ωⱼ² − ω² − iωΓⱼ).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LorentzDrude {
    /// The plasma frequency ωₚ (eV).
    pub plasma: f64,
    /// The free electrons' oscillator strength f₀ and damping Γ₀ (eV).
    pub drude: (f64, f64),
    /// The bound oscillators: strength fⱼ, frequency ωⱼ (eV) and damping Γⱼ (eV).
    pub lorentz: [(f64, f64, f64); 4],
}

impl LorentzDrude {
    /// The complex index of refraction (η, k) at `lambda` nm.
    pub fn eta_k(&self, lambda: f64) -> (f64, f64) {
        let w = 1_239.841_984 / lambda; // photon energy (eV)
        let wp2 = self.plasma * self.plasma;
        // 1 − f₀ωₚ² / (ω² + iωΓ₀).
        let (f0, g0) = self.drude;
        let (dr, di) = (w * w, w * g0);
        let d2 = dr * dr + di * di;
        let mut re = 1.0 - f0 * wp2 * dr / d2;
        let mut im = f0 * wp2 * di / d2;
        for &(f, wj, g) in &self.lorentz {
            let (dr, di) = (wj * wj - w * w, -w * g);
            let d2 = dr * dr + di * di;
            re += f * wp2 * dr / d2;
            im -= f * wp2 * di / d2;
        }
        // The root with a positive imaginary part.
        let r = re.hypot(im);
        (((r + re) / 2.0).sqrt(), ((r - re) / 2.0).sqrt())
    }
}

/// Chromium, Lorentz–Drude (Rakić et al. 1998).
pub const CHROMIUM: LorentzDrude = LorentzDrude {
    plasma: 10.75,
    drude: (0.168, 0.047),
    lorentz: [
        (0.151, 0.121, 3.175),
        (0.150, 0.543, 1.305),
        (1.149, 1.970, 2.676),
        (0.825, 8.775, 1.335),
    ],
};

/// Nickel, Lorentz–Drude (Rakić et al. 1998).
pub const NICKEL: LorentzDrude = LorentzDrude {
    plasma: 15.92,
    drude: (0.096, 0.048),
    lorentz: [
        (0.100, 0.174, 4.511),
        (0.135, 0.582, 1.334),
        (0.106, 1.597, 2.178),
        (0.729, 6.089, 6.292),
    ],
};

/// Titanium, Lorentz–Drude (Rakić et al. 1998).
pub const TITANIUM: LorentzDrude = LorentzDrude {
    plasma: 7.29,
    drude: (0.148, 0.082),
    lorentz: [
        (0.899, 0.777, 2.276),
        (0.393, 1.545, 2.518),
        (0.187, 2.509, 1.663),
        (0.001, 19.43, 1.762),
    ],
};

/// Schott's Sellmeier coefficients (Schott optical glass data sheets, 2017) and, for fused
/// silica, I. H. Malitson, "Interspecimen comparison of the refractive index of fused
/// silica", J. Opt. Soc. Am. 55(10), 1205–1209 (1965).
const GLASSES: &[(&str, Sellmeier)] = &[
    (
        "BK7",
        sellmeier(
            [1.039_612_12, 0.231_792_344, 1.010_469_45],
            [0.006_000_698_67, 0.020_017_914_4, 103.560_653],
        ),
    ),
    (
        "BAF10",
        sellmeier(
            [1.585_149_5, 0.143_559_385, 1.085_212_69],
            [0.009_266_812_82, 0.042_448_980_5, 105.613_573],
        ),
    ),
    (
        "FK51A",
        sellmeier(
            [0.971_247_817, 0.216_901_417, 0.904_651_666],
            [0.004_723_019_95, 0.015_357_561_2, 168.681_33],
        ),
    ),
    (
        "LASF9",
        sellmeier(
            [2.000_295_47, 0.298_926_886, 1.806_918_43],
            [0.012_142_601_7, 0.053_873_623_6, 156.530_829],
        ),
    ),
    (
        "SF5",
        sellmeier(
            [1.524_818_89, 0.187_085_527, 1.427_290_15],
            [0.011_254_756, 0.058_899_539_2, 129.141_675],
        ),
    ),
    (
        "SF10",
        sellmeier(
            [1.621_539_02, 0.256_287_842, 1.644_475_52],
            [0.012_224_145_7, 0.059_573_677_5, 147.468_793],
        ),
    ),
    (
        "SF11",
        sellmeier(
            [1.737_596_95, 0.313_747_346, 1.898_781_01],
            [0.013_188_707, 0.062_306_814_2, 155.236_29],
        ),
    ),
    (
        "fused-silica",
        sellmeier(
            [0.696_166_3, 0.407_942_6, 0.897_479_4],
            [
                0.068_404_3 * 0.068_404_3,
                0.116_241_4 * 0.116_241_4,
                9.896_161 * 9.896_161,
            ],
        ),
    ),
];

const fn sellmeier(b: [f64; 3], c: [f64; 3]) -> Sellmeier {
    Sellmeier { b, c }
}

/// Which part of a complex index of refraction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// The real part η.
    Eta,
    /// The extinction coefficient k.
    K,
}

/// What a named spectrum is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NamedKind {
    /// Measured values at increasing wavelengths (nm), linear between them, zero outside.
    Table {
        /// The wavelengths (nm).
        lambda: &'static [f32],
        /// The values.
        value: &'static [f32],
    },
    /// A glass's index of refraction.
    Sellmeier(Sellmeier),
    /// One part of a metal's index of refraction.
    LorentzDrude(LorentzDrude, Part),
    /// A standard illuminant (luminance 1).
    Illuminant(Illuminant),
}

/// A spectrum known by name.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Named {
    /// pbrt-v4's name (raylink's own for the ones pbrt-v4 lacks).
    pub name: &'static str,
    /// What it is.
    pub kind: NamedKind,
}

/// Linear interpolation in a table; zero outside it (pbrt-v4's `PiecewiseLinearSpectrum`).
pub(super) fn piecewise_linear(lambda: &[f32], value: &[f32], l: f32) -> f32 {
    let (Some(&first), Some(&last)) = (lambda.first(), lambda.last()) else {
        return 0.0;
    };
    if !(first..=last).contains(&l) {
        return 0.0;
    }
    let i = lambda
        .partition_point(|&x| x <= l)
        .clamp(1, lambda.len() - 1)
        - 1;
    if lambda.len() == 1 {
        return value[0];
    }
    let t = (l - lambda[i]) / (lambda[i + 1] - lambda[i]);
    value[i] + t * (value[i + 1] - value[i])
}

impl Named {
    /// The value at `lambda` nm.
    pub fn eval(&self, lambda: f32) -> f32 {
        match self.kind {
            NamedKind::Table { lambda: l, value } => piecewise_linear(l, value, lambda),
            NamedKind::Sellmeier(s) => s.eta(lambda as f64) as f32,
            NamedKind::LorentzDrude(m, part) => {
                let (eta, k) = m.eta_k(lambda as f64);
                match part {
                    Part::Eta => eta as f32,
                    Part::K => k as f32,
                }
            }
            NamedKind::Illuminant(i) => i.eval(lambda as f64) as f32,
        }
    }

    /// The values at the sampled wavelengths.
    pub fn sample(&self, lambda: &SampledWavelengths) -> SampledSpectrum {
        SampledSpectrum(lambda.lambdas().map(|l| self.eval(l)))
    }
}

/// The tabulated metals: name, η and k.
const METALS: &[(&str, &[f32; 56], &[f32; 56])] = &[
    ("Ag", &AG_ETA, &AG_K),
    ("Al", &AL_ETA, &AL_K),
    ("Au", &AU_ETA, &AU_K),
    ("Cu", &CU_ETA, &CU_K),
];

/// The metals given by a model: name and model.
const MODELLED_METALS: &[(&str, LorentzDrude)] =
    &[("Cr", CHROMIUM), ("Ni", NICKEL), ("Ti", TITANIUM)];

/// The pbrt-v4 spectrum called `name`, or `None`. Metals are `metal-X-eta` and `metal-X-k`
/// for X in Ag, Al, Au, Cu (pbrt-v4's tables) and Cr, Ni, Ti (raylink's, from their
/// Lorentz–Drude models); glasses are `glass-X` for BK7, BAF10, FK51A, LASF9, SF5 (or F5),
/// SF10 (F10), SF11 (F11) and fused-silica; illuminants are `stdillum-D65`, `stdillum-A`
/// and `illum-acesD60`.
pub fn named(name: &str) -> Option<Named> {
    let found = |name: &'static str, kind| Some(Named { name, kind });
    if let Some(rest) = name.strip_prefix("metal-") {
        let (metal, part) = rest.rsplit_once('-')?;
        let part = match part {
            "eta" => Part::Eta,
            "k" => Part::K,
            _ => return None,
        };
        if let Some(&(n, eta, k)) = METALS.iter().find(|m| m.0 == metal) {
            let value: &'static [f32] = if part == Part::Eta { eta } else { k };
            return found(
                static_name(n, part),
                NamedKind::Table {
                    lambda: &METAL_LAMBDA,
                    value,
                },
            );
        }
        let &(n, model) = MODELLED_METALS.iter().find(|m| m.0 == metal)?;
        return found(static_name(n, part), NamedKind::LorentzDrude(model, part));
    }
    if let Some(glass) = name.strip_prefix("glass-") {
        // pbrt-v4 names the Schott flints F5, F10 and F11 as well.
        let glass = match glass {
            "F5" => "SF5",
            "F10" => "SF10",
            "F11" => "SF11",
            g => g,
        };
        let (n, s) = GLASSES.iter().find(|g| g.0 == glass)?;
        return found(n, NamedKind::Sellmeier(*s));
    }
    let illuminant = match name {
        "stdillum-D65" => Illuminant::D65,
        "stdillum-A" => Illuminant::A,
        "illum-acesD60" => Illuminant::AcesD60,
        _ => return None,
    };
    let n = ["stdillum-D65", "stdillum-A", "illum-acesD60"]
        .into_iter()
        .find(|n| *n == name)?;
    found(n, NamedKind::Illuminant(illuminant))
}

/// The glasses [`named`] knows as `glass-X`, in its table's order.
pub fn glasses() -> impl Iterator<Item = &'static str> {
    GLASSES.iter().map(|g| g.0)
}

/// The static name of a metal's part.
fn static_name(metal: &str, part: Part) -> &'static str {
    const NAMES: &[(&str, &str, &str)] = &[
        ("Ag", "metal-Ag-eta", "metal-Ag-k"),
        ("Al", "metal-Al-eta", "metal-Al-k"),
        ("Au", "metal-Au-eta", "metal-Au-k"),
        ("Cu", "metal-Cu-eta", "metal-Cu-k"),
        ("Cr", "metal-Cr-eta", "metal-Cr-k"),
        ("Ni", "metal-Ni-eta", "metal-Ni-k"),
        ("Ti", "metal-Ti-eta", "metal-Ti-k"),
    ];
    let &(_, eta, k) = NAMES
        .iter()
        .find(|n| n.0 == metal)
        .expect("every metal has its names");
    match part {
        Part::Eta => eta,
        Part::K => k,
    }
}

#[cfg(test)]
mod tests;
