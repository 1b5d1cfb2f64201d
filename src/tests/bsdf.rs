//! Sampling tests for every BSDF: a chi-square test of the sampled directions against the
//! density the BSDF reports, the density integrating to the fraction of non-delta samples,
//! and sample weights equal to eval/pdf.

use crate::bsdf::{Bsdf, Transport};
use crate::math::{Rgb, Rng, Vec2, Vec3};
use crate::scene::{Classic, Coating, Conductor, Material, Surface, SurfacePoint, Texture};

const THETA_BINS: usize = 20;
const PHI_BINS: usize = 40;

pub(super) fn point() -> SurfacePoint {
    SurfacePoint {
        p: Vec3::ZERO,
        error: Vec3::ZERO,
        ng: Vec3::Z,
        ns: Vec3::Z,
        uv: Vec2::ZERO,
        t: 1.0,
        shape: 0,
        instance: None,
        material: 0,
        time: 0.0,
    }
}

fn bin_of(w: Vec3) -> usize {
    let c = ((w.z + 1.0) * 0.5 * THETA_BINS as f32) as usize;
    let phi = w.y.atan2(w.x).rem_euclid(std::f32::consts::TAU);
    let p = (phi / std::f32::consts::TAU * PHI_BINS as f32) as usize;
    c.min(THETA_BINS - 1) * PHI_BINS + p.min(PHI_BINS - 1)
}

/// ∫ pdf over each (cos θ, φ) bin by the midpoint rule (dω = d cos θ dφ) at `sub`² points
/// a bin.
fn integrate_pdf(bsdf: &Bsdf, wo: Vec3, sub: usize) -> Vec<f64> {
    let mut out = vec![0.0; THETA_BINS * PHI_BINS];
    for (i, o) in out.iter_mut().enumerate() {
        let (ct, cp) = (i / PHI_BINS, i % PHI_BINS);
        let dz = 2.0 / (THETA_BINS * sub) as f64;
        let dphi = std::f64::consts::TAU / (PHI_BINS * sub) as f64;
        let mut sum = 0.0;
        for a in 0..sub {
            let z = -1.0 + (ct * sub + a) as f64 * dz + 0.5 * dz;
            let r = (1.0 - z * z).max(0.0).sqrt();
            for b in 0..sub {
                let phi = (cp * sub + b) as f64 * dphi + 0.5 * dphi;
                let w = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
                sum += bsdf.pdf(wo, w) as f64;
            }
        }
        *o = sum * dz * dphi;
    }
    out
}

/// Upper-tail probability of the chi-square distribution (Wilson-Hilferty approximation).
fn chi2_tail(x: f64, dof: f64) -> f64 {
    let k = 2.0 / (9.0 * dof);
    let z = ((x / dof).powf(1.0 / 3.0) - (1.0 - k)) / k.sqrt();
    0.5 * crate::math::erfc(z / std::f64::consts::SQRT_2)
}

/// Runs the three checks for one material and outgoing direction.
pub(super) fn check(name: &str, m: &Material, wo: Vec3) {
    check_at(name, m, wo, 24);
}

/// [`check`] with the density integrated at `sub`² points a bin (more for narrow lobes).
pub(super) fn check_at(name: &str, m: &Material, wo: Vec3, sub: usize) {
    check_in(name, m, wo, sub, Transport::Radiance);
}

/// [`check_at`] in transport `mode`.
pub(super) fn check_in(name: &str, m: &Material, wo: Vec3, sub: usize, mode: Transport) {
    let wo = wo.normalize();
    let bsdf = m.bsdf(&point(), wo);
    let n = 400_000;
    let mut counts = vec![0.0f64; THETA_BINS * PHI_BINS];
    let mut rng = Rng::for_key(17, &[name.len() as u64]);
    let mut non_delta = 0usize;
    for _ in 0..n {
        let u_lobe = rng.uniform();
        let u = Vec2::new(rng.uniform(), rng.uniform());
        let Some(s) = bsdf.sample(wo, u_lobe, u, mode) else {
            continue;
        };
        assert!((s.wi.length() - 1.0).abs() < 1e-3, "{name}: wi not unit");
        if s.delta {
            continue;
        }
        non_delta += 1;
        counts[bin_of(s.wi)] += 1.0;
        // The weight is eval/pdf; and both at once are the two apart, to the bit (next-event
        // estimation takes them together).
        let (f, pdf) = (bsdf.eval(wo, s.wi, mode), bsdf.pdf(wo, s.wi));
        let (f_both, pdf_both) = bsdf.eval_and_pdf(wo, s.wi, mode);
        assert_eq!(
            (f.to_array().map(f32::to_bits), pdf.to_bits()),
            (f_both.to_array().map(f32::to_bits), pdf_both.to_bits()),
            "{name}: eval_and_pdf differs from eval and pdf"
        );
        let expect = f / pdf;
        assert!(
            (s.weight - expect).abs().max_element() <= 1e-3 * expect.max_element().max(1.0),
            "{name}: weight {} vs eval/pdf {}",
            s.weight,
            expect
        );
    }
    let expected: Vec<f64> = integrate_pdf(&bsdf, wo, sub)
        .iter()
        .map(|p| p * n as f64)
        .collect();
    // The density integrates to the share of samples that came from non-delta lobes.
    let integral: f64 = expected.iter().sum::<f64>() / n as f64;
    let share = non_delta as f64 / n as f64;
    assert!(
        (integral - share).abs() < 0.01,
        "{name}: ∫pdf = {integral:.4} but {share:.4} of samples were non-delta"
    );
    // Chi-square, pooling bins with small expected counts (Mitsuba's approach).
    let (mut chi2, mut dof, mut pool_e, mut pool_o) = (0.0, 0.0, 0.0, 0.0);
    for (o, e) in counts.iter().zip(&expected) {
        if *e < 5.0 {
            pool_e += e;
            pool_o += o;
        } else {
            chi2 += (o - e) * (o - e) / e;
            dof += 1.0;
        }
    }
    if pool_e > 5.0 {
        chi2 += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        dof += 1.0;
    } else {
        assert!(
            pool_o < 20.0,
            "{name}: {pool_o} samples where the pdf is ~0"
        );
    }
    dof -= 1.0;
    let p = chi2_tail(chi2, dof);
    // 1% significance, Šidák-corrected for the number of cases in this file.
    let alpha = 1.0 - (1.0f64 - 0.01).powf(1.0 / 68.0);
    eprintln!("{name}: chi2 {chi2:.1} dof {dof} p {p:.3}");
    assert!(
        p > alpha,
        "{name}: chi-square {chi2:.1} with {dof} dof, p = {p:.2e}"
    );
}

pub(super) fn material(f: impl FnOnce(&mut Classic)) -> Material {
    Material::classic("", classic(f))
}

/// The classic terms of `m`, a classic material (as [`material`] makes), to change.
pub(super) fn classic_mut(m: &mut Material) -> &mut Classic {
    match &mut m.surface {
        Surface::Classic(c) => c,
        other => panic!("not a classic material: {other:?}"),
    }
}

/// The coat of `m`, if it is a coated material.
pub(super) fn coating_of(m: &Material) -> Option<Coating> {
    match &m.surface {
        Surface::CoatedDiffuse(c) => Some(*c.coating()),
        Surface::CoatedConductor(c) => Some(*c.coating()),
        _ => None,
    }
}

/// The classic terms [`material`] takes: black, then set by `f`.
pub(super) fn classic(f: impl FnOnce(&mut Classic)) -> Classic {
    let mut c = Classic {
        diffuse: Texture::Constant(Rgb::ZERO),
        ..Classic::default()
    };
    f(&mut c);
    c
}

pub(super) fn directions() -> [Vec3; 3] {
    [
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(0.6, 0.1, 0.8),
        Vec3::new(-0.9, 0.3, 0.15),
    ]
}

#[test]
fn lambertian() {
    let m = material(|m| m.diffuse = Texture::Constant(Rgb::new(0.8, 0.5, 0.2)));
    for (i, wo) in directions().into_iter().enumerate() {
        check(&format!("lambert{i}"), &m, wo);
        // Seen from below, an opaque surface reflects on that side.
        check(&format!("lambert-back{i}"), &m, -wo);
    }
}

#[test]
fn ggx_conductor() {
    for alpha in [0.2, 0.5] {
        let m = material(|m| {
            m.specular = Rgb::new(0.9, 0.7, 0.5);
            m.roughness = alpha;
        });
        for (i, wo) in directions().into_iter().enumerate() {
            check(&format!("ggx{alpha}-{i}"), &m, wo);
        }
    }
}

/// Copper with pbrt-v4's conductor lobe: complex Fresnel per channel, GGX isotropic and
/// anisotropic (α_x along the tangent, α_y along the bitangent), both sides of the surface.
fn copper(alpha_x: f32, alpha_y: f32) -> Material {
    material(|m| {
        m.specular = Rgb::ONE;
        m.conductor = Conductor::named("Cu");
        m.roughness = alpha_x;
        m.roughness_v = (alpha_y != alpha_x).then_some(alpha_y);
    })
}

#[test]
fn rough_conductors() {
    for (ax, ay) in [(0.3, 0.3), (0.1, 0.5)] {
        let m = copper(ax, ay);
        for (i, wo) in directions().into_iter().enumerate() {
            check(&format!("copper{ax}x{ay}-{i}"), &m, wo);
        }
        check(&format!("copper{ax}x{ay}-back"), &m, -directions()[1]);
    }
}

/// A smooth conductor is a mirror whose sample weight is the complex Fresnel reflectance at
/// the incidence angle, per channel.
#[test]
fn smooth_conductor_weight_is_complex_fresnel() {
    let m = copper(0.0, 0.0);
    let cu = Conductor::named("Cu").unwrap();
    for wo in directions() {
        let wo = wo.normalize();
        let bsdf = m.bsdf(&point(), wo);
        assert!(!bsdf.has_non_delta());
        for mode in [Transport::Radiance, Transport::Importance] {
            let s = bsdf.sample(wo, 0.5, Vec2::new(0.3, 0.7), mode).unwrap();
            assert!(s.delta);
            assert!((s.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-5);
            let f = cu.reflectance(wo.z);
            assert!(
                (s.weight - f).abs().max_element() < 1e-5,
                "{} vs {f}",
                s.weight
            );
        }
    }
}

#[test]
fn coated_diffuse_and_mirror_mixtures() {
    let coated = material(|m| {
        m.diffuse = Texture::Constant(Rgb::new(0.6, 0.2, 0.2));
        m.specular = Rgb::ONE;
        m.fresnel = true;
        m.roughness = 0.3;
    });
    let mirror_mix = material(|m| {
        m.diffuse = Texture::Constant(Rgb::splat(0.5));
        m.specular = Rgb::splat(0.3);
    });
    for (i, wo) in directions().into_iter().enumerate() {
        check(&format!("coated{i}"), &coated, wo);
        check(&format!("mirror-mix{i}"), &mirror_mix, wo);
    }
}

/// The glossy share of f·cos is the GGX lobe alone: all of it for a rough metal, f·cos less
/// the Lambertian kd/π·cos for a plastic without Fresnel, nothing for a mirror mixture or a
/// Lambertian surface (which have no glossy lobe).
#[test]
fn glossy_share_is_the_ggx_lobe() {
    let kd = Rgb::new(0.15, 0.2, 0.35);
    let metal = material(|m| {
        m.specular = Rgb::new(1.0, 0.78, 0.34);
        m.roughness = 0.25;
    });
    let plastic = material(|m| {
        m.diffuse = Texture::Constant(kd);
        m.specular = Rgb::splat(0.5);
        m.roughness = 0.15;
    });
    let mirror_mix = material(|m| {
        m.diffuse = Texture::Constant(kd);
        m.specular = Rgb::splat(0.3);
    });
    let lambert = material(|m| m.diffuse = Texture::Constant(kd));
    let wi = Vec3::new(-0.5, -0.2, 0.84).normalize();
    for wo in directions() {
        let wo = wo.normalize();
        let mode = Transport::Radiance;
        let b = metal.bsdf(&point(), wo);
        assert!(b.has_glossy());
        assert_eq!(b.eval_glossy(wo, wi, mode), b.eval(wo, wi, mode));
        let b = plastic.bsdf(&point(), wo);
        assert!(b.has_glossy());
        let diffuse = b.eval(wo, wi, mode) - b.eval_glossy(wo, wi, mode);
        let want = kd * (std::f32::consts::FRAC_1_PI * wi.z);
        assert!(
            (diffuse - want).abs().max_element() < 1e-6,
            "{diffuse} vs {want}"
        );
        assert!(b.eval_glossy(wo, wi, mode).min_element() > 0.0);
        for m in [&mirror_mix, &lambert] {
            let b = m.bsdf(&point(), wo);
            assert!(!b.has_glossy());
            assert_eq!(b.eval_glossy(wo, wi, mode), Rgb::ZERO);
        }
    }
}

/// A smooth dielectric is all delta: the expected weight of a sample is R + T·(ηi/ηt)² in
/// radiance transport and R + T in importance transport, i.e. energy is conserved for
/// importance and radiance follows the (η)² law.
#[test]
fn glass_weights() {
    let glass = material(|m| {
        m.specular = Rgb::ONE;
        m.transmission = Rgb::ONE;
        m.fresnel = true;
        m.ior = 1.5;
    });
    for wo in [Vec3::new(0.3, 0.0, 0.95), Vec3::new(0.3, 0.0, -0.95)] {
        let wo = wo.normalize();
        let bsdf = glass.bsdf(&point(), wo);
        let eta = if wo.z > 0.0 { 1.0 / 1.5 } else { 1.5 };
        let f = crate::math::optics::fresnel_dielectric(wo.z.abs(), eta);
        let mut rng = Rng::for_key(3, &[]);
        let n = 100_000;
        let (mut rad, mut imp, mut refl) = (0.0f64, 0.0f64, 0usize);
        for _ in 0..n {
            let (ul, u) = (rng.uniform(), Vec2::new(rng.uniform(), rng.uniform()));
            let s = bsdf.sample(wo, ul, u, Transport::Radiance).unwrap();
            assert!(s.delta);
            rad += s.weight.x as f64 / n as f64;
            if s.wi.z * wo.z > 0.0 {
                refl += 1;
                // Mirror direction.
                assert!((s.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-4);
            } else {
                // Snell's law.
                let sin_o = (1.0 - wo.z * wo.z).sqrt();
                let sin_i = (1.0 - s.wi.z * s.wi.z).sqrt();
                assert!((sin_o * eta - sin_i).abs() < 1e-4);
            }
            let s = bsdf.sample(wo, ul, u, Transport::Importance).unwrap();
            imp += s.weight.x as f64 / n as f64;
        }
        let share = refl as f64 / n as f64;
        assert!(
            (share - f as f64).abs() < 0.01,
            "reflected share {share} vs F {f}"
        );
        let expect_rad = f + (1.0 - f) * eta * eta;
        assert!(
            (rad - expect_rad as f64).abs() < 1e-3,
            "radiance weight {rad} vs {expect_rad}"
        );
        assert!((imp - 1.0).abs() < 1e-3, "importance weight {imp}");
    }
}

/// Reciprocity: f(wo, wi) cos θo ... the BRDF itself is symmetric; eval includes cos θi.
/// Holds for the coated surface and the rough conductors, isotropic and anisotropic.
#[test]
fn brdfs_are_reciprocal() {
    let coated = material(|m| {
        m.diffuse = Texture::Constant(Rgb::new(0.6, 0.2, 0.2));
        m.specular = Rgb::splat(0.8);
        m.fresnel = true;
        m.roughness = 0.3;
    });
    for (name, m) in [
        ("coated", coated),
        ("copper", copper(0.3, 0.3)),
        ("copper-aniso", copper(0.1, 0.5)),
    ] {
        let mut rng = Rng::for_key(8, &[]);
        let mut nonzero = 0;
        for _ in 0..1000 {
            let a = crate::math::warp::cosine_hemisphere(Vec2::new(rng.uniform(), rng.uniform()));
            let b = crate::math::warp::cosine_hemisphere(Vec2::new(rng.uniform(), rng.uniform()));
            let bsdf = m.bsdf(&point(), a);
            let fab = bsdf.eval(a, b, Transport::Radiance) / b.z;
            let fba = bsdf.eval(b, a, Transport::Radiance) / a.z;
            if fab.max_element() > 0.0 {
                nonzero += 1;
            }
            assert!(
                (fab - fba).abs().max_element() < 1e-4 * fab.max_element().max(1.0),
                "{name}: f(a, b) = {fab} but f(b, a) = {fba}"
            );
        }
        assert!(nonzero > 900, "{name}: only {nonzero} non-zero values");
    }
}

/// The anisotropic lobe is anisotropic the way pbrt's is: stretched along the axis of the
/// larger α. Reflection of normal incidence spreads further along y (α_y = 0.5) than along x.
#[test]
fn anisotropic_lobe_follows_the_larger_alpha() {
    let m = copper(0.1, 0.5);
    let wo = Vec3::Z;
    let bsdf = m.bsdf(&point(), wo);
    let tilt = |x: f32, y: f32| Vec3::new(x, y, 1.0).normalize();
    let along_x = bsdf.eval(wo, tilt(0.3, 0.0), Transport::Radiance).x;
    let along_y = bsdf.eval(wo, tilt(0.0, 0.3), Transport::Radiance).x;
    assert!(along_y > 5.0 * along_x, "x {along_x} y {along_y}");
}

/// A thin translucent sheet: Lambertian reflection kd/π on wo's side and transmission
/// kdt/π on the other (pbrt-v4's `DiffuseTransmissionBxDF`), alone and under a glossy
/// coat, seen from both sides.
fn leaf() -> Material {
    material(|m| {
        m.diffuse = Texture::Constant(Rgb::new(0.2, 0.4, 0.1));
        m.diffuse_transmission = Texture::Constant(Rgb::new(0.3, 0.5, 0.1));
    })
}

#[test]
fn diffuse_transmission_sampling() {
    let coated = material(|m| {
        m.diffuse = Texture::Constant(Rgb::splat(0.3));
        m.diffuse_transmission = Texture::Constant(Rgb::splat(0.4));
        m.specular = Rgb::ONE;
        m.fresnel = true;
        m.roughness = 0.3;
    });
    for (i, wo) in directions().into_iter().enumerate() {
        check(&format!("leaf{i}"), &leaf(), wo);
        check(&format!("leaf-back{i}"), &leaf(), -wo);
    }
    check("coated-leaf", &coated, directions()[1]);
    check("coated-leaf-back", &coated, -directions()[1]);
}

/// f is kd/π on wo's side and kdt/π on the other, whichever side wo is on; so it is
/// symmetric, the mean sample weight is kd + kdt in both transport directions (no
/// refraction, no η²), and the sheet is a non-delta but not a glossy BSDF.
#[test]
fn diffuse_transmission_values_and_albedo() {
    let m = leaf();
    let (kd, kdt) = (Rgb::new(0.2, 0.4, 0.1), Rgb::new(0.3, 0.5, 0.1));
    let pi = std::f32::consts::PI;
    let mut rng = Rng::for_key(4, &[]);
    for wo in directions() {
        for wo in [wo.normalize(), -wo.normalize()] {
            let bsdf = m.bsdf(&point(), wo);
            assert!(bsdf.has_non_delta() && !bsdf.has_glossy());
            for _ in 0..100 {
                let wi =
                    crate::math::warp::cosine_hemisphere(Vec2::new(rng.uniform(), rng.uniform()));
                for (wi, k) in [(wi * wo.z.signum(), kd), (wi * -wo.z.signum(), kdt)] {
                    for mode in [Transport::Radiance, Transport::Importance] {
                        let f = bsdf.eval(wo, wi, mode);
                        let want = k * (wi.z.abs() / pi);
                        assert!((f - want).abs().max_element() < 1e-6, "{f} vs {want}");
                        let back = m.bsdf(&point(), wi).eval(wi, wo, mode);
                        assert!((back / wo.z.abs() - f / wi.z.abs()).abs().max_element() < 1e-5);
                    }
                }
            }
            let n = 100_000;
            for mode in [Transport::Radiance, Transport::Importance] {
                let (mut sum, mut through, mut none) = (Rgb::ZERO, 0usize, 0usize);
                for _ in 0..n {
                    let (ul, u) = (rng.uniform(), Vec2::new(rng.uniform(), rng.uniform()));
                    // (None where u_lobe rounds past the last lobe: rare.)
                    let Some(s) = bsdf.sample(wo, ul, u, mode) else {
                        none += 1;
                        continue;
                    };
                    assert!(!s.delta);
                    sum += s.weight / n as f32;
                    through += usize::from(s.wi.z * wo.z < 0.0);
                }
                assert!(none < 10, "{none} samples failed");
                // Lobes are picked by luminance, each sample weighs its lobe's
                // colour over its probability: the mean is kd + kdt within noise.
                let want = kd + kdt;
                assert!((sum - want).abs().max_element() < 0.01, "{sum} vs {want}");
                let share = through as f32 / n as f32;
                let p = crate::math::luminance(kdt)
                    / (crate::math::luminance(kd) + crate::math::luminance(kdt));
                assert!((share - p).abs() < 0.01, "{share} vs {p}");
            }
        }
    }
}
