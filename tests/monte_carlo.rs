//! The Monte Carlo integrators against analytic answers, each other, an external reference
//! render, and themselves (determinism).

use raylink::image::compare::{bright_mask, mean, rmse};
use raylink::image::filter::{Filter, Reconstruction};
use raylink::image::output::read_image;
use raylink::image::Image;
use raylink::job::MonteCarloSettings;
use raylink::scene::Scene;
use raylink::{Backend, Control, Job, Renderer, Technique};
use std::path::Path;

mod agreement;

fn manifest(p: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(p)
}

#[derive(Clone, Copy, Debug)]
enum Kind {
    Path,
    Light,
    Bdpt,
}

impl Kind {
    fn name(self) -> &'static str {
        match self {
            Kind::Path => "Path",
            Kind::Light => "Light",
            Kind::Bdpt => "Bdpt",
        }
    }
}

fn technique(kind: Kind, mc: MonteCarloSettings) -> Technique {
    match kind {
        Kind::Path => Technique::Path(mc),
        Kind::Light => Technique::Light(mc),
        Kind::Bdpt => Technique::Bdpt(mc),
    }
}

struct Setup {
    width: u32,
    height: u32,
    spp: u32,
    max_depth: u32,
    seed: u64,
    threads: Option<usize>,
    filter: Filter,
}

fn render(scene: &Scene, kind: Kind, s: &Setup) -> Image {
    render_with(scene, kind, s, Reconstruction::Splat)
}

fn render_with(scene: &Scene, kind: Kind, s: &Setup, reconstruction: Reconstruction) -> Image {
    let mc = MonteCarloSettings {
        max_depth: s.max_depth,
        spp: s.spp,
        time_limit: None,
        filter: s.filter,
        reconstruction,
        adaptive: None,
        max_component_value: None,
        guiding: false,
        spectral: false,
    };
    let job = Job {
        width: s.width,
        height: s.height,
        region: None,
        seed: s.seed,
        threads: s.threads,
        accel: Backend::Embree,
        ..Job::new(scene, technique(kind, mc))
    };
    let control = Control::default();
    let rendered = Renderer::new(scene.clone(), job, &control)
        .unwrap()
        .render(&control)
        .unwrap();
    let film = rendered
        .film
        .expect("a whole progressive render keeps its film");
    assert_eq!(film.invalid, 0, "{kind:?}: non-finite samples");
    film.image().unwrap()
}

/// White furnace: in a closed cube whose walls have albedo ρ = 0.5 and emit Le = 1, every
/// pixel is Le / (1 − ρ) = 2. The image mean must be within 0.5%, and every pixel within a
/// bound several times its noise at the chosen sample count.
#[test]
fn white_furnace() {
    let scene = Scene::load(&manifest("tests/scenes/furnace.toml")).unwrap();
    let pixel = Filter::Box { radius: 0.5 };
    for (kind, spp, pixel_tolerance, filter) in [
        (Kind::Path, 256, 0.05, pixel),
        // Splatted through a Gaussian: pixels on the image's edges, which lose the weight
        // that falls outside it, are still their samples' weighted mean.
        (Kind::Path, 256, 0.05, Filter::default()),
        (Kind::Bdpt, 256, 0.05, pixel),
        // Light tracing spreads its paths over all 24 m² of wall, most unseen: many more.
        (Kind::Light, 8192, 0.15, pixel),
    ] {
        let setup = Setup {
            width: 24,
            height: 16,
            spp,
            // Truncation leaves out ρ^21 ≈ 5e-7 of the answer.
            max_depth: 20,
            seed: 1,
            threads: None,
            filter,
        };
        let image = render(&scene, kind, &setup);
        let m = mean(&image, None);
        let err = (m.x / 2.0 - 1.0).abs();
        eprintln!("furnace {kind:?}: mean {} (error {:.3}%)", m.x, 100.0 * err);
        assert!(err < 0.005, "{kind:?}: furnace mean {} instead of 2", m.x);
        for p in &image.pixels {
            assert!(
                (p.x / 2.0 - 1.0).abs() < pixel_tolerance,
                "{kind:?}: furnace pixel {p}"
            );
        }
    }
}

/// Adjoint consistency: path tracing (gathering), light tracing (shooting) and BDPT render
/// the Cornell box to the same image. Each is rendered with 8 seeds; per pixel, the
/// difference of two estimators' means divided by its standard error (Welch's t, 7+ degrees
/// of freedom) must rarely exceed 5, and the image-wide mean difference must be within 4
/// standard errors.
#[test]
fn gathering_shooting_and_bidirectional_agree() {
    let scene = Scene::load(&manifest("scenes/cornell-box.toml")).unwrap();
    check_adjoint(&scene, &[]);
}

/// The same on the Cornell box with rough gold, mirror and glass spheres, where light also
/// arrives through specular bounces (caustics under the glass sphere). A light path cannot
/// end on the camera through a mirror or glass surface (the camera is a pinhole and the
/// surface's BSDF a delta), so light tracing is compared only in pixels that see neither;
/// path tracing and BDPT everywhere.
#[test]
fn gathering_shooting_and_bidirectional_agree_on_glossy_and_specular_spheres() {
    let scene = Scene::load(&manifest("scenes/cornell-spheres.toml")).unwrap();
    // Shapes 1 and 2 are the mirror and the glass sphere.
    check_adjoint(&scene, &[1, 2]);
}

/// The same with the glass sphere made rough (GGX α = 0.3, reflection and refraction):
/// light now reaches the camera through it by every strategy, light tracing included, so
/// only the mirror sphere's pixels are left out of the comparisons with light tracing.
#[test]
fn gathering_shooting_and_bidirectional_agree_through_rough_glass() {
    let scene = cornell_spheres_with_glass(|glass| classic_mut(glass).roughness = 0.3);
    check_adjoint(&scene, &[1]);
}

/// The same with the glass sphere made a translucent shell (Lambertian reflection 0.3,
/// Lambertian transmission 0.5): light tracing is compared on it too.
#[test]
fn gathering_shooting_and_bidirectional_agree_through_diffuse_transmission() {
    let scene = cornell_spheres_with_glass(|glass| {
        *glass = raylink::scene::Material::classic(
            glass.name.clone(),
            raylink::scene::Classic {
                diffuse: raylink::scene::Texture::Constant(raylink::math::Rgb::splat(0.3)),
                diffuse_transmission: raylink::scene::Texture::Constant(raylink::math::Rgb::splat(
                    0.5,
                )),
                ..raylink::scene::Classic::default()
            },
        )
    });
    check_adjoint(&scene, &[1]);
}

/// The same with the glass sphere a mix (`amount` 0.4) of its glass and a diffuse white:
/// the material chosen at each hit by a hash of the hit and the arriving direction, which
/// light paths and camera paths arrive by differently, agrees on average. Light tracing
/// cannot see the glass's share (a delta), so it is left out there.
#[test]
fn gathering_shooting_and_bidirectional_agree_on_a_mix() {
    let mut scene = Scene::load(&manifest("scenes/cornell-spheres.toml")).unwrap();
    let glass = scene
        .materials
        .iter()
        .position(|m| m.name == "glass")
        .unwrap();
    scene.materials.push(raylink::scene::Material::classic(
        "white",
        raylink::scene::Classic {
            diffuse: raylink::scene::Texture::Constant(raylink::math::Rgb::splat(0.8)),
            ..raylink::scene::Classic::default()
        },
    ));
    let white = scene.materials.len() - 1;
    let mix = raylink::scene::Material::mix_of(
        "mix".into(),
        (glass, &scene.materials[glass]),
        (white, &scene.materials[white]),
        raylink::scene::Texture::Constant(raylink::math::Vec3::splat(0.4)),
    );
    scene.materials.push(mix);
    let mixed = scene.materials.len() - 1;
    for shape in &mut scene.shapes {
        if shape.material == glass {
            shape.material = mixed;
        }
    }
    check_adjoint(&scene, &[1, 2]);
}

/// `scenes/cornell-spheres.toml` with its glass material changed by `edit`.
fn cornell_spheres_with_glass(edit: impl FnOnce(&mut raylink::scene::Material)) -> Scene {
    let mut scene = Scene::load(&manifest("scenes/cornell-spheres.toml")).unwrap();
    let glass = scene
        .materials
        .iter_mut()
        .find(|m| m.name == "glass")
        .expect("the scene has a glass material");
    edit(glass);
    scene
}

/// The classic terms of `m`, a classic material (as the scene files' plain keys make), to
/// change.
fn classic_mut(m: &mut raylink::scene::Material) -> &mut raylink::scene::Classic {
    match &mut m.surface {
        raylink::scene::Surface::Classic(c) => c,
        other => panic!("not a classic material: {other:?}"),
    }
}

/// Whether each pixel of a 48x48 view sees any of `shapes` at its centre or corners.
fn sees_shapes(scene: &Scene, shapes: &[u32]) -> Vec<bool> {
    let accel = raylink::accel::build(scene, Backend::Embree, &Control::default()).unwrap();
    let mut camera = scene.camera.clone();
    (camera.width, camera.height) = (48, 48);
    let basis = camera.basis();
    let mut mask = Vec::with_capacity(48 * 48);
    for y in 0..48 {
        for x in 0..48 {
            let points = [(0.5, 0.5), (0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)];
            mask.push(points.iter().any(|(dx, dy)| {
                let ray = basis.ray(x as f32 + dx, y as f32 + dy);
                accel
                    .intersect(&ray)
                    .is_some_and(|h| shapes.contains(&h.geom_id))
            }));
        }
    }
    mask
}

fn check_adjoint(scene: &Scene, specular_shapes: &[u32]) {
    let specular = sees_shapes(scene, specular_shapes);
    let runs = [(Kind::Path, 16), (Kind::Light, 32), (Kind::Bdpt, 8)];
    let results = agreement::over_seeds(
        runs.map(|(kind, spp)| (kind.name(), (kind, spp))),
        |&(kind, spp), seed| {
            render(
                scene,
                kind,
                &Setup {
                    width: 48,
                    height: 48,
                    spp,
                    max_depth: 5,
                    seed,
                    threads: None,
                    filter: Filter::Box { radius: 0.5 },
                },
            )
        },
    );
    let light = |a: &str, b: &str| a == "Light" || b == "Light";
    agreement::assert_agree(&results, |a, b, i| !(light(a, b) && specular[i]));
}

/// Renders `scene` with the path tracer at 256x256 (64 bounces, box filter) and returns the
/// RMSE against Tungsten's converged render (box-downsampled from 1024x1024 to 256x256, as
/// stored in scenes/cornell-box-bitterli; the light's pixels, i.e. reference brighter than 1
/// and their neighbours, excluded), after checking the mean colour is within 1%.
fn error_against_tungsten(scene: &Scene, spp: u32) -> f64 {
    let reference = manifest("scenes/cornell-box-bitterli/TungstenRender-256.exr");
    let (reference, _) = read_image(&reference).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((reference.width, reference.height), (256, 256));
    let image = render(
        scene,
        Kind::Path,
        &Setup {
            width: 256,
            height: 256,
            spp,
            max_depth: 64,
            seed: 0,
            threads: None,
            filter: Filter::Box { radius: 0.5 },
        },
    );
    let mask = bright_mask(&reference, 1.0);
    let e = rmse(&image, &reference, Some(&mask));
    let (m, r) = (mean(&image, Some(&mask)), mean(&reference, Some(&mask)));
    eprintln!("Tungsten: RMSE {e:.5} without the light, mean {m} vs {r}");
    for c in 0..3 {
        assert!((m[c] / r[c] - 1.0).abs() < 0.01, "mean {m} vs {r}");
    }
    e
}

/// The Bitterli Cornell box (scenes/cornell-box.toml) against Tungsten's converged render.
/// At 64 spp the path tracer reaches an RMSE of about 0.006 (Mitsuba 3: 0.0056); the bound
/// leaves room for noise.
#[test]
fn cornell_box_matches_tungsten() {
    let scene = Scene::load(&manifest("scenes/cornell-box.toml")).unwrap();
    let e = error_against_tungsten(&scene, 64);
    assert!(e < 0.0075, "RMSE {e}");
}

/// Splatting against filter importance sampling, on the Bitterli box with the default
/// Gaussian at 16 spp: both agree with Tungsten's mean, and splatting, where neighbours share
/// samples, has about half the variance (measured 0.44 of it; the bound is 0.7). With a box
/// of one pixel the two are the same estimator with the same samples: equal pixels, up to
/// the rounding of a mean taken as a ratio.
#[test]
fn splatting_keeps_the_mean_and_lowers_the_noise() {
    let scene = Scene::load(&manifest("scenes/cornell-box.toml")).unwrap();
    let reference = manifest("scenes/cornell-box-bitterli/TungstenRender-256.exr");
    let (reference, _) = read_image(&reference).unwrap_or_else(|e| panic!("{e}"));
    let mask = bright_mask(&reference, 1.0);
    let setup = |filter| Setup {
        width: 256,
        height: 256,
        spp: 16,
        max_depth: 64,
        seed: 2,
        threads: None,
        filter,
    };
    let error = |reconstruction| {
        let image = render_with(
            &scene,
            Kind::Path,
            &setup(Filter::default()),
            reconstruction,
        );
        let (m, r) = (mean(&image, Some(&mask)), mean(&reference, Some(&mask)));
        for c in 0..3 {
            assert!(
                (m[c] / r[c] - 1.0).abs() < 0.01,
                "{reconstruction:?}: mean {m} vs {r}"
            );
        }
        rmse(&image, &reference, Some(&mask))
    };
    let (splat, importance) = (
        error(Reconstruction::Splat),
        error(Reconstruction::Importance),
    );
    eprintln!("RMSE at 16 spp: splatted {splat:.5}, sampled {importance:.5}");
    assert!(
        splat * splat < 0.7 * importance * importance,
        "splatted {splat} vs sampled {importance}"
    );
    let pixel = Setup {
        width: 48,
        height: 40,
        spp: 4,
        ..setup(Filter::Box { radius: 0.5 })
    };
    let a = render_with(&scene, Kind::Path, &pixel, Reconstruction::Splat);
    let b = render_with(&scene, Kind::Path, &pixel, Reconstruction::Importance);
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        assert!(
            (*p - *q).abs().max_element() <= 1e-6 * q.max_element().max(1.0),
            "{p} vs {q}"
        );
    }
}

/// The same scene read from Bitterli's own pbrt-v4 file: 32 spp reach about 0.0085.
#[test]
fn cornell_box_from_pbrt_matches_tungsten() {
    let path = manifest("scenes/cornell-box-bitterli/scene-v4.pbrt");
    let scene = Scene::load(&path).unwrap();
    let e = error_against_tungsten(&scene, 32);
    assert!(e < 0.0105, "RMSE {e}");
}

/// The same seed gives the same image, bit for bit, on 1 and 2 threads, for every
/// integrator (light paths splat across tiles: their merge order is fixed).
#[test]
fn images_do_not_depend_on_thread_count() {
    let scene = Scene::load(&manifest("scenes/cornell-box.toml")).unwrap();
    for kind in [Kind::Path, Kind::Light, Kind::Bdpt] {
        let setup = |threads| Setup {
            width: 40,
            height: 40,
            spp: 4,
            max_depth: 8,
            seed: 7,
            threads: Some(threads),
            filter: Filter::default(),
        };
        let a = render(&scene, kind, &setup(1));
        let b = render(&scene, kind, &setup(2));
        assert!(
            a.pixels == b.pixels,
            "{kind:?}: images differ between 1 and 2 threads"
        );
    }
}

/// Image-based lighting: a diffuse sphere under a non-uniform environment map. Seen head-on,
/// its radiance is ρ/π ∫ L_env(ω) cos θ dω over the hemisphere about the normal, integrated
/// here numerically from the map itself; the path tracer (which samples the map by
/// luminance and combines it with BSDF sampling) must agree within 1%.
#[test]
fn environment_map_lighting_matches_quadrature() {
    use raylink::math::{Mat3, Rgb, Vec3};
    use raylink::scene::{
        Camera, Classic, Environment, Geometry, Material, Shape, Sphere, Texture,
    };
    let n = 16;
    let mut map = Image::new(n, n);
    for y in 0..n {
        for x in 0..n {
            // A smooth gradient plus one bright texel, like a sun.
            let v = 0.2 + (x as f32 / n as f32) * 2.0 + (y as f32 / n as f32);
            let sun = if (x, y) == (11, 4) { 300.0 } else { 0.0 };
            map.set(x, y, Rgb::new(v + sun, 0.5 * v + sun, 0.25 * v + sun));
        }
    }
    let env = Environment::new(map, "gradient".into(), Mat3::IDENTITY, Rgb::ONE).unwrap();
    let scene = Scene {
        media: Vec::new(),
        camera_medium: None,
        source: "environment test".into(),
        camera: Camera {
            position: Vec3::new(0.0, 0.0, 5.0),
            look_at: Vec3::ZERO,
            up: Vec3::Y,
            fov_deg: 1.0,
            width: 4,
            height: 4,
            projection: raylink::scene::Projection::Pinhole,
        },
        materials: vec![Material::classic(
            "",
            Classic {
                diffuse: Texture::Constant(Rgb::splat(0.5)),
                ..Classic::default()
            },
        )],
        shapes: vec![Shape {
            media: None,
            geometry: Geometry::Sphere(Sphere {
                center: Vec3::ZERO,
                radius: 1.0,
            }),
            material: 0,
            alpha: None,
            motion: None,
        }],
        prototypes: Vec::new(),
        instances: Vec::new(),
        lights: vec![],
        ambient: Rgb::ZERO,
        background: Rgb::ZERO,
        settings: Default::default(),
        setting_sources: Vec::new(),
        output: None,
        color_space: None,
        inputs: Vec::new(),
        environment: Some(std::sync::Arc::new(env.clone())),
        warnings: vec![],
    };
    // Quadrature over the hemisphere about +z (the normal the camera sees).
    let (nt, np) = (400, 800);
    let mut expected = Rgb::ZERO;
    for i in 0..nt {
        let cos = (i as f32 + 0.5) / nt as f32;
        let sin = (1.0 - cos * cos).sqrt();
        for j in 0..np {
            let phi = std::f32::consts::TAU * (j as f32 + 0.5) / np as f32;
            let w = Vec3::new(sin * phi.cos(), sin * phi.sin(), cos);
            expected += env.eval(w) * cos * (std::f32::consts::TAU / (nt * np) as f32);
        }
    }
    expected *= 0.5 / std::f32::consts::PI;
    let image = render(
        &scene,
        Kind::Path,
        &Setup {
            width: 4,
            height: 4,
            spp: 4096,
            max_depth: 1,
            seed: 3,
            threads: None,
            filter: Filter::Box { radius: 0.5 },
        },
    );
    let m = mean(&image, None);
    eprintln!("environment: {m} vs quadrature {expected}");
    for c in 0..3 {
        assert!((m[c] / expected[c] - 1.0).abs() < 0.01, "{m} vs {expected}");
    }
}

/// A diffuse sphere (albedo 0.5, radius 1, at the origin) seen head-on from direction `n`
/// through a 1° camera, lit by the environment map of `scene_dir/file` (a TOML scene
/// written there): the path tracer's image mean.
fn sphere_under_environment(
    scene_dir: &Path,
    file: &str,
    n: raylink::math::Vec3,
) -> (Scene, raylink::math::Rgb) {
    let p = n.normalize() * 5.0;
    let toml = format!(
        "[camera]\nposition = [{}, {}, {}]\nlook_at = [0, 0, 0]\nup = [0, 0, 1]\nfov = 1\nwidth = 4\nheight = 4\n\n\
         [world]\nenvironment = {{ file = \"{file}\" }}\n\n\
         [materials.grey]\ndiffuse = 0.5\n\n\
         [[shapes]]\ntype = \"sphere\"\nmaterial = \"grey\"\nradius = 1\n",
        p.x, p.y, p.z
    );
    let path = scene_dir.join(format!("{file}.toml"));
    std::fs::write(&path, toml).unwrap();
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let image = render(
        &scene,
        Kind::Path,
        &Setup {
            width: 4,
            height: 4,
            spp: 4096,
            max_depth: 1,
            seed: 3,
            threads: None,
            filter: Filter::Box { radius: 0.5 },
        },
    );
    (scene, mean(&image, None))
}

/// Lat-long texel (column, row) of a W×H map: its light-space direction at the centre
/// (pbrt-v4's convention: θ from +z down the rows, φ from +x towards +y across).
fn lat_long_dir(w: u32, h: u32, x: f64, y: f64) -> glam::DVec3 {
    let (theta, phi) = (
        std::f64::consts::PI * y / h as f64,
        std::f64::consts::TAU * x / w as f64,
    );
    glam::DVec3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    )
}

/// ρ/π ∫ L(ω) max(0, n·ω) dω for a lat-long map read as constant over each texel, by
/// 8×8 points per texel in (θ, φ) weighted by sin θ: independent of the conversion to the
/// equal-area mapping and of the renderer.
fn lat_long_quadrature(map: &Image, n: glam::DVec3, albedo: f64) -> [f64; 3] {
    let (w, h) = (map.width, map.height);
    let s = 8;
    let mut sum = [0.0f64; 3];
    let cell = (std::f64::consts::TAU / (w * s) as f64) * (std::f64::consts::PI / (h * s) as f64);
    for y in 0..h * s {
        for x in 0..w * s {
            let d = lat_long_dir(
                w,
                h,
                x as f64 / s as f64 + 0.5 / s as f64,
                y as f64 / s as f64 + 0.5 / s as f64,
            );
            let cos = n.dot(d);
            if cos <= 0.0 {
                continue;
            }
            let sin_theta = (1.0 - d.z * d.z).max(0.0).sqrt();
            let l = map.get(x / s, y / s);
            for c in 0..3 {
                sum[c] += l[c] as f64 * cos * sin_theta * cell;
            }
        }
    }
    sum.map(|v| v * albedo / std::f64::consts::PI)
}

/// A lat-long sky (W×H = 128×64): a smooth gradient in θ and φ plus a 3×3-texel sun.
fn lat_long_sky(sun: (u32, u32), sun_radiance: f32) -> Image {
    let (w, h) = (128u32, 64u32);
    let mut map = Image::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let d = lat_long_dir(w, h, x as f64 + 0.5, y as f64 + 0.5);
            let v = (0.3 + 1.2 * (0.5 + 0.5 * d.z) + 0.6 * (0.5 + 0.5 * (d.y - 0.5 * d.x))) as f32;
            let near_sun = x.abs_diff(sun.0) <= 1 && y.abs_diff(sun.1) <= 1;
            let s = if near_sun { sun_radiance } else { 0.0 };
            map.set(
                x,
                y,
                raylink::math::Rgb::new(0.5 * v + s, 0.8 * v + s, v + 0.8 * s),
            );
        }
    }
    map
}

/// A lat-long environment map and the equal-area map it converts to light a diffuse sphere
/// alike, and as the lat-long image itself says: the path tracer's means under (a) the
/// lat-long EXR and (b) its conversion written out and read back as an equal-area EXR agree
/// within 1%, and both within 1% of the quadrature of the lat-long texels over the
/// hemisphere the camera sees. The view and the sun are away from the poles and off the
/// x–z plane, so a mirrored or turned convention moves the sun out of (or across) that
/// hemisphere and fails.
#[test]
fn lat_long_environment_lights_like_its_conversion_and_its_quadrature() {
    let dir = tempfile::tempdir().unwrap();
    // The sun at texel (28, 18): φ ≈ 80°, θ ≈ 52°; the camera looks from φ = 40°, θ = 70°.
    let sky = lat_long_sky((28, 18), 1000.0);
    raylink::write_image(&dir.path().join("sky.exr"), &sky, &[], &Default::default()).unwrap();
    let view = lat_long_dir(128, 64, 128.0 * 40.0 / 360.0, 64.0 * 70.0 / 180.0);
    let (scene, a) = sphere_under_environment(dir.path(), "sky.exr", view.as_vec3());
    let env = scene.environment.as_ref().unwrap();
    assert_eq!((env.image.width, env.image.height), (128, 128));
    raylink::write_image(
        &dir.path().join("octa.exr"),
        &env.image,
        &[],
        &Default::default(),
    )
    .unwrap();
    let (scene_b, b) = sphere_under_environment(dir.path(), "octa.exr", view.as_vec3());
    assert_eq!(scene_b.environment.as_ref().unwrap().image, env.image);
    let expected = lat_long_quadrature(&sky, view, 0.5);
    // The same with the map mirrored (φ → −φ): what a wrong convention would give.
    let mirrored = lat_long_quadrature(&sky, glam::DVec3::new(view.x, -view.y, view.z), 0.5);
    eprintln!("lat-long {a}, equal-area {b}, quadrature {expected:?} (mirrored {mirrored:?})");
    for c in 0..3 {
        assert!(
            (a[c] / b[c] - 1.0).abs() < 0.01,
            "lat-long {a} vs equal-area {b}"
        );
        let e = expected[c] as f32;
        assert!(
            (a[c] / e - 1.0).abs() < 0.01,
            "lat-long {a} vs quadrature {expected:?}"
        );
        assert!(
            (mirrored[c] as f32 / e - 1.0).abs() > 0.1,
            "the test cannot tell a mirror"
        );
    }
}

/// A constant lat-long map is exactly the constant equal-area map of the same side (W×W),
/// so the two render the same image bit for bit; and as a white furnace (radiance 1, a
/// white sphere) the image stays white.
#[test]
fn constant_lat_long_map_equals_constant_equal_area_map_and_furnace_stays_white() {
    use raylink::math::Rgb;
    let dir = tempfile::tempdir().unwrap();
    let mut latlong = Image::new(64, 32);
    latlong.pixels.fill(Rgb::ONE);
    let mut square = Image::new(64, 64);
    square.pixels.fill(Rgb::ONE);
    for (name, image) in [("latlong.exr", &latlong), ("square.exr", &square)] {
        raylink::write_image(&dir.path().join(name), image, &[], &Default::default()).unwrap();
    }
    let scene = |file: &str| {
        let toml = format!(
            "[camera]\nposition = [0.3, -4, 1]\nlook_at = [0, 0, 0]\nup = [0, 0, 1]\nfov = 40\nwidth = 16\nheight = 12\n\n\
             [world]\nenvironment = {{ file = \"{file}\" }}\n\n\
             [materials.white]\ndiffuse = 1\n\n\
             [[shapes]]\ntype = \"sphere\"\nmaterial = \"white\"\nradius = 1\n"
        );
        let path = dir.path().join(format!("{file}.toml"));
        std::fs::write(&path, toml).unwrap();
        Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
    };
    let (a, b) = (scene("latlong.exr"), scene("square.exr"));
    assert_eq!(a.environment.as_ref().unwrap().image, square);
    let setup = Setup {
        width: 16,
        height: 12,
        spp: 256,
        max_depth: 5,
        seed: 5,
        threads: None,
        filter: Filter::Box { radius: 0.5 },
    };
    let (ia, ib) = (
        render(&a, Kind::Path, &setup),
        render(&b, Kind::Path, &setup),
    );
    assert!(
        ia.pixels == ib.pixels,
        "constant lat-long and equal-area maps render differently"
    );
    let m = mean(&ia, None);
    let worst = ia
        .pixels
        .iter()
        .map(|p| (p.x - 1.0).abs())
        .fold(0.0f32, f32::max);
    eprintln!("furnace under a lat-long map: mean {m}, worst pixel off by {worst}");
    for c in 0..3 {
        assert!((m[c] - 1.0).abs() < 0.005, "furnace mean {m}");
    }
    assert!(worst < 0.05, "a furnace pixel is off by {worst}");
}

/// Importance sampling of a converted lat-long map: a sky with a small, very bright sun
/// (one texel of 128×64 at 20000, 95% of the light on the sphere), so that the sun is
/// found only through the sampling distribution built from the converted image. As the
/// equal-area test above (environment_map_lighting_matches_quadrature), the path tracer
/// must agree within 1% with the quadrature of the converted map (Environment::eval),
/// and that with the quadrature of the lat-long texels.
#[test]
fn lat_long_sun_is_importance_sampled_without_bias() {
    use raylink::math::{Rgb, Vec3};
    let dir = tempfile::tempdir().unwrap();
    let mut sky = lat_long_sky((0, 0), 0.0);
    sky.set(100, 20, Rgb::new(20000.0, 18000.0, 15000.0));
    raylink::write_image(&dir.path().join("sun.exr"), &sky, &[], &Default::default()).unwrap();
    let view = lat_long_dir(128, 64, 128.0 * 300.0 / 360.0, 64.0 * 80.0 / 180.0);
    let (scene, m) = sphere_under_environment(dir.path(), "sun.exr", view.as_vec3());
    let env = scene.environment.as_ref().unwrap();
    // Quadrature of the converted map over the hemisphere about `view`.
    let n = view.as_vec3().normalize();
    let (t, b) = {
        let a = if n.x.abs() > 0.9 { Vec3::Y } else { Vec3::X };
        let t = n.cross(a).normalize();
        (t, n.cross(t))
    };
    let (nt, np) = (800, 1600);
    let mut converted = [0.0f64; 3];
    for i in 0..nt {
        let cos = (i as f32 + 0.5) / nt as f32;
        let sin = (1.0 - cos * cos).sqrt();
        for j in 0..np {
            let phi = std::f32::consts::TAU * (j as f32 + 0.5) / np as f32;
            let w = t * (sin * phi.cos()) + b * (sin * phi.sin()) + n * cos;
            let l = env.eval(w);
            for c in 0..3 {
                converted[c] += (l[c] * cos) as f64 * (std::f64::consts::TAU / (nt * np) as f64);
            }
        }
    }
    let converted = converted.map(|v| v * 0.5 / std::f64::consts::PI);
    let latlong = lat_long_quadrature(&sky, view, 0.5);
    let sky_only = lat_long_quadrature(&lat_long_sky((0, 0), 0.0), view, 0.5);
    eprintln!(
        "lat-long sun: path {m}, quadrature of the conversion {converted:?}, of the lat-long \
         texels {latlong:?} (sky alone {sky_only:?})"
    );
    for c in 0..3 {
        assert!(
            (m[c] / converted[c] as f32 - 1.0).abs() < 0.01,
            "{m} vs {converted:?}"
        );
        assert!(
            (converted[c] / latlong[c] - 1.0).abs() < 0.01,
            "{converted:?} vs {latlong:?}"
        );
        assert!(sky_only[c] / latlong[c] < 0.2, "the sun must dominate");
    }
}

/// The same with the glass sphere made a thin sheet (`thin = true`: reflection R, straight
/// transmission 1 − R); light tracing cannot see through its delta lobes, as for glass.
#[test]
fn gathering_shooting_and_bidirectional_agree_through_a_thin_sheet() {
    let scene = cornell_spheres_with_glass(|glass| classic_mut(glass).thin = true);
    check_adjoint(&scene, &[1, 2]);
}

/// A scene from TOML text.
fn scene_from(text: &str) -> Scene {
    raylink::scene::toml::from_str(text, Path::new("test.toml")).unwrap_or_else(|e| panic!("{e}"))
}

const THIN_GLASS: &str =
    "[materials.pane]\ndiffuse = 0\nspecular = 1\ntransmission = 1\nfresnel = true\nthin = true\n";

/// Furnace through thin sheets: a thin-glass sphere and a pane in front of it under a
/// uniform background of radiance 1 reflect R and pass 1 − R at every interaction, so every
/// pixel of the path tracer stays 1 whatever the bounces between them (R + T = 1).
#[test]
fn thin_sheets_in_a_white_furnace_stay_white() {
    let scene = scene_from(&format!(
        "[camera]\nposition = [0.2, -4, 0.3]\nlook_at = [0, 0, 0]\nup = [0, 0, 1]\nfov = 40\nwidth = 16\nheight = 12\n\
         [world]\nbackground = 1\n{THIN_GLASS}\
         [[shapes]]\ntype = \"sphere\"\nmaterial = \"pane\"\nradius = 1\n\
         [[shapes]]\ntype = \"quad\"\nmaterial = \"pane\"\n\
         vertices = [[-3, -2, -3], [3, -1.5, -3], [3, -1.5, 3], [-3, -2, 3]]\n"
    ));
    let setup = Setup {
        width: 16,
        height: 12,
        spp: 64,
        max_depth: 12,
        seed: 3,
        threads: None,
        filter: Filter::Box { radius: 0.5 },
    };
    // (BDPT and light tracing take no background light.)
    let image = render(&scene, Kind::Path, &setup);
    let worst = image
        .pixels
        .iter()
        .map(|p| (*p - raylink::math::Rgb::ONE).abs().max_element())
        .fold(0.0f32, f32::max);
    eprintln!("thin furnace: worst pixel off by {worst}");
    // Every sample weighs exactly 1 (the lobes are chosen with probabilities R and T):
    // only truncation (R^11 < 1e-11) and rounding remain. (Were the pane one refracting
    // glass face, the light it lets in would be scaled by 1/1.5².)
    assert!(worst < 1e-4, "a pixel is off by {worst}");
}

/// A camera looks through a pane tilted by 45° at a wall whose left half glows (radiance
/// 1 left of x = 0.05, which cuts a pixel column; the reflection sees only black). A thin sheet passes the light straight on: each
/// pixel is T(θ) (θ its ray's angle to the pane) times the same pixel without the pane,
/// within 5 standard errors; a glass slab 0.5 thick would shift the edge by about 1.5
/// pixels.
#[test]
fn a_thin_pane_does_not_displace_what_is_behind_it() {
    let (w, h, spp) = (32u32, 8u32, 1024u32);
    let pane = "[[shapes]]\ntype = \"quad\"\nmaterial = \"pane\"\n\
                vertices = [[-20, -20, 15], [20, -20, -25], [20, 20, -25], [-20, 20, 15]]\n";
    let text = |with_pane: bool| {
        format!(
            "[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, -1]\nup = [0, 1, 0]\nfov = 20\nwidth = {w}\nheight = {h}\n\
             [materials.glow]\ndiffuse = 0\nemission = 1\n{THIN_GLASS}\
             [[shapes]]\ntype = \"quad\"\nmaterial = \"glow\"\n\
             vertices = [[-20, -20, -10], [0.05, -20, -10], [0.05, 20, -10], [-20, 20, -10]]\n{}",
            if with_pane { pane } else { "" }
        )
    };
    let setup = Setup {
        width: w,
        height: h,
        spp,
        max_depth: 4,
        seed: 9,
        threads: None,
        filter: Filter::Box { radius: 0.5 },
    };
    let bare = render(&scene_from(&text(false)), Kind::Path, &setup);
    let scene = scene_from(&text(true));
    let through = render(&scene, Kind::Path, &setup);
    let basis = scene.camera.basis();
    let normal = raylink::math::Vec3::new(1.0, 0.0, 1.0).normalize();
    let mut edge = 0;
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let (a, b) = (bare.pixels[i].x as f64, through.pixels[i].x as f64);
            let cos = basis
                .ray(x as f32 + 0.5, y as f32 + 0.5)
                .dir
                .normalize()
                .dot(normal)
                .abs();
            let f = {
                // The sheet's transmittance 1 − 2F/(1 + F) (F of one face, η = 1.5).
                let c = cos as f64;
                let ct = (1.0 - (1.0 - c * c) / 2.25).sqrt();
                let rs = (c - 1.5 * ct) / (c + 1.5 * ct);
                let rp = (1.5 * c - ct) / (1.5 * c + ct);
                0.5 * (rs * rs + rp * rp)
            };
            let t = 1.0 - 2.0 * f / (1.0 + f);
            // Bernoulli variances: coverage a of the bare pixel, T·a through the pane.
            let n = spp as f64;
            let se = ((a * (1.0 - a) * t * t + t * a * (1.0 - t * a)) / n).sqrt();
            assert!(
                (b - t * a).abs() <= 5.0 * se + 1e-4,
                "pixel ({x}, {y}): {b} through the pane, {a} × T {t} without"
            );
            edge += usize::from(a > 0.05 && a < 0.95);
        }
    }
    // The glowing half's edge runs through the image.
    assert!(edge >= h as usize, "no edge pixels");
}
