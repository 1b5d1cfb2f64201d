//! pbrt-v4's `coateddiffuse` read from a scene file and path traced in a white furnace: each
//! pixel on the sphere shows the layered BSDF's directional albedo at its view angle.

use super::bsdf::{coating_of, point};
use crate::bsdf::Transport;
use crate::image::filter::Filter;
use crate::job::MonteCarloSettings;
use crate::math::{Rng, Vec2, Vec3};
use crate::scene::Scene;
use crate::{Backend, Control, Job, Renderer, Technique};

const SIZE: u32 = 40;

/// The directional albedo of `scene`'s first material at view cosine `cos` (green
/// channel), from 20000 samples of the BSDF.
fn albedo(scene: &Scene, cos: f32) -> f64 {
    let wo = Vec3::new((1.0 - cos * cos).max(0.0).sqrt(), 0.0, cos);
    let bsdf = scene.materials[0].bsdf(&point(), wo);
    let mut rng = Rng::for_key(0x6675, &[cos.to_bits() as u64]);
    let n = 20_000;
    let mut sum = 0.0;
    for _ in 0..n {
        let (u_lobe, u) = (rng.uniform(), Vec2::new(rng.uniform(), rng.uniform()));
        if let Some(s) = bsdf.sample(wo, u_lobe, u, Transport::Radiance) {
            sum += s.weight.y as f64;
        }
    }
    sum / n as f64
}

/// The cosine between the view ray through (x, y) and the unit sphere's normal, if it hits.
fn incidence(scene: &Scene, x: f32, y: f32) -> Option<f32> {
    let ray = scene.camera.ray(x, y);
    let (o, d) = (ray.origin, ray.dir.normalize());
    let b = o.dot(d);
    let disc = b * b - (o.length_squared() - 1.0);
    if disc < 0.0 {
        return None;
    }
    let p = o + d * (-b - disc.sqrt());
    Some(-d.dot(p.normalize()))
}

/// A coated diffuse sphere (reflectance 0.8, pbrt's default coat: smooth, index 1.5,
/// thickness 0.01) under a uniform white sky loads without a warning and renders its
/// albedo: over each ring of pixels, the mean of (pixel − albedo at the pixel centre's view
/// angle) is within four standard errors plus 1% (the pixel-centre approximation and the
/// albedo's own sampling error).
#[test]
fn coated_diffuse_sphere_in_a_furnace_renders_its_albedo() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("furnace.pbrt");
    std::fs::write(
        &file,
        format!(
            "LookAt 0 0 3.2  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 45\n\
             Film \"rgb\" \"integer xresolution\" {SIZE} \"integer yresolution\" {SIZE}\n\
             WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n\
             Material \"coateddiffuse\" \"rgb reflectance\" [0.8 0.8 0.8]\n\
             Shape \"sphere\" \"float radius\" 1\n"
        ),
    )
    .unwrap();
    let scene = Scene::load(&file).unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    assert!(coating_of(&scene.materials[0]).is_some());
    let mc = MonteCarloSettings {
        max_depth: 2,
        spp: 256,
        time_limit: None,
        filter: Filter::Box { radius: 0.5 },
        reconstruction: crate::image::filter::Reconstruction::Splat,
        adaptive: None,
        max_component_value: None,
        guiding: false,
        spectral: false,
    };
    let job = Job {
        width: SIZE,
        height: SIZE,
        region: None,
        seed: 3,
        threads: None,
        accel: Backend::Embree,
        ..Job::new(&scene, Technique::Path(mc))
    };
    let control = Control::default();
    let image = Renderer::new(scene.clone(), job, &control)
        .unwrap()
        .render(&control)
        .unwrap()
        .film
        .unwrap()
        .image()
        .unwrap();
    let table: Vec<f64> = (0..=16).map(|i| albedo(&scene, i as f32 / 16.0)).collect();
    let albedo_at = |cos: f32| {
        let x = cos.clamp(0.0, 1.0) as f64 * 16.0;
        let i = (x.floor() as usize).min(15);
        table[i] + (table[i + 1] - table[i]) * (x - i as f64)
    };
    let rings = [0.0, 0.4, 0.6, 0.8];
    for ring in rings.windows(2) {
        let (mut residuals, mut expect) = (Vec::new(), 0.0);
        for py in 0..SIZE {
            for px in 0..SIZE {
                let Some(cos) = incidence(&scene, px as f32 + 0.5, py as f32 + 0.5) else {
                    continue;
                };
                let sin = (1.0 - cos * cos).sqrt();
                if sin < ring[0] || sin >= ring[1] {
                    continue;
                }
                let a = albedo_at(cos);
                residuals.push(image.get(px, py)[1] as f64 - a);
                expect += a;
            }
        }
        let n = residuals.len() as f64;
        assert!(n > 20.0, "ring {ring:?}: {n} pixels");
        let mean = residuals.iter().sum::<f64>() / n;
        let var = residuals.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / (n - 1.0);
        let bound = 4.0 * (var / n).sqrt() + 0.01 * expect / n;
        eprintln!(
            "ring {ring:?}: pixels {:.4} vs albedo {:.4} (bound {bound:.4})",
            expect / n + mean,
            expect / n
        );
        assert!(mean.abs() < bound, "ring {ring:?}: {mean} vs bound {bound}");
        assert!(
            expect / n < 0.95,
            "the albedo of ρ 0.8 under a coat is below 1"
        );
    }
}

/// A coated material written to a scene file reads back as it was, and the keys that follow
/// from the coat (a diffuse base's Fresnel-weighted mirror, the coat's index) are set.
#[test]
fn coating_round_trips_through_a_scene_file() {
    let text = "[camera]\nposition = [0, 0, 3]\nlook_at = [0, 0, 0]\n\
        [materials.lacquer]\ndiffuse = 0.6\n\
        coating = { ior = 1.4, roughness = [0.1, 0.2], thickness = 0.05, albedo = 0.3, g = 0.2, max_depth = 20, samples = 2 }\n\
        [materials.gold]\nconductor = \"Au\"\nroughness = 0.1\ncoating = { roughness = 0.05 }\n\
        [[shapes]]\ntype = \"sphere\"\nmaterial = \"lacquer\"\n\
        [[shapes]]\ntype = \"sphere\"\ncenter = [2, 0, 0]\nmaterial = \"gold\"\n";
    let scene = crate::scene::toml::from_str(text, std::path::Path::new("coat.toml")).unwrap();
    let (lacquer, gold) = (&scene.materials[0], &scene.materials[1]);
    let c = coating_of(lacquer).unwrap();
    assert_eq!((c.ior, c.roughness, c.roughness_v), (1.4, 0.1, Some(0.2)));
    assert_eq!(
        (c.thickness, c.g, c.max_depth, c.samples),
        (0.05, 0.2, 20, 2)
    );
    let (lc, gc) = (lacquer.approximation(), gold.approximation());
    assert!(lc.fresnel && lc.ior == 1.4 && lc.roughness == 0.1);
    assert_eq!(lc.specular, crate::math::Rgb::ONE);
    let g = coating_of(gold).unwrap();
    assert_eq!((g.ior, g.roughness, g.thickness), (1.5, 0.05, 0.01));
    assert!(!gc.fresnel && gc.roughness == 0.1 && gc.conductor.is_some());
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.toml");
    crate::scene::convert::write_toml(&scene, &out).unwrap();
    let back = Scene::load(&out).unwrap();
    assert_eq!(coating_of(&back.materials[0]), coating_of(lacquer));
    assert_eq!(coating_of(&back.materials[1]), coating_of(gold));
    assert_eq!(back.materials[0].approximation().fresnel, lc.fresnel);
    assert_eq!(back.materials[1].approximation().roughness, gc.roughness);
}

/// pbrt-v4's `coatedconductor` reads as a coat over the metal without a warning: the
/// interface's roughness and index, the conductor's roughness and index (or its unprefixed
/// `reflectance`), the walk's settings.
#[test]
fn pbrt_coated_conductor_is_a_coat_over_the_metal() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("coated.pbrt");
    std::fs::write(
        &file,
        "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\"\nWorldBegin\n\
         Material \"coatedconductor\" \"float interface.roughness\" 0.04 \"float interface.eta\" 1.4 \
         \"float conductor.roughness\" 0.09 \"spectrum conductor.eta\" \"metal-Au-eta\" \
         \"spectrum conductor.k\" \"metal-Au-k\" \"float thickness\" 0.02 \"integer maxdepth\" 5 \
         \"integer nsamples\" 3 \"float g\" 0.5 \"rgb albedo\" [0.1 0.2 0.3]\n\
         Shape \"sphere\"\n\
         Material \"coatedconductor\" \"rgb reflectance\" [0.9 0.5 0.2]\nShape \"sphere\"\n",
    )
    .unwrap();
    let scene = Scene::load(&file).unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let m = scene.materials[0].approximation();
    let c = coating_of(&scene.materials[0]).unwrap();
    assert!((c.roughness - 0.2).abs() < 1e-6 && c.ior == 1.4 && c.thickness == 0.02);
    assert_eq!((c.max_depth, c.samples, c.g), (5, 3, 0.5));
    assert_eq!(c.albedo, crate::math::Rgb::new(0.1, 0.2, 0.3));
    assert!((m.roughness - 0.3).abs() < 1e-6 && !m.fresnel);
    assert_eq!(m.conductor, crate::scene::Conductor::named("Au"));
    let r = scene.materials[1].approximation().specular_at_normal();
    assert!(
        (r - crate::math::Rgb::new(0.9, 0.5, 0.2))
            .abs()
            .max_element()
            < 1e-4,
        "{r}"
    );
    assert_eq!(
        coating_of(&scene.materials[1]).unwrap(),
        crate::scene::Coating::default()
    );
}
