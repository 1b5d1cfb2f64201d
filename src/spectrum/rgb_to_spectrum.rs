//! RGB to spectrum: Jakob and Hanika's sigmoid of a quadratic ("A Low-Dimensional Function
//! Space for Efficient Spectral Upsampling", Computer Graphics Forum 38(2), 2019), with the
//! three coefficients of each colour found by raylink.
//!
//! pbrt-v4 looks the coefficients up in a 3 × 64³ table per colour space that its build
//! computes (`rgb2spec_opt`: a Gauss–Newton solve per entry in CIELAB, warm-started along
//! the brightness axis) and interpolates it trilinearly. raylink solves each colour on its
//! own instead, with the same objective (the CIELAB difference, under the colour space's
//! illuminant, between the spectrum's colour and the target), by Levenberg–Marquardt with an
//! analytic Jacobian, starting from the grey of the same mean (whose coefficients are
//! closed-form) and walking towards the colour if the direct solve stalls. Why: a scene's
//! RGB parameters are few (a colour is converted once, when the scene is read); a solve
//! takes about 0.15 ms for an sRGB colour (0.2 ms in DCI-P3; up to a few ms for colours no
//! real surface has, which Rec.2020 and ACES2065-1 are full of); the answer is exact to the
//! solver's tolerance rather than to a table's interpolation; and no table has to be built
//! at start-up (3 × 64³ solves per colour space: minutes from cold, which is why pbrt-v4
//! builds it offline with warm starts) or shipped. RGB textures, a colour per texel, would
//! want pbrt's table; [`solve`] can fill it when they are upsampled.
//!
//! The polynomial is kept in normalised wavelength t = (λ − 360 nm) / 470 nm, where the
//! coefficients stay moderate and single precision evaluates them well (pbrt keeps them in
//! nanometres).

use super::cie::{self, Illuminant, LAMBDA_MAX, LAMBDA_MIN};
use super::color_space::ColorSpace;
use super::sampled::{SampledSpectrum, SampledWavelengths};
use glam::{DMat3, DVec3};
use std::sync::OnceLock;

/// s(x) = ½ + x / (2 √(1 + x²)): a smooth step from 0 to 1.
fn sigmoid(x: f64) -> f64 {
    if x.is_infinite() {
        return if x > 0.0 { 1.0 } else { 0.0 };
    }
    0.5 + x / (2.0 * (1.0 + x * x).sqrt())
}

/// ds/dx.
fn sigmoid_derivative(x: f64) -> f64 {
    0.5 / (1.0 + x * x).powf(1.5)
}

/// Normalised wavelength of `lambda` nm.
fn normalised(lambda: f64) -> f64 {
    (lambda - LAMBDA_MIN as f64) / (LAMBDA_MAX - LAMBDA_MIN) as f64
}

/// A reflectance spectrum in (0, 1): s(c₀t² + c₁t + c₂) of the normalised wavelength t.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SigmoidPolynomial {
    /// c₀, c₁, c₂.
    pub c: [f32; 3],
}

impl SigmoidPolynomial {
    /// The constant spectrum `v` in (0, 1) (0 and 1 themselves as infinite coefficients).
    pub fn constant(v: f32) -> Self {
        let v = v as f64;
        let c2 = if v <= 0.0 {
            f64::NEG_INFINITY
        } else if v >= 1.0 {
            f64::INFINITY
        } else {
            (v - 0.5) / (v * (1.0 - v)).sqrt()
        };
        SigmoidPolynomial {
            c: [0.0, 0.0, c2 as f32],
        }
    }

    /// The value at `lambda` nm.
    pub fn eval(&self, lambda: f32) -> f32 {
        let t = (lambda - LAMBDA_MIN) / (LAMBDA_MAX - LAMBDA_MIN);
        let [c0, c1, c2] = self.c;
        sigmoid(((c0 * t + c1) * t + c2) as f64) as f32
    }

    /// The values at the sampled wavelengths.
    pub fn sample(&self, lambda: &SampledWavelengths) -> SampledSpectrum {
        SampledSpectrum(lambda.lambdas().map(|l| self.eval(l)))
    }

    /// The largest value over 360 to 830 nm.
    pub fn max_value(&self) -> f32 {
        let [c0, c1, _] = self.c;
        let mut m = self.eval(LAMBDA_MIN).max(self.eval(LAMBDA_MAX));
        if c0 != 0.0 {
            let t = -c1 / (2.0 * c0);
            if (0.0..=1.0).contains(&t) {
                m = m.max(self.eval(LAMBDA_MIN + t * (LAMBDA_MAX - LAMBDA_MIN)));
            }
        }
        m
    }
}

/// A colour space's quadrature: XYZ(s) = Σ wᵢ s(tᵢ) over 1 nm steps, the reflectance s lit
/// by the space's illuminant (of luminance 1), so that s ≡ 1 is the white.
struct Quadrature {
    nodes: Vec<(f64, DVec3)>,
}

impl Quadrature {
    fn of(illuminant: Illuminant) -> &'static Quadrature {
        static Q: [OnceLock<Quadrature>; 3] = [OnceLock::new(), OnceLock::new(), OnceLock::new()];
        Q[illuminant as usize].get_or_init(|| {
            let norm = cie::y_integral();
            Quadrature {
                nodes: cie::integration_wavelengths()
                    .map(|l| (normalised(l), cie::cmf_xyz(l) * illuminant.eval(l) / norm))
                    .collect(),
            }
        })
    }

    /// XYZ of the coefficients `c` and its derivatives by c₀, c₁, c₂ (the columns).
    fn xyz_and_jacobian(&self, c: [f64; 3]) -> (DVec3, DMat3) {
        let mut xyz = DVec3::ZERO;
        let mut j = [DVec3::ZERO; 3];
        for &(t, w) in &self.nodes {
            let x = (c[0] * t + c[1]) * t + c[2];
            xyz += w * sigmoid(x);
            let d = w * sigmoid_derivative(x);
            j[0] += d * (t * t);
            j[1] += d * t;
            j[2] += d;
        }
        (xyz, DMat3::from_cols(j[0], j[1], j[2]))
    }

    fn xyz(&self, c: [f64; 3]) -> DVec3 {
        self.nodes
            .iter()
            .map(|&(t, w)| w * sigmoid((c[0] * t + c[1]) * t + c[2]))
            .sum()
    }
}

/// CIELAB of `xyz` against the white `white`, and its derivative by XYZ.
fn lab(xyz: DVec3, white: DVec3) -> (DVec3, DMat3) {
    const D: f64 = 6.0 / 29.0;
    let f = |t: f64| {
        if t > D * D * D {
            (t.cbrt(), 1.0 / (3.0 * t.cbrt() * t.cbrt()))
        } else {
            (t / (3.0 * D * D) + 4.0 / 29.0, 1.0 / (3.0 * D * D))
        }
    };
    let (fx, dx) = f(xyz.x / white.x);
    let (fy, dy) = f(xyz.y / white.y);
    let (fz, dz) = f(xyz.z / white.z);
    let (dx, dy, dz) = (dx / white.x, dy / white.y, dz / white.z);
    let lab = DVec3::new(116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz));
    // Rows: L, a, b; columns: X, Y, Z (glam is column-major).
    let jac = DMat3::from_cols(
        DVec3::new(0.0, 500.0 * dx, 0.0),
        DVec3::new(116.0 * dy, -500.0 * dy, 200.0 * dy),
        DVec3::new(0.0, 0.0, -200.0 * dz),
    );
    (lab, jac)
}

/// The solver's stopping distance in CIELAB (ΔE).
const TOLERANCE: f64 = 1e-8;

/// Levenberg–Marquardt on the CIELAB difference from `target` (a Lab colour), from `c`.
/// Returns the coefficients and the remaining difference.
fn minimise(
    q: &Quadrature,
    white: DVec3,
    target: DVec3,
    mut c: [f64; 3],
    iterations: usize,
) -> ([f64; 3], f64) {
    let residual = |c: [f64; 3]| lab(q.xyz(c), white).0 - target;
    let mut r = residual(c);
    let mut mu = 1e-3;
    for _ in 0..iterations {
        let err = r.length();
        if err < TOLERANCE {
            break;
        }
        let (xyz, jx) = q.xyz_and_jacobian(c);
        let (_, jl) = lab(xyz, white);
        let j = jl * jx;
        let jt = j.transpose();
        let jtj = jt * j;
        let g = jt * r;
        let mut improved = false;
        for _ in 0..12 {
            let damped = jtj
                + DMat3::from_diagonal(DVec3::new(jtj.x_axis.x, jtj.y_axis.y, jtj.z_axis.z) * mu);
            if damped.determinant().abs() < 1e-300 {
                mu *= 10.0;
                continue;
            }
            let step = damped.inverse() * -g;
            let trial = [c[0] + step.x, c[1] + step.y, c[2] + step.z];
            let rt = residual(trial);
            if rt.is_finite() && rt.length() < err {
                c = trial;
                r = rt;
                mu = (mu * 0.3).max(1e-12);
                improved = true;
                break;
            }
            mu *= 10.0;
        }
        if !improved {
            break;
        }
    }
    (c, r.length())
}

/// The sigmoid-polynomial coefficients of the reflectance whose colour, lit by `space`'s
/// illuminant, is the linear RGB `rgb` of `space` (components in [0, 1]). Colours no
/// reflectance reaches (outside the gamut of real surfaces, as parts of Rec.2020 and
/// ACES2065-1 are) get the closest the solver finds.
pub fn solve(space: &ColorSpace, rgb: [f32; 3]) -> SigmoidPolynomial {
    let rgb = DVec3::from(rgb.map(|v| v.clamp(0.0, 1.0) as f64));
    // A grey's spectrum is a constant.
    if rgb.x == rgb.y && rgb.y == rgb.z {
        return SigmoidPolynomial::constant(rgb.x as f32);
    }
    let q = Quadrature::of(space.illuminant);
    let white = space.rgb_to_xyz(DVec3::ONE);
    let lab_of = |rgb: DVec3| lab(space.rgb_to_xyz(rgb), white).0;
    let grey = rgb.element_sum() / 3.0;
    let g = grey.clamp(1e-3, 1.0 - 1e-3);
    let start = [0.0, 0.0, (g - 0.5) / (g * (1.0 - g)).sqrt()];
    let (c, err) = minimise(q, white, lab_of(rgb), start, 50);
    let c = if err < TOLERANCE {
        c
    } else {
        // Walk from the grey towards the colour, each solve starting at the last; a colour
        // beyond real reflectances ends at the closest one the walk reaches.
        let steps = 16;
        let mut c = start;
        for k in 1..=steps {
            let f = k as f64 / steps as f64;
            let iterations = if k == steps { 100 } else { 25 };
            c = minimise(
                q,
                white,
                lab_of(DVec3::splat(grey).lerp(rgb, f)),
                c,
                iterations,
            )
            .0;
        }
        c
    };
    SigmoidPolynomial {
        c: c.map(|v| v as f32),
    }
}

/// The linear RGB in `space` of the reflectance `s` lit by the space's illuminant, by the
/// solver's own quadrature.
pub fn reflectance_rgb(space: &ColorSpace, s: &SigmoidPolynomial) -> DVec3 {
    let q = Quadrature::of(space.illuminant);
    space.xyz_to_rgb(q.xyz(s.c.map(|v| v as f64)))
}

/// An error for an RGB reflectance with a component outside [0, 1].
#[derive(Clone, Debug, PartialEq)]
pub struct OutOfRange(pub [f32; 3]);

impl std::fmt::Display for OutOfRange {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [r, g, b] = self.0;
        write!(
            f,
            "RGB reflectance ({r}, {g}, {b}) has a component outside [0, 1]"
        )
    }
}

impl std::error::Error for OutOfRange {}

/// A reflectance (albedo) given as RGB in [0, 1]: pbrt-v4's `RGBAlbedoSpectrum`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RgbAlbedo {
    /// The spectrum.
    pub rsp: SigmoidPolynomial,
}

impl RgbAlbedo {
    /// The reflectance of colour `rgb` in `space`; an error if a component is outside [0, 1].
    pub fn new(space: &ColorSpace, rgb: [f32; 3]) -> Result<Self, OutOfRange> {
        if rgb.iter().any(|v| !(0.0..=1.0).contains(v)) {
            return Err(OutOfRange(rgb));
        }
        Ok(RgbAlbedo {
            rsp: solve(space, rgb),
        })
    }

    /// The value at `lambda` nm.
    pub fn eval(&self, lambda: f32) -> f32 {
        self.rsp.eval(lambda)
    }
}

/// A spectrum of any positive magnitude given as RGB (a scattering coefficient, say):
/// pbrt-v4's `RGBUnboundedSpectrum`, 2m · s(λ) with m the largest component and s the
/// reflectance of RGB / 2m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RgbUnbounded {
    /// The scale 2m.
    pub scale: f32,
    /// The reflectance of RGB / scale.
    pub rsp: SigmoidPolynomial,
}

impl RgbUnbounded {
    /// The spectrum of the RGB `rgb` (components at least 0) in `space`.
    pub fn new(space: &ColorSpace, rgb: [f32; 3]) -> Self {
        let m = rgb.iter().copied().fold(0.0, f32::max);
        let scale = 2.0 * m;
        let rsp = if scale > 0.0 {
            solve(space, rgb.map(|v| v.max(0.0) / scale))
        } else {
            SigmoidPolynomial::constant(0.0)
        };
        RgbUnbounded { scale, rsp }
    }

    /// The value at `lambda` nm.
    pub fn eval(&self, lambda: f32) -> f32 {
        self.scale * self.rsp.eval(lambda)
    }
}

/// An emitter given as RGB: pbrt-v4's `RGBIlluminantSpectrum`, the unbounded spectrum of
/// the RGB times the colour space's illuminant, so that RGB (1, 1, 1) is the space's white
/// at luminance 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RgbIlluminant {
    /// The spectrum's shape.
    pub rgb: RgbUnbounded,
    /// The colour space's illuminant.
    pub illuminant: Illuminant,
}

impl RgbIlluminant {
    /// The emission of the RGB `rgb` (components at least 0) in `space`.
    pub fn new(space: &ColorSpace, rgb: [f32; 3]) -> Self {
        RgbIlluminant {
            rgb: RgbUnbounded::new(space, rgb),
            illuminant: space.illuminant,
        }
    }

    /// The value at `lambda` nm.
    pub fn eval(&self, lambda: f32) -> f32 {
        self.rgb.eval(lambda) * self.illuminant.eval(lambda as f64) as f32
    }
}

#[cfg(test)]
mod tests;
