//! Spectral mode: a path carries the values of light at [`N_SAMPLES`] wavelengths in place of
//! red, green and blue (pbrt-v4's hero-wavelength sampling, Wilkie et al. 2014), in the same
//! three-channel carrier, so that every BSDF and light evaluates unchanged on them once the
//! scene's colours are replaced by their spectra at those wavelengths ([`Colours`]).
//!
//! The scene's RGB colours are the linear sRGB of the scene; reflectances become Jakob and
//! Hanika's smooth spectra of that colour under the colour space's illuminant, emitters the
//! same spectrum times the illuminant (D65: white (1, 1, 1) is D65 at luminance 1), so a
//! scene without dispersion or measured metals keeps its colours. A glass with a named
//! dispersion refracts each path at its hero wavelength alone (the others are terminated),
//! and a named metal reflects by its measured η and k. A sample's value is estimated in CIE
//! XYZ from its wavelengths and converted to the output's linear sRGB.

use crate::bsdf::{Bsdf, Conductor, LobeColours};
use crate::error::{Error, Result};
use crate::math::{Ray, Rgb, Vec3};
use crate::scene::materials::Surface;
use crate::scene::media::{MediumKind, MediumModel, MediumPoint, Segment};
use crate::scene::Scene;
use crate::spectrum::rgb_to_spectrum::{solve, SigmoidPolynomial};
use crate::spectrum::{
    BlackbodyEmission, ColorSpace, SampledSpectrum, SampledWavelengths, N_SAMPLES,
};
use std::collections::HashMap;
use std::sync::{OnceLock, RwLock};

/// How a path turns the scene's colours into the values it carries: unchanged in RGB
/// renders ([`RgbColours`]), values at the path's wavelengths in spectral ones
/// ([`Wavelengths`]).
pub trait Colours {
    /// The BSDF at a vertex with its colours as the path carries them (a dispersive glass
    /// may terminate the path's secondary wavelengths).
    fn bsdf<'a>(&mut self, bsdf: Bsdf<'a>) -> Bsdf<'a>;
    /// Emitted radiance given as RGB, of the blackbody `shape` gives, if any (asked only in
    /// spectral renders: RGB ones need no more than the RGB).
    fn emission(&self, rgb: Rgb, shape: impl FnOnce() -> Option<BlackbodyEmission>) -> Rgb;
    /// The RGB a film takes of values the path carries.
    fn output(&self, v: Rgb) -> Rgb;
    /// Calls `f` with the medium `model` whose coefficients are as the path carries them.
    fn medium<R>(&self, model: &dyn MediumModel, f: impl FnOnce(&dyn MediumModel) -> R) -> R;
}

/// RGB rendering: colours are what the path carries.
#[derive(Clone, Copy, Debug, Default)]
pub struct RgbColours;

impl Colours for RgbColours {
    #[inline(always)]
    fn bsdf<'a>(&mut self, bsdf: Bsdf<'a>) -> Bsdf<'a> {
        bsdf
    }

    #[inline(always)]
    fn emission(&self, rgb: Rgb, _shape: impl FnOnce() -> Option<BlackbodyEmission>) -> Rgb {
        rgb
    }

    #[inline(always)]
    fn output(&self, v: Rgb) -> Rgb {
        v
    }

    #[inline(always)]
    fn medium<R>(&self, model: &dyn MediumModel, f: impl FnOnce(&dyn MediumModel) -> R) -> R {
        f(model)
    }
}

/// A path's wavelengths (hero first) and what the scene's colours are at them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wavelengths {
    lambda: SampledWavelengths,
}

impl Wavelengths {
    /// The wavelengths of the sample `u` in [0, 1): pbrt-v4's visible-light sampling, which
    /// puts them where the eye is sensitive.
    pub fn sample(u: f32) -> Wavelengths {
        Wavelengths {
            lambda: SampledWavelengths::sample_visible(u),
        }
    }

    /// A reflectance given as RGB (components above 1 are taken as an unbounded spectrum).
    pub fn albedo(&self, rgb: Rgb) -> Rgb {
        if rgb.max_element() > 1.0 {
            return self.unbounded(rgb);
        }
        if grey(rgb) {
            return rgb;
        }
        self.at(&polynomial(rgb), 1.0)
    }

    /// A positive quantity of any size given as RGB (pbrt-v4's `RGBUnboundedSpectrum`).
    pub fn unbounded(&self, rgb: Rgb) -> Rgb {
        let m = rgb.max_element();
        if m <= 0.0 {
            return Rgb::ZERO;
        }
        if grey(rgb) {
            return rgb;
        }
        let scale = 2.0 * m;
        self.at(&polynomial(rgb.max(Rgb::ZERO) / scale), scale)
    }

    /// Emission given as RGB: the unbounded spectrum times the colour space's illuminant,
    /// whose luminance is 1 (pbrt-v4's `RGBIlluminantSpectrum`).
    pub fn illuminant(&self, rgb: Rgb) -> Rgb {
        let shape = self.unbounded(rgb);
        let space = ColorSpace::srgb();
        let l = self.lambda.lambdas();
        Rgb::from(std::array::from_fn::<f32, N_SAMPLES, _>(|i| {
            shape[i] * space.illuminant.eval(l[i] as f64) as f32
        }))
    }

    /// The linear sRGB estimate of the values `v` carried at these wavelengths.
    pub fn rgb_of(&self, v: Rgb) -> Rgb {
        SampledSpectrum(v.to_array()).to_rgb(&self.lambda, ColorSpace::srgb())
    }

    #[cfg(test)]
    /// The wavelengths with `hero` first and the others spread as [`Wavelengths::sample`]
    /// spreads them.
    pub fn with_hero(hero: f32) -> Wavelengths {
        let u = crate::spectrum::sampled::visible_wavelengths_cdf(hero);
        Wavelengths::sample(u)
    }

    #[cfg(test)]
    /// The hero wavelength (nm).
    pub fn hero(&self) -> f32 {
        self.lambda.lambda(0)
    }

    fn at(&self, s: &SigmoidPolynomial, scale: f32) -> Rgb {
        Rgb::from(self.lambda.lambdas().map(|l| scale * s.eval(l)))
    }
}

impl Colours for Wavelengths {
    fn bsdf<'a>(&mut self, bsdf: Bsdf<'a>) -> Bsdf<'a> {
        let c = bsdf.colours();
        let parts = bsdf.spectral_parts();
        let mut ior = c.ior;
        if let Some(glass) = parts.dispersion {
            if c.kt.max_element() > 0.0 || c.ks.max_element() > 0.0 {
                // One index for the path from here on: the hero's.
                ior = glass.eval(self.lambda.lambda(0));
                self.lambda.terminate_secondary();
            }
        }
        let conductor = c.conductor.map(|metal| match parts.metal {
            Some((eta, k)) => Conductor {
                eta: Rgb::from(eta.sample(&self.lambda).0),
                k: Rgb::from(k.sample(&self.lambda).0),
            },
            None => Conductor {
                eta: self.unbounded(metal.eta),
                k: self.unbounded(metal.k),
            },
        });
        bsdf.with_colours(LobeColours {
            kd: self.albedo(c.kd),
            kdt: self.albedo(c.kdt),
            ks: self.albedo(c.ks),
            kt: self.albedo(c.kt),
            ior,
            conductor,
        })
    }

    fn emission(&self, rgb: Rgb, shape: impl FnOnce() -> Option<BlackbodyEmission>) -> Rgb {
        match shape() {
            // Planck's law at the luminance of the RGB (the emitter's RGB is the
            // blackbody's, times its luminance and whatever scales it on the way).
            Some(body) => {
                let y = ColorSpace::srgb().luminance(rgb);
                Rgb::from(body.sample(&self.lambda, y).0)
            }
            None => self.illuminant(rgb),
        }
    }

    fn output(&self, v: Rgb) -> Rgb {
        self.rgb_of(v)
    }

    fn medium<R>(&self, model: &dyn MediumModel, f: impl FnOnce(&dyn MediumModel) -> R) -> R {
        match model.colours() {
            Some(unit) if !is_grey_absorber(unit) => f(&MediumAt::new(model, unit, self)),
            // Grey coefficients are the same at every wavelength; other media are refused
            // by `check_scene`.
            _ => f(model),
        }
    }
}

/// Whether a medium of coefficients `unit` is the same at every wavelength: grey σa and σs,
/// and no emission (an emitter's white is the colour space's illuminant, not a constant).
fn is_grey_absorber(unit: &MediumPoint) -> bool {
    grey(unit.sigma_a) && grey(unit.sigma_s) && unit.le * unit.sigma_a == Rgb::ZERO
}

/// A medium of one set of colours scaled by a density ([`MediumModel::colours`]) at a
/// path's wavelengths: the colours become spectra once, and each point's density (and
/// emission scale) is read back from the RGB medium as the ratio to its colours. Its
/// majorants are the densities' bounds times the spectra.
struct MediumAt<'a> {
    model: &'a dyn MediumModel,
    /// The largest channel of σt and of Le at density 1 (RGB).
    sigma_t_max: f32,
    le_max: f32,
    /// The coefficients at density 1 at the path's wavelengths.
    values: MediumPoint,
}

impl<'a> MediumAt<'a> {
    fn new(model: &'a dyn MediumModel, unit: &MediumPoint, lambda: &Wavelengths) -> Self {
        MediumAt {
            model,
            sigma_t_max: (unit.sigma_a + unit.sigma_s).max_element(),
            le_max: unit.le.max_element(),
            values: MediumPoint {
                sigma_a: lambda.unbounded(unit.sigma_a),
                sigma_s: lambda.unbounded(unit.sigma_s),
                le: lambda.illuminant(unit.le),
                g: unit.g,
            },
        }
    }

    fn ratio(x: f32, unit: f32) -> f32 {
        if unit > 0.0 {
            x / unit
        } else {
            0.0
        }
    }
}

/// Headroom on a majorant for the rounding of a density read back as a ratio.
const MAJORANT_HEADROOM: f32 = 1.0 + 1e-5;

impl MediumModel for MediumAt<'_> {
    fn kind(&self) -> &'static str {
        self.model.kind()
    }

    fn at(&self, p: Vec3) -> MediumPoint {
        let rgb = self.model.at(p);
        let density = Self::ratio((rgb.sigma_a + rgb.sigma_s).max_element(), self.sigma_t_max);
        let le_scale = Self::ratio(rgb.le.max_element(), self.le_max);
        MediumPoint {
            sigma_a: self.values.sigma_a * density,
            sigma_s: self.values.sigma_s * density,
            le: self.values.le * le_scale,
            g: rgb.g,
        }
    }

    fn segments(&self, ray: &Ray, t_max: f32, visit: &mut dyn FnMut(Segment) -> bool) {
        let sigma_t = self.values.sigma_a + self.values.sigma_s;
        self.model.segments(ray, t_max, &mut |s| {
            let bound = Self::ratio(s.sigma_maj.max_element(), self.sigma_t_max);
            visit(Segment {
                sigma_maj: sigma_t * (bound * MAJORANT_HEADROOM),
                ..s
            })
        });
    }

    fn emits(&self) -> bool {
        self.model.emits()
    }
}

/// Refuses what spectral mode does not render yet (for every technique that renders
/// spectrally, by `Technique::lifecycle`): RGB grid media whose colours vary (or emit),
/// measured reflectances (RGB tables) and coats whose medium is coloured.
pub(crate) fn check_scene(scene: &Scene) -> Result<()> {
    let refuse = |why: String| Err(Error::setting("spectral", why));
    for m in &scene.media {
        if let MediumKind::RgbGrid(grid) = &m.kind {
            if !grey_rgb_grid(grid) {
                return refuse(format!(
                    "medium \"{}\" is an rgbgrid with colours or emission, which spectral \
                     mode does not render (grey grids, homogeneous media and density grids \
                     it does)",
                    m.name
                ));
            }
        }
    }
    for m in scene.materials.iter() {
        let coat = match &m.surface {
            Surface::Measured(_) => {
                return refuse(format!(
                    "material \"{}\" is a measured RGB reflectance, which spectral mode does \
                     not render",
                    m.name
                ))
            }
            Surface::CoatedDiffuse(s) => s.coating(),
            Surface::CoatedConductor(s) => s.coating(),
            _ => continue,
        };
        if !grey(coat.albedo) {
            return refuse(format!(
                "material \"{}\" has a coloured coat albedo, which spectral mode does not \
                 render",
                m.name
            ));
        }
    }
    Ok(())
}

/// Whether an RGB grid is grey everywhere and emits nothing: the same at every wavelength.
fn grey_rgb_grid(grid: &crate::scene::media::RgbGrid) -> bool {
    let all_grey = |v: &[Rgb]| v.iter().copied().all(grey);
    grid.sigma_a().is_none_or(all_grey) && grid.sigma_s().is_none_or(all_grey) && !grid.emits()
}

/// Whether `rgb`'s channels are equal: a grey is the same number at every wavelength.
fn grey(rgb: Rgb) -> bool {
    rgb.x == rgb.y && rgb.y == rgb.z
}

/// The spectrum of the sRGB reflectance `rgb`, solved once per colour for the whole
/// process: a scene has few colours, and a texel's colour repeats from sample to sample.
fn polynomial(rgb: Rgb) -> SigmoidPolynomial {
    type Cache = RwLock<HashMap<[u32; 3], SigmoidPolynomial>>;
    static CACHE: OnceLock<Cache> = OnceLock::new();
    let cache = CACHE.get_or_init(Default::default);
    let key = rgb.to_array().map(f32::to_bits);
    if let Some(s) = cache.read().ok().and_then(|c| c.get(&key).copied()) {
        return s;
    }
    let s = solve(ColorSpace::srgb(), rgb.to_array());
    if let Ok(mut c) = cache.write() {
        c.insert(key, s);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::{Lobes, SpectralParts, Transport};
    use crate::math::{Vec2, Vec3};

    /// The mean over stratified wavelength samples of the linear sRGB estimate of `f`.
    fn mean_rgb(f: impl Fn(&Wavelengths) -> Rgb) -> Rgb {
        let n = 2000;
        (0..n)
            .map(|k| {
                let w = Wavelengths::sample((k as f32 + 0.5) / n as f32);
                w.rgb_of(f(&w))
            })
            .sum::<Rgb>()
            / n as f32
    }

    #[test]
    fn white_light_on_a_colour_gives_back_the_colour() {
        for rgb in [
            Rgb::new(0.63, 0.065, 0.05),
            Rgb::new(0.14, 0.45, 0.091),
            Rgb::new(0.2, 0.3, 0.9),
            Rgb::splat(0.725),
        ] {
            let seen = mean_rgb(|w| w.illuminant(Rgb::ONE) * w.albedo(rgb));
            assert!(
                (seen - rgb).abs().max_element() < 4e-3,
                "{rgb} seen as {seen}"
            );
        }
    }

    /// BK7's Sellmeier coefficients as Schott's catalogue gives them (typed here, not read
    /// from the renderer's table).
    fn bk7_index(lambda_nm: f64) -> f64 {
        let l2 = (lambda_nm * 1e-3).powi(2);
        let b = [1.039_612_12, 0.231_792_344, 1.010_469_45];
        let c = [0.006_000_698_67, 0.020_017_914_4, 103.560_653];
        (1.0 + (0..3).map(|i| b[i] * l2 / (l2 - c[i])).sum::<f64>()).sqrt()
    }

    /// Refraction through `bsdf`'s smooth interface of normal `n` for light arriving along
    /// `dir`.
    fn refract_through(bsdf: &Bsdf, n: Vec3, dir: Vec3) -> Vec3 {
        (0..64)
            .filter_map(|i| {
                let u = (i as f32 + 0.5) / 64.0;
                bsdf.sample(-dir, u, Vec2::splat(0.5), Transport::Radiance)
            })
            .find(|s| s.wi.dot(n) * dir.dot(n) > 0.0 && s.weight.max_element() > 0.0)
            .expect("the interface transmits")
            .wi
    }

    #[test]
    fn a_prism_bends_each_wavelength_by_snells_law() {
        // A 60° BK7 prism: light enters the left face at 50° and leaves the right one; the
        // exit angle at 450, 550 and 650 nm against Snell's law at both faces.
        let apex = 60f64.to_radians();
        let (s, c) = (apex / 2.0).sin_cos();
        let n1 = Vec3::new(-c as f32, 0.0, s as f32);
        let n2 = Vec3::new(c as f32, 0.0, s as f32);
        let theta1 = 50f64.to_radians();
        let a = theta1 - apex / 2.0;
        let dir = Vec3::new(a.cos() as f32, 0.0, a.sin() as f32);
        let glass = Lobes {
            kd: Rgb::ZERO,
            kdt: Rgb::ZERO,
            ks: Rgb::ONE,
            kt: Rgb::ONE,
            ior: 1.5168,
            alphas: (0.0, 0.0),
            fresnel: true,
            thin: false,
            conductor: None,
            lambertian: false,
            spectral: SpectralParts {
                dispersion: SpectralParts::glass_named("BK7"),
                metal: None,
            },
        };
        let mut exits = vec![];
        for lambda in [450.0, 550.0, 650.0] {
            let mut w = Wavelengths::with_hero(lambda);
            assert!((w.hero() - lambda).abs() < 0.01, "{}", w.hero());
            let face1 = w.bsdf(Bsdf::of_lobes(&glass, n1, n1));
            let inside = refract_through(&face1, n1, dir);
            let face2 = w.bsdf(Bsdf::of_lobes(&glass, n2, n2));
            let out = refract_through(&face2, n2, inside);
            let exit = (out.dot(n2) as f64).clamp(-1.0, 1.0).acos().to_degrees();
            let n = bk7_index(lambda as f64);
            let inner = (theta1.sin() / n).asin();
            let expected = (n * (apex - inner).sin()).asin().to_degrees();
            assert!(
                (exit - expected).abs() < 0.1,
                "{lambda} nm: exit {exit}°, Snell {expected}°"
            );
            assert!(w.lambda.secondary_terminated());
            exits.push(exit);
        }
        // Blue bends most: the spread is what RGB mode's one index cannot give.
        assert!(exits[0] - exits[2] > 0.5, "{exits:?}");
    }

    #[test]
    fn emitters_keep_their_colour_and_brightness() {
        for rgb in [Rgb::ONE, Rgb::new(17.0, 12.0, 4.0), Rgb::new(0.0, 0.5, 2.0)] {
            let seen = mean_rgb(|w| w.illuminant(rgb));
            let tol = 4e-3 * rgb.max_element();
            assert!(
                (seen - rgb).abs().max_element() < tol,
                "{rgb} seen as {seen}"
            );
        }
    }
}
