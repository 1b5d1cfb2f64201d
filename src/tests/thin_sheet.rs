//! The thin dielectric sheet (`thin = true`, pbrt-v4's `ThinDielectricBxDF`): its BSDF
//! against the closed form, and Whitted's integrator along single rays through a pane.

use super::bsdf::{classic_mut, material, point};
use super::network_common::{build, closed_box, params};
use super::whitted::scenes::{add_material, empty_scene, floor, quad};
use crate::accel::{self, Backend};
use crate::bsdf::Transport;
use crate::control::Control;
use crate::integrators::illumination_network::distribute::surfaces;
use crate::integrators::illumination_network::preprocess::Builder;
use crate::integrators::whitted::{Whitted, WhittedOptions};
use crate::math::{Ray, Rgb, Rng, Vec2, Vec3};
use crate::scene::{Classic, Material, Texture};
use crate::transport::{Context, Integrator, RayStats};

/// The sheet's reflectance in closed form, in f64 and independent of the crate's Fresnel
/// code: the unpolarised Fresnel reflectance F of one face, then the sum over the bounces
/// between the two faces, F + (1 − F)²F/(1 − F²) = 2F/(1 + F).
fn thin_reflectance(cos: f64, ior: f64) -> f64 {
    let cos_t = (1.0 - (1.0 - cos * cos) / (ior * ior)).sqrt();
    let rs = (cos - ior * cos_t) / (cos + ior * cos_t);
    let rp = (ior * cos - cos_t) / (ior * cos + cos_t);
    let f = 0.5 * (rs * rs + rp * rp);
    2.0 * f / (1.0 + f)
}

fn thin_glass(ior: f32, kt: Rgb) -> Material {
    material(|m| {
        m.specular = Rgb::ONE;
        m.transmission = kt;
        m.fresnel = true;
        m.thin = true;
        m.ior = ior;
    })
}

/// Reflection with probability R (the closed form) into the mirror direction, transmission
/// with 1 − R straight on (wi = −wo exactly), each with weight ks or kt in both transport
/// directions (no η²); seen alike from both sides; nothing but the two deltas, whatever
/// the roughness.
#[test]
fn reflectance_and_transmittance_match_the_closed_form() {
    let kt = Rgb::new(0.5, 0.8, 1.0);
    for ior in [1.5f32, 1.33, 2.4] {
        for cos in [1.0f32, 0.8, 0.5, 0.2, 0.05] {
            let sin = (1.0 - cos * cos).sqrt();
            for side in [1.0f32, -1.0] {
                let wo = Vec3::new(sin * 0.6, sin * 0.8, cos * side);
                let want_r = thin_reflectance(cos as f64, ior as f64);
                for rough in [0.0, 0.5] {
                    let mut m = thin_glass(ior, Rgb::ONE);
                    classic_mut(&mut m).roughness = rough;
                    let bsdf = m.bsdf(&point(), wo);
                    assert!(!bsdf.has_non_delta());
                    let other = Vec3::new(0.1, -0.2, -side).normalize();
                    assert_eq!(bsdf.pdf(wo, other), 0.0);
                    assert_eq!(bsdf.eval(wo, other, Transport::Radiance), Rgb::ZERO);
                    for mode in [Transport::Radiance, Transport::Importance] {
                        let r = bsdf.sample(wo, 0.0, Vec2::splat(0.5), mode).unwrap();
                        let t = bsdf.sample(wo, 0.999_999, Vec2::splat(0.5), mode).unwrap();
                        assert!(r.delta && t.delta);
                        let mirror = Vec3::new(-wo.x, -wo.y, wo.z);
                        assert!((r.wi - mirror).length() < 1e-5, "{} vs {mirror}", r.wi);
                        assert_eq!(t.wi, -wo, "transmission bends");
                        let (pr, pt) = (r.pdf as f64, t.pdf as f64);
                        assert!(
                            (pr - want_r).abs() < 2e-6 && (pt - (1.0 - want_r)).abs() < 2e-6,
                            "ior {ior} cos {cos}: R {pr} T {pt}, closed form R {want_r}"
                        );
                        for w in [r.weight, t.weight] {
                            assert!((w - Rgb::ONE).abs().max_element() < 1e-5, "{w}");
                        }
                    }
                }
                // A tinted sheet: the lobes are picked by luminance, kt·T over its share.
                let glass = thin_glass(ior, kt);
                let bsdf = glass.bsdf(&point(), wo);
                let t = bsdf
                    .sample(wo, 0.999_999, Vec2::ZERO, Transport::Radiance)
                    .unwrap();
                let r = want_r as f32;
                let share = crate::math::luminance(kt) * (1.0 - r)
                    / (r + crate::math::luminance(kt) * (1.0 - r));
                assert!((t.pdf - share).abs() < 1e-5, "{} vs {share}", t.pdf);
                let want = kt * ((1.0 - r) / share);
                assert!((t.weight - want).abs().max_element() < 1e-4, "{}", t.weight);
            }
        }
    }
}

/// R + T = 1: the mean sample weight of a clear sheet is exactly 1 at every angle, in both
/// transport directions, and the reflected share is R.
#[test]
fn a_clear_sheet_conserves_energy() {
    let m = thin_glass(1.5, Rgb::ONE);
    let mut rng = Rng::for_key(11, &[]);
    for cos in [0.95f32, 0.6, 0.1] {
        let wo = Vec3::new((1.0 - cos * cos).sqrt(), 0.0, cos);
        let bsdf = m.bsdf(&point(), wo);
        let n = 20_000;
        let mut reflected = 0usize;
        for _ in 0..n {
            let ul = rng.uniform();
            for mode in [Transport::Radiance, Transport::Importance] {
                let s = bsdf.sample(wo, ul, Vec2::ZERO, mode).unwrap();
                assert!((s.weight - Rgb::ONE).abs().max_element() < 1e-5);
            }
            let s = bsdf
                .sample(wo, ul, Vec2::ZERO, Transport::Radiance)
                .unwrap();
            reflected += usize::from(s.wi.z > 0.0);
        }
        let r = thin_reflectance(cos as f64, 1.5);
        let share = reflected as f64 / n as f64;
        // 5 binomial standard errors.
        let se = (r * (1.0 - r) / n as f64).sqrt();
        assert!((share - r).abs() < 5.0 * se + 1e-4, "{share} vs {r}");
    }
}

/// The techniques without angular Fresnel (Whitted's Phong highlight) take the sheet's R and
/// 1 − R at normal incidence: 2F₀/(1 + F₀) with F₀ = ((η − 1)/(η + 1))²; the network's
/// lobes of a thin sheet are smooth and scatter R₀ and kt(1 − R₀) at normal incidence.
#[test]
fn normal_incidence_coefficients_and_a_smooth_network_lobe() {
    let mut m = thin_glass(1.5, Rgb::splat(0.8));
    classic_mut(&mut m).roughness = 0.4;
    let f0 = (0.5f64 / 2.5).powi(2);
    let r0 = (2.0 * f0 / (1.0 + f0)) as f32;
    assert!(
        (m.approximation().specular_at_normal() - Rgb::splat(r0))
            .abs()
            .max_element()
            < 1e-6
    );
    let t = m.approximation().transmission_at_normal();
    assert!(
        (t - Rgb::splat(0.8 * (1.0 - r0))).abs().max_element() < 1e-6,
        "{t}"
    );
    // The unit box with a thin glass floor (TOML refuses a rough sheet: the material above
    // carries its roughness in directly).
    let mut scene = closed_box(
        "[materials.w]\ndiffuse = 0.5\n[materials.pane]\nthin = true\n",
        "w",
        "pane",
    );
    let pane = scene
        .materials
        .iter()
        .position(|p| p.name == "pane")
        .unwrap();
    scene.materials[pane] = Material {
        name: "pane".into(),
        ..m
    };
    let net = build(&scene, params(4, 0.5), Builder::Scan);
    let panes: Vec<_> = surfaces(&net, &scene, 1.0)
        .into_iter()
        .filter(|s| s.kt != Rgb::ZERO)
        .collect();
    assert!(!panes.is_empty());
    for s in panes {
        assert_eq!(s.alpha, 0.0);
        assert!(s.optics.thin);
        assert!((s.ks - Rgb::splat(r0)).abs().max_element() < 1e-6);
        // The network scatters by the sheet's BSDF: at normal incidence R₀ back, kt(1 − R₀)
        // straight on.
        let bsdf = s.directional_bsdf(Vec3::Y, Vec3::Y);
        let (r, tr) = bsdf.albedo_by_side(Vec3::Y, 1, Transport::Importance);
        assert!((r - Rgb::splat(r0)).abs().max_element() < 1e-6, "{r}");
        assert!((tr - t).abs().max_element() < 1e-6, "{tr}");
    }
}

/// Whitted's integrator along single rays through a horizontal pane: R·(what the mirror
/// direction sees) + T·(what is straight on), with no total internal reflection at 60°,
/// where a glass surface seen from the same side reflects everything.
#[test]
fn whitted_sees_straight_through_a_pane() {
    let mut scene = empty_scene();
    let pane = add_material(&mut scene, thin_glass(1.5, Rgb::ONE));
    let sky = Rgb::new(1.0, 2.0, 3.0);
    let glow = Rgb::new(0.5, 0.0, 0.0);
    let emitter = |e: Rgb| {
        Material::classic(
            "",
            Classic {
                diffuse: Texture::Constant(Rgb::ZERO),
                ..Classic::default()
            },
        )
        .emitting(e)
    };
    let sky_m = add_material(&mut scene, emitter(sky));
    let glow_m = add_material(&mut scene, emitter(glow));
    // The pane at y = 1 facing up (the ray starts below it); the sky at y = 3 facing down;
    // the glowing floor at y = -1 facing up.
    floor(&mut scene, 1.0, 50.0, pane);
    let s = 50.0;
    quad(
        &mut scene,
        [
            Vec3::new(-s, 3.0, -s),
            Vec3::new(s, 3.0, -s),
            Vec3::new(s, 3.0, s),
            Vec3::new(-s, 3.0, s),
        ],
        sky_m,
    );
    floor(&mut scene, -1.0, 50.0, glow_m);
    let accel = accel::build(&scene, Backend::Embree, &Control::default()).unwrap();
    let ctx = Context::new(&scene, accel.as_ref());
    let whitted = Whitted::new(WhittedOptions {
        max_depth: 3,
        ..WhittedOptions::default()
    });
    for deg in [0.0f32, 30.0, 60.0, 80.0] {
        let a = deg.to_radians();
        let ray = Ray::new(Vec3::ZERO, Vec3::new(a.sin(), a.cos(), 0.0));
        let l = whitted
            .radiance(
                &ctx,
                &ray,
                &mut Rng::for_key(0, &[]),
                &mut RayStats::default(),
            )
            .radiance;
        let r = thin_reflectance(a.cos() as f64, 1.5) as f32;
        let want = glow * r + sky * (1.0 - r);
        assert!(
            (l - want).abs().max_element() < 1e-4,
            "{deg}°: {l} vs {want}"
        );
    }
}
