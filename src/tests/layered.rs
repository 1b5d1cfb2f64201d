//! The layered (coated) BSDF against what it must conserve and against closed forms: energy
//! through a lossless coat, a smooth coat over a Lambertian base (the `plastic` model's
//! geometric series of internal reflections), absorption in the coat, a smooth coat over a
//! smooth metal, reciprocity, and sampling that agrees with evaluation.

use super::bsdf::point;
use crate::bsdf::Transport;
use crate::math::optics::{fresnel_dielectric, fresnel_dielectric_mean};
use crate::math::{Rgb, Rng, Vec2, Vec3};
use crate::scene::materials::{CoatedConductor, CoatedDiffuse, SurfaceModel};
use crate::scene::{Classic, Coating, Conductor, Material, Surface, Texture};
use std::f64::consts::{PI, TAU};

/// A coat of index 1.5 and roughness `alpha` over a Lambertian base `kd`.
fn coated_diffuse(kd: f32, alpha: f32, thickness: f32) -> Material {
    let (base, coat) = coated_parts(kd, alpha, thickness);
    Material::new("", Surface::CoatedDiffuse(CoatedDiffuse::new(base, coat)))
}

/// The base and the coat of [`coated_diffuse`].
fn coated_parts(kd: f32, alpha: f32, thickness: f32) -> (Classic, Coating) {
    let base = Classic {
        diffuse: Texture::Constant(Rgb::splat(kd)),
        specular: Rgb::ONE,
        fresnel: true,
        ior: 1.5,
        roughness: alpha,
        ..Classic::default()
    };
    let coat = Coating {
        roughness: alpha,
        thickness,
        max_depth: 100,
        ..Coating::default()
    };
    (base, coat)
}

/// [`coated_diffuse`] with a black base (`kd` 0) over the metal `metal` of roughness
/// `metal_alpha` instead.
fn coated_metal(metal: &str, metal_alpha: f32, alpha: f32, thickness: f32) -> Material {
    let (mut base, coat) = coated_parts(0.0, alpha, thickness);
    base.conductor = Conductor::named(metal);
    base.roughness = metal_alpha;
    Material::new(
        "",
        Surface::CoatedConductor(CoatedConductor::new(base, coat)),
    )
}

/// The coat of a coated material.
fn coat_of(m: &Material) -> &Coating {
    match &m.surface {
        Surface::CoatedDiffuse(c) => c.coating(),
        Surface::CoatedConductor(c) => c.coating(),
        other => panic!("not a coated material: {other:?}"),
    }
}

/// The coated material `m` with its coat changed by `f`.
fn recoat(m: Material, f: impl FnOnce(&mut Coating)) -> Material {
    let mut coat = *coat_of(&m);
    f(&mut coat);
    let surface = match &m.surface {
        Surface::CoatedDiffuse(c) => {
            Surface::CoatedDiffuse(CoatedDiffuse::new(c.approximation().clone(), coat))
        }
        Surface::CoatedConductor(c) => {
            Surface::CoatedConductor(CoatedConductor::new(c.approximation().clone(), coat))
        }
        _ => unreachable!(),
    };
    Material { surface, ..m }
}

fn direction(cos: f32) -> Vec3 {
    Vec3::new((1.0 - cos * cos).max(0.0).sqrt(), 0.0, cos)
}

/// Mean and standard error of the sample weights from `wo` (optionally times `g(wi)`) over
/// `n` samples.
fn sampled_mean(
    m: &Material,
    wo: Vec3,
    n: u32,
    mode: Transport,
    g: &dyn Fn(Vec3) -> f32,
) -> (Rgb, Rgb) {
    let bsdf = m.bsdf(&point(), wo);
    let mut rng = Rng::for_key(0x6c61, &[wo.z.to_bits() as u64]);
    // f64 sums: f32 ones drift by 1e-3 over 1e5 terms.
    let (mut sum, mut sum2) = ([0.0f64; 3], [0.0f64; 3]);
    for _ in 0..n {
        let u_lobe = rng.uniform();
        let u = Vec2::new(rng.uniform(), rng.uniform());
        if let Some(s) = bsdf.sample(wo, u_lobe, u, mode) {
            let x = (s.weight * g(s.wi)).to_array();
            for c in 0..3 {
                sum[c] += x[c] as f64;
                sum2[c] += (x[c] as f64).powi(2);
            }
        }
    }
    let mean = sum.map(|s| s / n as f64);
    let err: Vec<f64> = (0..3)
        .map(|c| ((sum2[c] / n as f64 - mean[c] * mean[c]).max(0.0) / n as f64).sqrt())
        .collect();
    (
        Rgb::new(mean[0] as f32, mean[1] as f32, mean[2] as f32),
        Rgb::new(err[0] as f32, err[1] as f32, err[2] as f32),
    )
}

/// ∫ eval(wo, wi)·g(wi) dωi over the upper hemisphere by the midpoint rule in (cos θ, φ),
/// denser near the horizon-free pole: cos θ = 1 − t².
fn integrated(m: &Material, wo: Vec3, n: usize, mode: Transport, g: &dyn Fn(Vec3) -> f32) -> Rgb {
    let bsdf = m.bsdf(&point(), wo);
    let mut sum = [0.0f64; 3];
    for i in 0..n {
        let t = (i as f64 + 0.5) / n as f64;
        let z = 1.0 - t * t;
        let dz = 2.0 * t / n as f64;
        let r = (1.0 - z * z).max(0.0).sqrt();
        for j in 0..n {
            let phi = TAU * (j as f64 + 0.5) / n as f64;
            let wi = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
            let f = bsdf.eval(wo, wi, mode) * g(wi);
            let w = dz * TAU / n as f64;
            for (c, s) in sum.iter_mut().enumerate() {
                *s += f.to_array()[c] as f64 * w;
            }
        }
    }
    Rgb::new(sum[0] as f32, sum[1] as f32, sum[2] as f32)
}

/// A lossless coat (no thickness) over a white Lambertian base reflects everything. The
/// smooth coat: the directional albedo from the sampling walk is 1 within 4 standard errors,
/// and from evaluation (F(θo) for the mirror plus ∫ f cos by quadrature) within 1.5%. A rough
/// coat loses what single-scattering GGX loses (light that would scatter again between
/// microfacets, most at the grazing angles met inside the coat): its albedo falls with α,
/// stays near 1 for a nearly smooth coat, and is the same from sampling and evaluation.
#[test]
fn lossless_coat_over_white_base_conserves_energy() {
    for cos in [0.95, 0.6, 0.25] {
        let wo = direction(cos);
        let m = coated_diffuse(1.0, 0.0, 0.0);
        let (mean, err) = sampled_mean(&m, wo, 200_000, Transport::Radiance, &|_| 1.0);
        let (a, e) = (mean.x, err.x);
        let evaluated = fresnel_dielectric(cos, 1.0 / 1.5)
            + integrated(&m, wo, 200, Transport::Radiance, &|_| 1.0).x;
        eprintln!("smooth cos {cos}: albedo {a:.5} ± {e:.5} sampled, {evaluated:.5} evaluated");
        assert!((a - 1.0).abs() <= 4.0 * e + 1e-5, "cos {cos}: {a} ± {e}");
        assert!((evaluated - 1.0).abs() < 0.015, "cos {cos}: {evaluated}");
        let mut last = a;
        for (alpha, low) in [(0.02, 0.98), (0.1, 0.9), (0.3, 0.6)] {
            let m = coated_diffuse(1.0, alpha, 0.0);
            let (mean, err) = sampled_mean(&m, wo, 100_000, Transport::Radiance, &|_| 1.0);
            let (a, e) = (mean.x, err.x);
            eprintln!("α {alpha} cos {cos}: albedo {a:.5} ± {e:.5}");
            assert!(
                a < last + 4.0 * e && a > low && a < 1.0 + 4.0 * e,
                "α {alpha} cos {cos}: {a} ± {e}"
            );
            last = a;
        }
    }
}

/// The smooth coat's albedo with absorption in closed form: F(θo) + (1 − F(θo)) e^(−t/μt) ρ
/// E / (1 − ρ R), where μt is the refracted cosine, E = ∫ 2μ e^(−t/μ) (1 − F_int(μ)) dμ the
/// share of the base's diffuse light that leaves and R = ∫ 2μ e^(−2t/μ) F_int(μ) dμ the share
/// that comes back to the base (midpoint rule).
fn absorbing_coat_albedo(rho: f64, t: f64, cos: f32) -> f64 {
    let eta = 1.5f32;
    let f = fresnel_dielectric(cos, 1.0 / eta) as f64;
    let sin_t = (1.0 - cos * cos).sqrt() / eta;
    let mu_t = (1.0 - sin_t * sin_t).sqrt() as f64;
    let n = 20_000;
    let (mut e, mut r) = (0.0, 0.0);
    for i in 0..n {
        let mu = (i as f64 + 0.5) / n as f64;
        let fi = fresnel_dielectric(mu as f32, eta) as f64;
        e += 2.0 * mu * (-t / mu).exp() * (1.0 - fi) / n as f64;
        r += 2.0 * mu * (-2.0 * t / mu).exp() * fi / n as f64;
    }
    f + (1.0 - f) * (-t / mu_t).exp() * rho * e / (1.0 - rho * r)
}

/// With pbrt's default thickness 0.01 the coat absorbs: the albedo is below 1 by what the
/// transmittance predicts (closed form above), within 4 standard errors.
#[test]
fn default_thickness_absorbs_what_transmittance_predicts() {
    let m = coated_diffuse(1.0, 0.0, 0.01);
    for cos in [0.9, 0.5, 0.2] {
        let (mean, err) = sampled_mean(&m, direction(cos), 200_000, Transport::Radiance, &|_| 1.0);
        let want = absorbing_coat_albedo(1.0, 0.01, cos) as f32;
        eprintln!(
            "cos {cos}: albedo {:.5} ± {:.5}, closed form {want:.5}",
            mean.x, err.x
        );
        assert!(want < 0.99, "the closed form absorbs: {want}");
        assert!(
            (mean.x - want).abs() < 4.0 * err.x + 1e-3,
            "cos {cos}: {} vs {want}",
            mean.x
        );
    }
}

/// f of a smooth lossless coat over a Lambertian base of albedo ρ, in closed form (the
/// `plastic` model): ρ (1 − F(θi))(1 − F(θo)) / (π η² (1 − ρ F̄_int)), F̄_int the internal
/// diffuse reflectance (cosine-weighted hemispherical mean of F from inside, total internal
/// reflection included).
fn plastic(rho: f64, wo: Vec3, wi: Vec3) -> f64 {
    let eta = 1.5f32;
    let fo = fresnel_dielectric(wo.z, 1.0 / eta) as f64;
    let fi = fresnel_dielectric(wi.z, 1.0 / eta) as f64;
    let f_int = fresnel_dielectric_mean(eta) as f64;
    rho * (1.0 - fi) * (1.0 - fo) / (PI * (eta * eta) as f64 * (1.0 - rho * f_int))
}

/// The smooth coat's f (estimated with 65536 walks per evaluation) agrees with the closed
/// form within 1% at several pairs of angles, for two base albedos.
#[test]
fn smooth_coat_matches_the_plastic_closed_form() {
    for rho in [0.8f32, 0.3] {
        let m = recoat(coated_diffuse(rho, 0.0, 0.0), |c| c.samples = 65536);
        for (co, ci, phi) in [
            (0.9f32, 0.8f32, 1.0f32),
            (0.5, 0.95, 2.5),
            (0.3, 0.4, 0.3),
            (0.7, 0.15, 3.0),
        ] {
            let wo = direction(co);
            let si = (1.0 - ci * ci).sqrt();
            let wi = Vec3::new(si * phi.cos(), si * phi.sin(), ci);
            let bsdf = m.bsdf(&point(), wo);
            let got = bsdf.eval(wo, wi, Transport::Radiance).x / ci;
            let want = plastic(rho as f64, wo, wi) as f32;
            eprintln!("ρ {rho} cos o {co} cos i {ci}: f {got:.5}, closed form {want:.5}");
            assert!(
                (got / want - 1.0).abs() < 0.02,
                "ρ {rho} ({co}, {ci}): {got} vs {want}"
            );
        }
    }
}

/// f(wo, wi) = f(wi, wo) within 2% (65536 walks per evaluation), smooth and rough coats over
/// a diffuse base and a rough coat over a rough metal.
#[test]
fn layered_brdf_is_reciprocal() {
    let metal = coated_metal("Au", 0.3, 0.2, 0.01);
    for (name, m) in [
        ("smooth", coated_diffuse(0.6, 0.0, 0.01)),
        ("rough", coated_diffuse(0.6, 0.3, 0.01)),
        ("metal", metal),
    ] {
        let m = recoat(m, |c| c.samples = 65536);
        for (a, b) in [(0.9f32, 0.4f32), (0.6, 0.75), (0.3, 0.85)] {
            let wa = direction(a);
            let wb = Vec3::new(-(1.0 - b * b).sqrt() * 0.6, (1.0 - b * b).sqrt() * 0.8, b);
            let fab = m.bsdf(&point(), wa).eval(wa, wb, Transport::Radiance) / wb.z;
            let fba = m.bsdf(&point(), wb).eval(wb, wa, Transport::Radiance) / wa.z;
            eprintln!("{name} ({a}, {b}): {fab} vs {fba}");
            for c in 0..3 {
                let (x, y) = (fab.to_array()[c], fba.to_array()[c]);
                assert!(
                    x > 0.0 && (x / y - 1.0).abs() < 0.02,
                    "{name} ({a}, {b}): {fab} vs {fba}"
                );
            }
        }
    }
}

/// Sampling agrees with evaluation: E[weight·g(wi)] over the walk's samples equals ∫ f |cos|
/// g dωi by quadrature of `eval` (plus the coat's mirror F(θo)·g(mirror) when it is smooth),
/// within 4 standard errors and 1% for the quadrature's own noise, for three test functions,
/// in both transport modes, with and without a scattering medium in the coat.
#[test]
fn sampling_agrees_with_evaluation() {
    let metal = coated_metal("Cu", 0.2, 0.25, 0.01);
    // A scattering medium in a thick rough coat.
    let milky = recoat(coated_diffuse(0.5, 0.2, 0.5), |c| {
        (c.albedo, c.g) = (Rgb::new(0.9, 0.6, 0.3), 0.4);
    });
    let tests: [(&str, &dyn Fn(Vec3) -> f32); 3] = [
        ("1", &|_| 1.0),
        ("z²", &|w: Vec3| w.z * w.z),
        ("x>0", &|w: Vec3| if w.x > 0.0 { 1.0 } else { 0.0 }),
    ];
    for (name, m) in [
        ("smooth", coated_diffuse(0.7, 0.0, 0.01)),
        ("rough", coated_diffuse(0.7, 0.3, 0.01)),
        ("metal", metal),
        ("milky", milky),
    ] {
        let smooth = coat_of(&m).roughness == 0.0;
        for mode in [Transport::Radiance, Transport::Importance] {
            for cos in [0.85f32, 0.35] {
                let wo = direction(cos);
                for (gname, g) in tests {
                    let (mean, err) = sampled_mean(&m, wo, 100_000, mode, g);
                    let mut want = integrated(&m, wo, 160, mode, g);
                    if smooth {
                        let mirror = Vec3::new(-wo.x, -wo.y, wo.z);
                        want += Rgb::splat(fresnel_dielectric(cos, 1.0 / 1.5) * g(mirror));
                    }
                    eprintln!("{name} {mode:?} cos {cos} g {gname}: {mean} ± {err} vs {want}");
                    for c in 0..3 {
                        let (x, e, y) = (mean.to_array()[c], err.to_array()[c], want.to_array()[c]);
                        assert!(
                            (x - y).abs() < 4.0 * e + 0.01 * y,
                            "{name} {mode:?} {cos} {gname}: {mean} ± {err} vs {want}"
                        );
                    }
                }
            }
        }
    }
}

/// A smooth coat over a smooth metal at normal incidence reflects the geometric series of
/// the two interfaces, R = F + (1 − F)² Rc T² / (1 − F Rc T²), Rc the metal's reflectance
/// against the coat (η/n, k/n) and T = e^(−t) the coat's transmittance: every sample is a
/// delta back along the normal and the mean weight is R within 4 standard errors.
#[test]
fn smooth_coat_over_smooth_metal_is_a_geometric_series() {
    for t in [0.0f32, 0.01, 0.2] {
        let m = coated_metal("Au", 0.0, 0.0, t);
        let gold = m.approximation().conductor.unwrap();
        let under = Conductor {
            eta: gold.eta / 1.5,
            k: gold.k / 1.5,
        };
        let bsdf = m.bsdf(&point(), Vec3::Z);
        assert!(!bsdf.has_non_delta());
        let f = fresnel_dielectric(1.0, 1.0 / 1.5);
        let rc = under.reflectance(1.0) * (-2.0 * t).exp();
        let want = Rgb::splat(f) + rc * (1.0 - f) * (1.0 - f) / (Rgb::ONE - rc * f);
        let (mean, err) = sampled_mean(&m, Vec3::Z, 200_000, Transport::Radiance, &|w| {
            assert!(w.z > 0.9999, "a delta along the normal: {w}");
            1.0
        });
        eprintln!("t {t}: {mean} ± {err} vs {want}");
        for c in 0..3 {
            let (x, e, y) = (mean.to_array()[c], err.to_array()[c], want.to_array()[c]);
            assert!(
                (x - y).abs() < 4.0 * e + 1e-4,
                "t {t}: {mean} ± {err} vs {want}"
            );
        }
    }
}

/// The estimates are functions of their arguments: the same query gives the same value.
#[test]
fn estimates_are_deterministic() {
    let m = coated_diffuse(0.5, 0.3, 0.01);
    let wo = direction(0.7);
    let wi = Vec3::new(-0.3, 0.2, 0.93).normalize();
    let a = m.bsdf(&point(), wo);
    let b = m.bsdf(&point(), wo);
    assert_eq!(
        a.eval(wo, wi, Transport::Radiance),
        b.eval(wo, wi, Transport::Radiance)
    );
    assert_eq!(a.pdf(wo, wi), b.pdf(wo, wi));
    let u = Vec2::new(0.3, 0.6);
    let (sa, sb) = (
        a.sample(wo, 0.9, u, Transport::Radiance),
        b.sample(wo, 0.9, u, Transport::Radiance),
    );
    assert_eq!(sa.map(|s| (s.wi, s.weight)), sb.map(|s| (s.wi, s.weight)));
}
