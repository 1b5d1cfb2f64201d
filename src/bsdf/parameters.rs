//! What a BSDF is made of, as plain values: the lobes of raylink's lobe mixture evaluated at
//! one point ([`Lobes`]), a metal's complex index ([`Conductor`]) and a dielectric coat
//! ([`Coating`]). Materials ([`crate::scene::materials`]) build them; nothing here knows a
//! scene.

use crate::math::Rgb;
use crate::spectrum::Named;
use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

/// The lobes of the BSDF at one point: kd/π Lambertian reflection, kdt/π Lambertian
/// transmission, ks reflection and kt transmission through an interface of index `ior`
/// (smooth, or GGX with `alphas`), optionally Fresnel-weighted, a thin sheet, or a metal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lobes {
    pub kd: Rgb,
    pub kdt: Rgb,
    pub ks: Rgb,
    pub kt: Rgb,
    /// Index of refraction of the inside (the side opposite the geometric normal).
    pub ior: f32,
    /// GGX (α_x, α_y); below 1e-3 the interface is smooth.
    pub alphas: (f32, f32),
    /// ks weighted by the dielectric Fresnel reflectance F, kt by 1 − F, kd by
    /// (1 − F(θi))(1 − F(θo)).
    pub fresnel: bool,
    /// A thin sheet: straight-through transmission, the sheet's reflectance for F.
    pub thin: bool,
    /// A metal: ks weighted by this index's Fresnel reflectance.
    pub conductor: Option<Conductor>,
    /// Only the Lambertian lobe anywhere on the material (decided from the material, not
    /// the point, so that a textured lobe that is zero here keeps the general path).
    pub lambertian: bool,
    /// What the lobes vary with wavelength that RGB cannot say (read in spectral mode only).
    pub spectral: SpectralParts,
}

/// The parts of a surface that a spectral render reads besides its colours: a glass's index
/// of refraction as a function of wavelength, a metal's measured complex index. RGB renders
/// use `ior` and the conductor's RGB values in their place.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SpectralParts {
    /// The interface's index of refraction by wavelength (a named dispersive glass).
    pub dispersion: Option<&'static Named>,
    /// The metal's η and k by wavelength.
    pub metal: Option<(&'static Named, &'static Named)>,
}

/// The named spectrum `name`, kept for the process: BSDFs refer to it instead of carrying
/// its tables, so that they stay small.
pub fn interned(name: &str) -> Option<&'static Named> {
    static KEPT: OnceLock<Mutex<HashMap<String, &'static Named>>> = OnceLock::new();
    let mut kept = KEPT.get_or_init(Default::default).lock().ok()?;
    if let Some(n) = kept.get(name) {
        return Some(*n);
    }
    let n: &'static Named = Box::leak(Box::new(crate::spectrum::named(name)?));
    kept.insert(name.to_owned(), n);
    Some(n)
}

impl SpectralParts {
    /// The measured η and k of the metal `name` (Ag, Al, Au, Cu, Cr, Ni, Ti), if known.
    pub fn metal_named(name: &str) -> Option<(&'static Named, &'static Named)> {
        let part = |p: &str| interned(&format!("metal-{name}-{p}"));
        Some((part("eta")?, part("k")?))
    }

    /// The index by wavelength of the glass `name` (pbrt-v4's names without `glass-`: BK7,
    /// BAF10, FK51A, LASF9, SF5, SF10, SF11, fused-silica), if known.
    pub fn glass_named(name: &str) -> Option<&'static Named> {
        interned(&format!("glass-{name}"))
    }

    /// The glass's name as [`SpectralParts::glass_named`] takes it.
    pub fn glass_name(&self) -> Option<&'static str> {
        self.dispersion.map(|n| n.name)
    }
}

/// A dielectric coat over a base (pbrt-v4's `coateddiffuse` and `coatedconductor`): light
/// refracts into a slab of index `ior` and `thickness`, bounces between the base and the coat
/// (absorbed along the way, optionally scattered by a medium), and leaves through the coat.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coating {
    /// Index of refraction of the coat (outside is vacuum).
    pub ior: f32,
    /// GGX α of the coat's interface; 0 is smooth.
    pub roughness: f32,
    /// GGX α along the bitangent when it differs from `roughness`.
    pub roughness_v: Option<f32>,
    /// Thickness in units of the medium's mean free path: light crossing it at angle θ keeps
    /// exp(−thickness/|cos θ|).
    pub thickness: f32,
    /// Single-scattering albedo of the medium in the coat; 0 is an absorbing, non-scattering
    /// coat.
    pub albedo: Rgb,
    /// Henyey–Greenstein asymmetry of the medium's scattering.
    pub g: f32,
    /// Longest random walk through the layers.
    pub max_depth: u32,
    /// Random walks per evaluation.
    pub samples: u32,
}

impl Default for Coating {
    /// pbrt-v4's defaults: a smooth coat of index 1.5 and thickness 0.01.
    fn default() -> Self {
        Coating {
            ior: 1.5,
            roughness: 0.0,
            roughness_v: None,
            thickness: 0.01,
            albedo: Rgb::ZERO,
            g: 0.0,
            max_depth: 10,
            samples: 1,
        }
    }
}

impl Coating {
    /// GGX (α_x, α_y) of the coat.
    pub fn alphas(&self) -> (f32, f32) {
        (self.roughness, self.roughness_v.unwrap_or(self.roughness))
    }
}

/// A conductor's complex index of refraction η + ik, per colour channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conductor {
    pub eta: Rgb,
    pub k: Rgb,
}

/// RGB (η, k) of the named metals: the widely used reductions of the measured spectra that
/// pbrt-v4 ships as `metal-<name>-eta` / `metal-<name>-k` (the values of pbrt-v3's and
/// Mitsuba's RGB builds).
const METALS: &[(&str, [f32; 3], [f32; 3])] = &[
    (
        "Cu",
        [0.200438, 0.924033, 1.10221],
        [3.91295, 2.45285, 2.14219],
    ),
    (
        "Au",
        [0.143119, 0.374957, 1.44248],
        [3.98316, 2.38572, 1.60322],
    ),
    (
        "Ag",
        [0.155265, 0.116723, 0.138342],
        [4.82835, 3.12225, 2.14696],
    ),
    (
        "Al",
        [1.65746, 0.880369, 0.521229],
        [9.22387, 6.26952, 4.837],
    ),
    ("CuZn", [0.444, 0.527, 1.094], [3.695, 2.765, 1.829]),
    ("MgO", [1.732, 1.736, 1.745], [0.0, 0.0, 0.0]),
    ("TiO2", [2.557, 2.651, 2.811], [0.0, 0.0, 0.0]),
];

impl Conductor {
    /// A named metal ("Cu", "Au", "Ag", "Al", "CuZn", "MgO", "TiO2"), `None` if unknown.
    pub fn named(name: &str) -> Option<Conductor> {
        METALS
            .iter()
            .find(|m| m.0 == name)
            .map(|&(_, eta, k)| Conductor {
                eta: Rgb::from(eta),
                k: Rgb::from(k),
            })
    }

    /// The names [`Conductor::named`] knows.
    pub fn names() -> impl Iterator<Item = &'static str> {
        METALS.iter().map(|m| m.0)
    }

    /// The conductor with normal-incidence reflectance `r` and no other parameter: η = 1,
    /// k = 2√r / √(1 − r) (pbrt-v4's `ConductorMaterial` given a `reflectance`).
    pub fn from_reflectance(r: Rgb) -> Conductor {
        let k = |r: f32| {
            let r = r.clamp(0.0, 0.9999);
            2.0 * r.sqrt() / (1.0 - r).sqrt()
        };
        Conductor {
            eta: Rgb::ONE,
            k: Rgb::new(k(r.x), k(r.y), k(r.z)),
        }
    }

    /// Fresnel reflectance per channel at incidence cosine `cos`.
    pub fn reflectance(&self, cos: f32) -> Rgb {
        crate::math::optics::fresnel_conductor(cos, self.eta, self.k)
    }
}
