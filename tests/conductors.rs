//! Metals (pbrt-v4's conductor: complex Fresnel, GGX) rendered inside a closed box whose
//! walls emit radiance 1 and reflect nothing: a uniform environment, in which a convex
//! metal object's pixel is exactly its directional albedo: the complex Fresnel reflectance
//! for a smooth metal, a numerically integrated single-scattering albedo for a rough one.

#[path = "common/render.rs"]
mod render_common;

use raylink::image::filter::Filter;
use raylink::image::Image;
use raylink::job::AntiAliasing;
use raylink::job::MonteCarloSettings;
use raylink::scene::{Conductor, Scene};
use raylink::settings::NetworkBuilder;
use raylink::{Backend, Control, Job, Renderer, Settings, Technique, TechniqueKind};
use render_common::{boxed, image, View};
use std::path::Path;

const SIZE: u32 = 48;

/// A unit sphere of copper of GGX α `roughness` at the origin, seen from 1.9 units away
/// (filling most of a 48x48 image), inside the emitting box [-2, 2]³.
fn scene(roughness: f32) -> Scene {
    let text = format!(
        "[camera]\nposition = [0, 0, 1.9]\nlook_at = [0, 0, 0]\nfov = 70\nwidth = {SIZE}\nheight = {SIZE}\n\
         [materials.cu]\ndiffuse = 0\nconductor = \"Cu\"\nroughness = {roughness}\n\
         [materials.sky]\ndiffuse = 0\nemission = 1\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"cu\"\n\
         [[shapes]]\ntype = \"mesh\"\nmaterial = \"sky\"\n\
         positions = [[-2, -2, -2], [2, -2, -2], [2, 2, -2], [-2, 2, -2], [-2, -2, 2], [2, -2, 2], [2, 2, 2], [-2, 2, 2]]\n\
         indices = [[0, 1, 2], [0, 2, 3], [4, 6, 5], [4, 7, 6], [0, 3, 7], [0, 7, 4], [1, 5, 6], [1, 6, 2], [0, 4, 5], [0, 5, 1], [3, 2, 6], [3, 6, 7]]\n"
    );
    raylink::scene::toml::from_str(&text, Path::new("copper.toml")).unwrap()
}

fn render(scene: &Scene, technique: fn(MonteCarloSettings) -> Technique, spp: u32) -> Image {
    let view = View {
        size: (SIZE, SIZE),
        seed: 5,
        threads: None,
        accel: Backend::Embree,
    };
    image(scene, technique(boxed(2, spp)), view)
}

/// A render with the technique's default settings, `spp` samples per pixel and a box
/// filter, uniform supersampling where the technique takes it.
fn render_settings(scene: &Scene, kind: TechniqueKind, spp: u32) -> Image {
    let technique = Technique::create(&Settings {
        integrator: Some(kind),
        aa: (kind != TechniqueKind::IrradianceCache).then_some(AntiAliasing::Uniform),
        spp: Some(spp),
        filter: Some(Filter::Box { radius: 0.5 }),
        // The scan converter takes polygons only.
        network_builder: Some(NetworkBuilder::Embree),
        ..Settings::default()
    })
    .unwrap();
    let job = Job {
        width: SIZE,
        height: SIZE,
        threads: None,
        accel: Backend::Embree,
        ..Job::new(scene, technique)
    };
    let control = Control::default();
    Renderer::new(scene.clone(), job, &control)
        .unwrap()
        .render(&control)
        .unwrap()
        .image
}

/// The cosine between the view ray through raster (x, y) and the sphere's normal where it
/// hits, `None` if it misses.
fn incidence(scene: &Scene, x: f32, y: f32) -> Option<f64> {
    let ray = scene.camera.ray(x, y);
    let (o, d) = (ray.origin, ray.dir.normalize());
    let b = o.dot(d);
    let disc = b * b - (o.length_squared() - 1.0);
    if disc < 0.0 {
        return None;
    }
    let p = o + d * (-b - disc.sqrt());
    Some((-d.dot(p.normalize())) as f64)
}

/// The average of `f`(cos θ) over pixel (px, py) by a 32x32 grid (1 where the ray misses:
/// the background), matching a box filter of one pixel.
fn pixel_average(scene: &Scene, px: u32, py: u32, f: impl Fn(f64) -> [f64; 3]) -> [f64; 3] {
    let n = 32;
    let mut sum = [0.0; 3];
    for i in 0..n {
        for j in 0..n {
            let x = px as f32 + (i as f32 + 0.5) / n as f32;
            let y = py as f32 + (j as f32 + 0.5) / n as f32;
            let v = incidence(scene, x, y).map_or([1.0; 3], &f);
            for c in 0..3 {
                sum[c] += v[c] / (n * n) as f64;
            }
        }
    }
    sum
}

/// pbrt-v4's FrComplex, written out in f64 from the Fresnel equations (independent of the
/// renderer's f32 version).
fn fr_complex(cos: f64, eta: f64, k: f64) -> f64 {
    // |r|² for r = (a − b)/(a + b) with complex a, b.
    let norm = |(ar, ai): (f64, f64), (br, bi): (f64, f64)| {
        ((ar - br).powi(2) + (ai - bi).powi(2)) / ((ar + br).powi(2) + (ai + bi).powi(2))
    };
    let sin2 = 1.0 - cos * cos;
    // η² and sin²θt = sin²θi / η².
    let (e2r, e2i) = (eta * eta - k * k, 2.0 * eta * k);
    let d = e2r * e2r + e2i * e2i;
    let (sr, si) = (sin2 * e2r / d, -sin2 * e2i / d);
    // cos θt = √(1 − sin²θt), principal root.
    let (zr, zi) = (1.0 - sr, -si);
    let m = (zr * zr + zi * zi).sqrt();
    let tr = ((m + zr) / 2.0).sqrt();
    let ti = ((m - zr) / 2.0).sqrt().copysign(zi);
    let eta_cos = (eta * cos, k * cos);
    let eta_ct = (eta * tr - k * ti, eta * ti + k * tr);
    0.5 * (norm(eta_cos, (tr, ti)) + norm((cos, 0.0), eta_ct))
}

fn copper_fresnel(cos: f64) -> [f64; 3] {
    let cu = Conductor::named("Cu").unwrap();
    [0, 1, 2].map(|c| fr_complex(cos, cu.eta[c] as f64, cu.k[c] as f64))
}

/// Smooth copper: every pixel is the complex Fresnel reflectance at its incidence angle
/// (averaged over the pixel), the centre copper's normal-incidence colour, the rim going to
/// 1. Path tracing, BDPT and Whitted (8x8 uniform supersampling), within 1% per channel.
#[test]
fn smooth_copper_sphere_shows_complex_fresnel() {
    let scene = scene(0.0);
    let f0 = copper_fresnel(1.0);
    let n = [0.200438f64, 0.924033, 1.10221];
    let k = [3.91295f64, 2.45285, 2.14219];
    for c in 0..3 {
        let closed = ((n[c] - 1.0).powi(2) + k[c] * k[c]) / ((n[c] + 1.0).powi(2) + k[c] * k[c]);
        assert!((f0[c] - closed).abs() < 1e-6);
    }
    // The network's lobes have no angular Fresnel: it shows copper at normal incidence,
    // F0, over the whole sphere.
    let network = render_settings(&scene, TechniqueKind::Network, 16);
    for (px, py) in [
        (SIZE / 2, SIZE / 2),
        (SIZE / 2, SIZE / 4),
        (SIZE / 3, SIZE / 2),
    ] {
        let got = network.get(px, py);
        eprintln!("network ({px}, {py}): {got}");
        for c in 0..3 {
            assert!(
                (got[c] as f64 / f0[c] - 1.0).abs() < 0.02,
                "network pixel ({px}, {py}) channel {c}: {} vs F0 {}",
                got[c],
                f0[c]
            );
        }
    }
    for name in ["path", "bdpt", "whitted", "cache"] {
        let image = match name {
            "path" => render(&scene, Technique::Path, 64),
            "bdpt" => render(&scene, Technique::Bdpt, 64),
            "whitted" => render_settings(&scene, TechniqueKind::Whitted, 64),
            _ => render_settings(&scene, TechniqueKind::IrradianceCache, 64),
        };
        let mut rim_cos = 1.0f64;
        let mut worst = 0.0f64;
        for py in 0..SIZE {
            for px in 0..SIZE {
                let corners = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                    .map(|(dx, dy)| incidence(&scene, px as f32 + dx, py as f32 + dy));
                // Pixels wholly on the sphere.
                if corners.iter().any(|c| c.is_none()) {
                    continue;
                }
                rim_cos = corners.iter().fold(rim_cos, |m, c| m.min(c.unwrap()));
                let expect = pixel_average(&scene, px, py, copper_fresnel);
                let got = image.get(px, py);
                for c in 0..3 {
                    let rel = (got[c] as f64 - expect[c]).abs() / expect[c];
                    worst = worst.max(rel);
                    assert!(
                        rel < 0.01,
                        "{name} pixel ({px}, {py}) channel {c}: {} vs Fresnel {}",
                        got[c],
                        expect[c]
                    );
                }
            }
        }
        let centre = image.get(SIZE / 2, SIZE / 2);
        eprintln!(
            "{name}: centre {centre} (F0 {f0:?}), worst relative error {worst:.2e}, rim pixels reach cos θ = {rim_cos:.3}"
        );
        // The rim pixels see grazing angles, where copper reflects nearly everything.
        assert!(rim_cos < 0.25);
    }
}

/// Directional albedo ∫ f cos θi dω of GGX copper of roughness `alpha` for view cosine
/// `cos_o`, integrated numerically in f64 from the model's formulas (Trowbridge-Reitz D,
/// height-correlated Smith G, FrComplex at the half vector): what a furnace pixel shows,
/// single scattering only.
fn rough_albedo(alpha: f64, cos_o: f64) -> [f64; 3] {
    let cos_o = cos_o.clamp(1e-4, 1.0);
    let wo = [(1.0 - cos_o * cos_o).sqrt(), 0.0, cos_o];
    let a2 = alpha * alpha;
    let lambda = |z: f64| {
        let tan2 = (1.0 - z * z).max(0.0) / (z * z);
        0.5 * ((1.0 + a2 * tan2).sqrt() - 1.0)
    };
    let cu = Conductor::named("Cu").unwrap();
    let n = 400;
    let mut sum = [0.0; 3];
    for i in 0..n {
        // z = 1 − t² puts more points near the pole.
        let t = (i as f64 + 0.5) / n as f64;
        let z = 1.0 - t * t;
        let dz = 2.0 * t / n as f64;
        let r = (1.0 - z * z).sqrt();
        for j in 0..n {
            let phi = std::f64::consts::TAU * (j as f64 + 0.5) / n as f64;
            let wi = [r * phi.cos(), r * phi.sin(), z];
            let h = [wo[0] + wi[0], wo[1] + wi[1], wo[2] + wi[2]];
            let len = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
            let (hz, o_h) = (h[2] / len, (wo[0] * h[0] + wo[2] * h[2]) / len);
            let k = hz * hz * (a2 - 1.0) + 1.0;
            let d = a2 / (std::f64::consts::PI * k * k);
            let g = 1.0 / (1.0 + lambda(cos_o) + lambda(z));
            let w = d * g / (4.0 * cos_o) * dz * std::f64::consts::TAU / n as f64;
            for (c, s) in sum.iter_mut().enumerate() {
                *s += w * fr_complex(o_h, cu.eta[c] as f64, cu.k[c] as f64);
            }
        }
    }
    sum
}

/// Rough copper (α = 0.3) in the furnace: path tracing, light tracing (importance
/// transport through the conductor) and BDPT each match the numerically integrated
/// single-scattering albedo, compared over rings of pixels (mean of the pixels' values
/// against the mean of their albedos at the pixel centre's view angle) within four standard
/// errors of the ring's mean plus 0.2%. The albedo is below
/// the smooth metal's Fresnel reflectance by the microfacet model's single-scattering
/// loss (about 12% at normal incidence for α = 0.3: GGX's long tail reflects some light
/// below the horizon, where G drops it).
#[test]
fn rough_copper_furnace_matches_integrated_albedo() {
    let alpha = 0.3;
    let scene = scene(alpha as f32);
    // Albedo at 65 view cosines, interpolated linearly.
    let table: Vec<[f64; 3]> = (0..=64)
        .map(|i| rough_albedo(alpha, i as f64 / 64.0))
        .collect();
    let albedo = |cos: f64| {
        let x = cos.clamp(0.0, 1.0) * 64.0;
        let i = (x.floor() as usize).min(63);
        let t = x - i as f64;
        [0, 1, 2].map(|c| table[i][c] * (1.0 - t) + table[i + 1][c] * t)
    };
    // Energy: below the smooth Fresnel reflectance, by a small single-scattering loss.
    for cos in [1.0, 0.7, 0.4] {
        let (a, f) = (albedo(cos), copper_fresnel(cos));
        for c in 0..3 {
            let loss = 1.0 - a[c] / f[c];
            eprintln!("cos {cos} channel {c}: single-scattering loss {loss:.3}");
            assert!(
                loss > 0.0 && loss < 0.25,
                "cos {cos}: albedo {a:?} vs F {f:?}"
            );
        }
    }
    let rings = [0.0, 0.3, 0.5, 0.7, 0.85];
    for (name, technique, spp) in [
        ("path", Technique::Path as fn(_) -> _, 256),
        ("bdpt", Technique::Bdpt as fn(_) -> _, 256),
        ("light", Technique::Light as fn(_) -> _, 2048),
    ] {
        let image = render(&scene, technique, spp);
        for ring in rings.windows(2) {
            // Per channel: the residuals (pixel − albedo) and the albedos of the ring.
            let mut residuals: [Vec<f64>; 3] = Default::default();
            let mut expect = [0.0f64; 3];
            for py in 0..SIZE {
                for px in 0..SIZE {
                    let (x, y) = (px as f32 + 0.5, py as f32 + 0.5);
                    let Some(cos) = incidence(&scene, x, y) else {
                        continue;
                    };
                    // Ring by sin θ (distance from the sphere's centre on the view).
                    let sin = (1.0 - cos * cos).sqrt();
                    if sin < ring[0] || sin >= ring[1] {
                        continue;
                    }
                    let a = albedo(cos);
                    let v = image.get(px, py);
                    for c in 0..3 {
                        residuals[c].push(v[c] as f64 - a[c]);
                        expect[c] += a[c];
                    }
                }
            }
            let count = residuals[0].len() as f64;
            assert!(count > 20.0);
            for c in 0..3 {
                let mean = residuals[c].iter().sum::<f64>() / count;
                let var =
                    residuals[c].iter().map(|r| (r - mean).powi(2)).sum::<f64>() / (count - 1.0);
                // Four standard errors of the ring's mean, plus 0.2% for the albedo table
                // and the pixel-centre approximation.
                let se = (var / count).sqrt();
                let albedo_mean = expect[c] / count;
                let bound = 4.0 * se + 0.002 * albedo_mean;
                eprintln!(
                    "{name} ring {ring:?} channel {c}: {:.4} vs albedo {albedo_mean:.4} ({:+.4}, bound {bound:.4})",
                    albedo_mean + mean,
                    mean
                );
                assert!(mean.abs() < bound, "{name} ring {ring:?} channel {c}");
            }
        }
    }
}
