//! Spot and goniometric lights (pbrt-v4's definitions) and two-sided area lights: each
//! point light's irradiance on a plane against its formula, path, light and bidirectional
//! tracing agreeing on a room it lights, and a two-sided emitter lighting both of its sides
//! alike.

#[path = "common/render.rs"]
mod render_common;

use raylink::image::filter::Filter;
use raylink::image::Image;
use raylink::job::{AntiAliasing, MonteCarloSettings};
use raylink::scene::{Light, Scene};
use raylink::{Backend, Settings, Technique, TechniqueKind};
use render_common::{image, View};
use std::path::Path;

mod agreement;

fn manifest(p: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(p)
}

fn parse(text: &str) -> Scene {
    raylink::scene::toml::from_str(text, Path::new("lights.toml")).unwrap_or_else(|e| panic!("{e}"))
}

fn render_job(scene: &Scene, technique: Technique, seed: u64) -> Image {
    image(
        scene,
        technique,
        View::of(scene, seed, None, Backend::Embree),
    )
}

fn mc(technique: fn(MonteCarloSettings) -> Technique, spp: u32, max_depth: u32) -> Technique {
    technique(MonteCarloSettings {
        max_depth,
        spp,
        time_limit: None,
        filter: Filter::Box { radius: 0.5 },
        reconstruction: raylink::image::filter::Reconstruction::Splat,
        adaptive: None,
        max_component_value: None,
        guiding: false,
        spectral: false,
    })
}

/// pbrt-v4's smooth step.
fn smooth_step(a: f64, b: f64, x: f64) -> f64 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// A spot light (I = 2, a 30° cone whose last 10° fall off) one unit above a white (albedo 0.8) diffuse floor, pointing straight down, seen by an
/// orthographic camera from above: each pixel is ρ/π·E averaged over the pixel, with
/// pbrt's E = I·SmoothStep(cos 30°, cos 20°, cos θ)·cos θ/d². Checked at pixels inside the
/// inner cone, in the falloff band and outside the cone, within 0.5% (0 outside), for the
/// path tracer, Whitted's ray tracer and the irradiance cache (whose direct light samples the
/// spot).
#[test]
fn spot_irradiance_matches_pbrts_formula() {
    let (size, width) = (2.0f64, 100u32);
    let scene = parse(&format!(
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nwidth = {width}\nheight = {width}\n\
         projection = \"orthographic\"\nsize = {size}\n\
         [materials.floor]\ndiffuse = 0.8\nphong_exponent = 0\n\
         [[shapes]]\ntype = \"quad\"\nvertices = [[-5, -5, 0], [5, -5, 0], [5, 5, 0], [-5, 5, 0]]\nmaterial = \"floor\"\n\
         [[lights]]\ntype = \"spot\"\nposition = [0, 0, 1]\ndirection = [0, 0, -1]\nintensity = 2\ncone_angle = 30\ncone_delta = 10\n"
    ));
    let (cos_end, cos_start) = (30f64.to_radians().cos(), 20f64.to_radians().cos());
    let radiance_at = |x: f64, y: f64| {
        let d2 = x * x + y * y + 1.0;
        let cos = 1.0 / d2.sqrt();
        0.8 / std::f64::consts::PI * 2.0 * smooth_step(cos_end, cos_start, cos) * cos / d2
    };
    // World (x, y) of raster (rx, ry): the film spans `size` across, x right, y up.
    let pixel = size / width as f64;
    let expected = |px: u32, py: u32| {
        let n = 16;
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let rx = px as f64 + (i as f64 + 0.5) / n as f64;
                let ry = py as f64 + (j as f64 + 0.5) / n as f64;
                let x = (rx - width as f64 / 2.0) * pixel;
                let y = -(ry - width as f64 / 2.0) * pixel;
                sum += radiance_at(x, y);
            }
        }
        sum / (n * n) as f64
    };
    let whitted = Technique::create(&Settings {
        integrator: Some(TechniqueKind::Whitted),
        aa: Some(AntiAliasing::Uniform),
        spp: Some(64),
        max_depth: Some(1),
        ..Settings::default()
    })
    .unwrap();
    let cache = Technique::create(&Settings {
        integrator: Some(TechniqueKind::IrradianceCache),
        spp: Some(64),
        max_depth: Some(1),
        filter: Some(Filter::Box { radius: 0.5 }),
        ..Settings::default()
    })
    .unwrap();
    for (name, technique) in [
        ("path", mc(Technique::Path, 64, 1)),
        ("whitted", whitted),
        ("cache", cache),
    ] {
        let image = render_job(&scene, technique, 1);
        // Along the +x axis from the centre: tan θ of the pixel centre 0.01 .. 0.99.
        let row = width / 2;
        let mut checked = [0; 3];
        for px in (width / 2..width).step_by(3) {
            let x = (px as f64 + 0.5 - width as f64 / 2.0) * pixel;
            let theta = x.atan().to_degrees();
            let band = if theta < 19.5 {
                0
            } else if theta < 30.5 {
                1
            } else {
                2
            };
            if (19.5..20.5).contains(&theta) || (29.5..30.5).contains(&theta) {
                continue; // pixels straddling an edge of the band
            }
            let want = expected(px, row);
            let got = image.get(px, row);
            let got = (got.x + got.y + got.z) as f64 / 3.0;
            if band == 2 {
                assert_eq!(
                    got, 0.0,
                    "{name}: light outside the cone at θ = {theta:.1}°"
                );
            } else {
                assert!(
                    (got / want - 1.0).abs() < 0.005,
                    "{name}: θ = {theta:.1}°: {got} vs pbrt's {want}"
                );
            }
            checked[band] += 1;
        }
        eprintln!("{name}: pixels checked inside, in the falloff band, outside: {checked:?}");
        assert!(checked.iter().all(|&c| c >= 3), "{checked:?}");
    }
}

/// An estimator to compare: its name, its technique and its samples per pixel.
type Run = (&'static str, fn(MonteCarloSettings) -> Technique, u32);

fn agree<const N: usize>(scene: &Scene, runs: [Run; N]) {
    let results = agreement::over_seeds(
        runs.map(|(name, technique, spp)| (name, (technique, spp))),
        |&(technique, spp), seed| render_job(scene, mc(technique, spp, 5), seed),
    );
    agreement::assert_agree(&results, |_, _, _| true);
}

/// The Cornell box lit only by a spot light under the ceiling aimed at the floor (its area
/// light switched off): path tracing, light tracing (emission sampled within the cone) and
/// BDPT agree, 8 seeds each.
#[test]
fn path_light_and_bidirectional_agree_under_a_spot() {
    agree_in_the_box_lit_by(Light::Spot(raylink::scene::lights::SpotLight::new(
        raylink::math::Vec3::new(0.0, 1.9, 0.0),
        raylink::math::Vec3::new(0.3, -1.0, 0.2),
        raylink::math::Vec3::splat(3.0),
        35.0,
        15.0,
    )));
}

/// Path tracing, light tracing and BDPT agree (8 seeds each) on the Cornell box at 48×48
/// lit by `light` alone (its area light switched off).
fn agree_in_the_box_lit_by(light: Light) {
    let mut scene = Scene::load(&manifest("scenes/cornell-box.toml")).unwrap();
    scene.camera.width = 48;
    scene.camera.height = 48;
    for m in &mut scene.materials {
        m.emission = raylink::math::Vec3::ZERO;
    }
    scene.lights.push(light);
    agree(
        &scene,
        [
            ("path", Technique::Path, 16),
            ("light", Technique::Light, 16),
            ("bdpt", Technique::Bdpt, 8),
        ],
    );
}

/// A two-sided emitting square (radiance 1) halfway between two grey planes 1 unit above and
/// below, seen edge-on from the side, direct light only: the upper and lower halves of the
/// image match (within 1%) and are lit, for path tracing, light tracing and BDPT; the same
/// square one-sided (facing up) leaves the lower half black. The three estimators agree on
/// the two-sided scene.
#[test]
fn two_sided_emitter_lights_both_sides_alike() {
    let scene = |two_sided: bool| {
        parse(&format!(
            "[camera]\nposition = [0, 0, 4]\nlook_at = [0, 0, 0]\nfov = 60\nwidth = 32\nheight = 32\n\
             [materials.grey]\ndiffuse = 0.5\n\
             [materials.lamp]\ndiffuse = 0\nemission = 1\ntwo_sided_emission = {two_sided}\n\
             [[shapes]]\ntype = \"quad\"\nvertices = [[-3, 1, -3], [3, 1, -3], [3, 1, 3], [-3, 1, 3]]\nmaterial = \"grey\"\n\
             [[shapes]]\ntype = \"quad\"\nvertices = [[-3, -1, -3], [-3, -1, 3], [3, -1, 3], [3, -1, -3]]\nmaterial = \"grey\"\n\
             [[shapes]]\ntype = \"quad\"\nvertices = [[-0.5, 0, -0.5], [-0.5, 0, 0.5], [0.5, 0, 0.5], [0.5, 0, -0.5]]\nmaterial = \"lamp\"\n"
        ))
    };
    let two = scene(true);
    let one = scene(false);
    assert!(two.materials.iter().any(|m| m.two_sided_emission));
    let halves = |image: &Image| {
        let (mut top, mut bottom) = (0.0f64, 0.0f64);
        for y in 0..image.height {
            for x in 0..image.width {
                let p = image.get(x, y);
                let v = (p.x + p.y + p.z) as f64;
                if y < image.height / 2 {
                    top += v;
                } else {
                    bottom += v;
                }
            }
        }
        (top, bottom)
    };
    for (name, technique, spp) in [
        ("path", Technique::Path as fn(_) -> _, 256),
        ("light", Technique::Light as fn(_) -> _, 256),
        ("bdpt", Technique::Bdpt as fn(_) -> _, 128),
    ] {
        let (top, bottom) = halves(&render_job(&two, mc(technique, spp, 1), 3));
        eprintln!("{name}: two-sided: top {top:.3} bottom {bottom:.3}");
        assert!(
            top > 1.0 && (top / bottom - 1.0).abs() < 0.01,
            "{name}: {top} vs {bottom}"
        );
        let (top1, bottom1) = halves(&render_job(&one, mc(technique, spp, 1), 3));
        eprintln!("{name}: one-sided: top {top1:.3} bottom {bottom1:.3}");
        // The upward-facing lamp lights the upper plane (seen in the image's top half).
        assert!(bottom1 < 1e-3 * top1 && (top1 / top - 1.0).abs() < 0.02);
    }
    agree(
        &two,
        [
            ("path", Technique::Path, 32),
            ("light", Technique::Light, 32),
            ("bdpt", Technique::Bdpt, 16),
        ],
    );
}

/// A goniometric light's image: texel (x, y) of an n×n square holds the value at the
/// direction of its centre in the equal-area mapping; here 1 + 0.9·d.x of the map's frame,
/// with a bright texel at the pole.
fn goniometric_image(n: u32) -> Image {
    let mut image = Image::new(n, n);
    for y in 0..n {
        for x in 0..n {
            let uv =
                raylink::math::Vec2::new((x as f32 + 0.5) / n as f32, (y as f32 + 0.5) / n as f32);
            let d = raylink::scene::environment::equal_area_square_to_sphere(uv);
            image.set(x, y, raylink::math::Vec3::splat(1.0 + 0.9 * d.x));
        }
    }
    image
}

/// pbrt-v4's conventions for a goniometric light: the light's +y is the image's centre (the
/// mapping's pole), its +z the image's edge, and every texel is seen along its centre's
/// direction; the frame follows the light's transform.
#[test]
fn goniometric_map_follows_pbrts_frame() {
    use raylink::math::{Mat3, Vec3};
    use raylink::scene::lights::GoniometricMap;
    let n = 32;
    let mut image = goniometric_image(n);
    image.set(n / 2, n / 2, Vec3::splat(7.0));
    let turn = Mat3::from_rotation_x(std::f32::consts::FRAC_PI_2); // +y to +z
    for (frame, pole) in [(Mat3::IDENTITY, Vec3::Y), (turn, Vec3::Z)] {
        let map = GoniometricMap::new("g.exr".into(), &image, frame).unwrap();
        // The pole lands on the corner of the four central texels: one of them is bright.
        let near_pole = (frame * Vec3::new(0.01, 1.0, 0.01)).normalize();
        assert_eq!(map.value(near_pole), 7.0, "{pole}");
        for (x, y) in [(3, 5), (20, 9), (30, 30), (16, 2)] {
            let uv =
                raylink::math::Vec2::new((x as f32 + 0.5) / n as f32, (y as f32 + 0.5) / n as f32);
            let d = raylink::scene::environment::equal_area_square_to_sphere(uv);
            // Map (x, y, z) is the light's (x, z, y).
            let world = frame * Vec3::new(d.x, d.z, d.y);
            assert_eq!(map.value(world), image.get(x, y).x, "texel ({x}, {y})");
        }
    }
    assert!(GoniometricMap::new("g.exr".into(), &Image::new(4, 2), Mat3::IDENTITY).is_err());
}

/// A goniometric light one unit above a white floor, its pole pointing down, seen by an
/// orthographic camera from above: each pixel is ρ/π·I·value(d)·cos θ/r², within 0.5% for
/// Whitted's ray tracer and the path tracer; and path, light and bidirectional tracing agree
/// on the Cornell box lit by it alone.
#[test]
fn goniometric_light_lights_as_its_image_says() {
    use raylink::math::{Mat3, Vec3};
    use raylink::scene::lights::GoniometricMap;
    let (size, width) = (2.0f64, 60u32);
    let mut scene = parse(&format!(
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nwidth = {width}\nheight = {width}\n\
         projection = \"orthographic\"\nsize = {size}\n\
         [materials.floor]\ndiffuse = 0.8\nphong_exponent = 0\n\
         [[shapes]]\ntype = \"quad\"\nvertices = [[-5, -5, 0], [5, -5, 0], [5, 5, 0], [-5, 5, 0]]\nmaterial = \"floor\"\n"
    ));
    // The light's +y (the pole) down the world's −z.
    let frame = Mat3::from_rotation_x(std::f32::consts::FRAC_PI_2).inverse();
    let map = GoniometricMap::new("g.exr".into(), &goniometric_image(64), frame).unwrap();
    let map = std::sync::Arc::new(map);
    scene.lights.push(Light::Goniometric(
        raylink::scene::lights::GoniometricLight {
            position: Vec3::new(0.0, 0.0, 1.0),
            intensity: Vec3::splat(2.0),
            map: map.clone(),
        },
    ));
    let pixel = size / width as f64;
    let expected = |px: u32, py: u32| {
        let n = 8;
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let x = (px as f64 + (i as f64 + 0.5) / n as f64 - width as f64 / 2.0) * pixel;
                let y = -(py as f64 + (j as f64 + 0.5) / n as f64 - width as f64 / 2.0) * pixel;
                let d2 = x * x + y * y + 1.0;
                let dir = Vec3::new(x as f32, y as f32, -1.0).normalize();
                let cos = 1.0 / d2.sqrt();
                sum += 0.8 / std::f64::consts::PI * 2.0 * f64::from(map.value(dir)) * cos / d2;
            }
        }
        sum / (n * n) as f64
    };
    let whitted = Technique::create(&Settings {
        integrator: Some(TechniqueKind::Whitted),
        aa: Some(AntiAliasing::Uniform),
        spp: Some(64),
        max_depth: Some(1),
        ..Settings::default()
    })
    .unwrap();
    let mut spread = (f64::MAX, 0.0f64);
    for (name, technique) in [("path", mc(Technique::Path, 64, 1)), ("whitted", whitted)] {
        let image = render_job(&scene, technique, 1);
        for py in (2..width).step_by(7) {
            for px in (1..width).step_by(5) {
                let (want, got) = (expected(px, py), image.get(px, py));
                let got = f64::from(got.x + got.y + got.z) / 3.0;
                // Pixels that straddle a texel edge average two values; the pixel's
                // supersampled expectation covers them.
                assert!(
                    (got / want - 1.0).abs() < 0.005,
                    "{name}: pixel ({px}, {py}): {got} vs {want}"
                );
                spread = (spread.0.min(want), spread.1.max(want));
            }
        }
    }
    // The image varies the light: the test could tell a point light from it.
    assert!(spread.1 > 3.0 * spread.0, "{spread:?}");

    agree_in_the_box_lit_by(Light::Goniometric(
        raylink::scene::lights::GoniometricLight {
            position: Vec3::new(0.0, 1.9, 0.0),
            intensity: Vec3::splat(1.5),
            map,
        },
    ));
}

/// pbrt-v4's `goniometric` light: at the origin of its transform, `I` × `scale`, or with
/// `power` the intensity that emits it (4π × the image's mean × intensity = power); it
/// converts to TOML and back unchanged. A non-square image is an error naming the file.
#[test]
fn pbrt_goniometric_lights_read_and_convert() {
    let dir = tempfile::tempdir().unwrap();
    let image = goniometric_image(16);
    raylink::image::output::write_image(
        &dir.path().join("g.exr"),
        &image,
        &[],
        &Default::default(),
    )
    .unwrap();
    let main = dir.path().join("main.pbrt");
    std::fs::write(
        &main,
        "Scale -1 1 1\nLookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\"\nWorldBegin\n\
         AttributeBegin Translate 1 2 3 Rotate 90 1 0 0\n\
         LightSource \"goniometric\" \"string filename\" \"g.exr\" \"rgb I\" [1 2 3] \"float scale\" 2\n\
         LightSource \"goniometric\" \"string filename\" \"g.exr\" \"float power\" 100\n\
         AttributeEnd\n\
         Shape \"sphere\"\n",
    )
    .unwrap();
    let s = Scene::load(&main).unwrap_or_else(|e| panic!("{e}"));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let Light::Goniometric(raylink::scene::lights::GoniometricLight {
        position,
        intensity,
        map,
    }) = &s.lights[0]
    else {
        panic!("{:?}", s.lights[0]);
    };
    assert!((*position - raylink::math::Vec3::new(1.0, 2.0, 3.0)).length() < 1e-5);
    assert_eq!(*intensity, raylink::math::Vec3::new(2.0, 4.0, 6.0));
    // The light's frame is the transform's: its +y (the image's pole), turned 90° about x,
    // is the world's +z.
    let pole = map.transform * raylink::math::Vec3::Y;
    assert!((pole - raylink::math::Vec3::Z).length() < 1e-5, "{pole}");
    let Light::Goniometric(raylink::scene::lights::GoniometricLight { intensity, map, .. }) =
        &s.lights[1]
    else {
        panic!();
    };
    let power = 4.0 * std::f32::consts::PI * map.mean() * intensity.x;
    assert!((power - 100.0).abs() < 1e-3, "{power}");

    let out = dir.path().join("out.toml");
    raylink::scene::convert::write_toml(&s, &out).unwrap();
    let back = Scene::load(&out).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(back.lights, s.lights);

    let mut wide = Image::new(4, 2);
    wide.set(0, 0, raylink::math::Vec3::ONE);
    raylink::image::output::write_image(&dir.path().join("w.exr"), &wide, &[], &Default::default())
        .unwrap();
    std::fs::write(
        &main,
        "Scale -1 1 1\nLookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\"\nWorldBegin\n\
         LightSource \"goniometric\" \"string filename\" \"w.exr\"\nShape \"sphere\"\n",
    )
    .unwrap();
    let e = Scene::load(&main).unwrap_err().to_string();
    assert!(
        e.contains("w.exr") && e.contains("must be square") && e.contains("line 5"),
        "{e}"
    );
}

/// A 4×2 projection slide: every texel a different grey, the top-left one 5.
fn slide() -> Image {
    let mut image = Image::new(4, 2);
    for y in 0..2 {
        for x in 0..4 {
            image.set(
                x,
                y,
                raylink::math::Vec3::splat(0.5 + x as f32 + 0.3 * y as f32),
            );
        }
    }
    image.set(0, 0, raylink::math::Vec3::splat(5.0));
    image
}

/// pbrt-v4's conventions for a projection light: it looks down its +z, the image's top row
/// towards its +y and its left column towards −x, the screen spanning `fov` across the
/// shorter side (tan(fov/2) from the axis at the top and bottom edges, aspect × that at
/// the sides), black outside; its flux, ∫ I dω by uniform sampling of the sphere, is
/// `flux()` within 1%, and `with_power` makes it scale × the power asked.
#[test]
fn projection_light_follows_pbrts_frame() {
    use raylink::math::{Mat3, Vec3};
    use raylink::scene::lights::{LightModel, PointSource, ProjectionLight};
    let light = ProjectionLight::new(
        Vec3::ZERO,
        Mat3::IDENTITY,
        "p.exr".into(),
        &slide(),
        2.0,
        60.0,
    )
    .unwrap();
    let t = (30f32).to_radians().tan();
    // Texel (x, y)'s centre, in units of t at z = 1: x from −2 to 2, y from +1 (top) to −1.
    let towards = |x: f32, y: f32| Vec3::new(x + 0.5 - 2.0, 1.0 - (y + 0.5), 1.0 / t);
    for y in 0..2 {
        for x in 0..4 {
            let want = slide().get(x, y).x * 2.0;
            let got = light.intensity_towards(towards(x as f32, y as f32).normalize());
            assert_eq!(got, Vec3::splat(want), "texel ({x}, {y})");
        }
    }
    // Just inside and just outside the edges.
    for (w, lit) in [
        (Vec3::new(1.99 * t, 0.0, 1.0), true),
        (Vec3::new(2.01 * t, 0.0, 1.0), false),
        (Vec3::new(0.0, 0.99 * t, 1.0), true),
        (Vec3::new(0.0, 1.01 * t, 1.0), false),
        (Vec3::new(0.0, 0.0, -1.0), false),
    ] {
        let i = light.intensity_towards(w.normalize());
        assert_eq!(i.x > 0.0, lit, "{w}: {i}");
    }
    // Flux by Monte Carlo over the sphere (stratified), against the light's own.
    let n = 1000u32;
    let mut sum = 0.0f64;
    for i in 0..n {
        for j in 0..n {
            let u =
                raylink::math::Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            let z = 1.0 - 2.0 * u.x;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = std::f32::consts::TAU * u.y;
            let w = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            let i = light.intensity_towards(w);
            sum += f64::from(0.2126 * i.x + 0.7152 * i.y + 0.0722 * i.z);
        }
    }
    let flux = sum * 4.0 * std::f64::consts::PI / f64::from(n * n);
    assert!(
        (flux / f64::from(light.flux()) - 1.0).abs() < 0.01,
        "{flux} vs {}",
        light.flux()
    );
    // pbrt-v4 multiplies `scale` and `power`: scale 2 and power 100 emit 200.
    let rescaled = light.clone().with_power(100.0);
    assert!(
        (rescaled.flux() - 200.0).abs() < 1e-3,
        "{}",
        rescaled.flux()
    );
}

/// A projection light one unit above a white floor, looking down, seen by an orthographic
/// camera from above: each pixel is ρ/π·scale·value·cos θ/r² (the image value of the texel
/// its direction meets), within 1% for Whitted's ray tracer and the path tracer; and path,
/// light and bidirectional tracing agree on the Cornell box lit by it alone.
#[test]
fn projection_light_lights_as_its_image_says() {
    use raylink::math::{Mat3, Vec3};
    use raylink::scene::lights::ProjectionLight;
    let (size, width) = (2.0f64, 60u32);
    let mut scene = parse(&format!(
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nwidth = {width}\nheight = {width}\n\
         projection = \"orthographic\"\nsize = {size}\n\
         [materials.floor]\ndiffuse = 0.8\nphong_exponent = 0\n\
         [[shapes]]\ntype = \"quad\"\nvertices = [[-5, -5, 0], [5, -5, 0], [5, 5, 0], [-5, 5, 0]]\nmaterial = \"floor\"\n"
    ));
    // The light's +z down the world's −z, its +y along the world's −y.
    let frame = Mat3::from_rotation_x(std::f32::consts::PI);
    let (scale, fov) = (2.0f32, 70.0f32);
    let light = ProjectionLight::new(
        Vec3::new(0.0, 0.0, 1.0),
        frame,
        "p.exr".into(),
        &slide(),
        scale,
        fov,
    )
    .unwrap();
    scene.lights.push(Light::Projection(light.clone()));
    let t = f64::from((0.5 * fov).to_radians().tan());
    // The texel a direction from the light meets, by pbrt-v4's definitions: light space is
    // the frame's with y flipped; the screen spans ±2t × ±t at z = 1, its top row at −y.
    let value = |d: Vec3| -> f64 {
        let l = frame.inverse() * d;
        let (x, y, z) = (f64::from(l.x), -f64::from(l.y), f64::from(l.z));
        let (sx, sy) = (x / (z * t), y / (z * t));
        if z <= 0.0 || sx.abs() > 2.0 || sy.abs() > 1.0 {
            return 0.0;
        }
        let col = (((sx / 2.0 + 1.0) / 2.0) * 4.0).floor().min(3.0) as u32;
        let row = (((sy + 1.0) / 2.0) * 2.0).floor().min(1.0) as u32;
        f64::from(slide().get(col, row).x)
    };
    let pixel = size / width as f64;
    let expected = |px: u32, py: u32| {
        let n = 8;
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let x = (px as f64 + (i as f64 + 0.5) / n as f64 - width as f64 / 2.0) * pixel;
                let y = -(py as f64 + (j as f64 + 0.5) / n as f64 - width as f64 / 2.0) * pixel;
                let d2 = x * x + y * y + 1.0;
                let dir = Vec3::new(x as f32, y as f32, -1.0);
                let cos = 1.0 / d2.sqrt();
                sum += 0.8 / std::f64::consts::PI * f64::from(scale) * value(dir) * cos / d2;
            }
        }
        sum / (n * n) as f64
    };
    let whitted = Technique::create(&Settings {
        integrator: Some(TechniqueKind::Whitted),
        aa: Some(AntiAliasing::Uniform),
        spp: Some(64),
        max_depth: Some(1),
        ..Settings::default()
    })
    .unwrap();
    let mut spread = (f64::MAX, 0.0f64);
    let mut checked = 0;
    for (name, technique) in [("path", mc(Technique::Path, 64, 1)), ("whitted", whitted)] {
        let image = render_job(&scene, technique, 1);
        for py in (1..width).step_by(3) {
            for px in (1..width).step_by(3) {
                let (want, got) = (expected(px, py), image.get(px, py));
                let got = f64::from(got.x + got.y + got.z) / 3.0;
                if want == 0.0 {
                    assert_eq!(got, 0.0, "{name}: pixel ({px}, {py}) is outside the screen");
                    continue;
                }
                assert!(
                    (got / want - 1.0).abs() < 0.01,
                    "{name}: pixel ({px}, {py}): {got} vs {want}"
                );
                spread = (spread.0.min(want), spread.1.max(want));
                checked += 1;
            }
        }
    }
    assert!(checked > 200, "{checked} lit pixels checked");
    // The image varies the light: the test could tell a point light from it.
    assert!(spread.1 > 3.0 * spread.0, "{spread:?}");

    // The light's +z down the world's −y.
    let down = Mat3::from_rotation_x(std::f32::consts::FRAC_PI_2);
    let in_box = ProjectionLight::new(
        Vec3::new(0.0, 1.9, 0.0),
        down,
        "p.exr".into(),
        &slide(),
        1.0,
        90.0,
    )
    .unwrap();
    agree_in_the_box_lit_by(Light::Projection(in_box));
}

/// pbrt-v4's `projection` light: at the origin of its transform, looking down its +z, its
/// image read and scaled (`scale`, or `power` for the flux); no warning. A missing image is
/// an error naming it.
#[test]
fn pbrt_projection_lights_read() {
    use raylink::scene::lights::PointSource;
    let dir = tempfile::tempdir().unwrap();
    raylink::image::output::write_image(
        &dir.path().join("p.exr"),
        &slide(),
        &[],
        &Default::default(),
    )
    .unwrap();
    let main = dir.path().join("main.pbrt");
    let scene = |lights: &str| {
        format!(
            "Scale -1 1 1\nLookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\"\nWorldBegin\n\
             AttributeBegin Translate 1 2 3\n{lights}\nAttributeEnd\nShape \"sphere\"\n"
        )
    };
    std::fs::write(
        &main,
        scene(
            "LightSource \"projection\" \"string filename\" \"p.exr\" \"float scale\" 2 \"float fov\" 40\n\
             LightSource \"projection\" \"string filename\" \"p.exr\" \"float power\" 50",
        ),
    )
    .unwrap();
    let s = Scene::load(&main).unwrap_or_else(|e| panic!("{e}"));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let Light::Projection(a) = &s.lights[0] else {
        panic!("{:?}", s.lights[0]);
    };
    assert!((a.position - raylink::math::Vec3::new(1.0, 2.0, 3.0)).length() < 1e-5);
    assert_eq!((a.scale, a.fov), (2.0, 40.0));
    let Light::Projection(b) = &s.lights[1] else {
        panic!("{:?}", s.lights[1]);
    };
    assert!((b.flux() - 50.0).abs() < 1e-3, "{}", b.flux());
    std::fs::write(
        &main,
        scene("LightSource \"projection\" \"string filename\" \"missing.exr\""),
    )
    .unwrap();
    let e = Scene::load(&main).unwrap_err().to_string();
    assert!(e.contains("main.pbrt") && e.contains("missing.exr"), "{e}");
}

/// A room lit only through a window in its left wall, by a sky (a constant background) and
/// a sun (a directional light), with a glossy ball inside: path tracing, light tracing and
/// BDPT (whose subpaths start at and end on lights at infinity) agree, 8 seeds each.
#[test]
fn path_light_and_bidirectional_agree_in_a_room_lit_by_sky_and_sun() {
    let quad = |v: [[f32; 3]; 4], m: &str| {
        format!("[[shapes]]\ntype = \"quad\"\nvertices = {v:?}\nmaterial = \"{m}\"\n")
    };
    let mut text = String::from(
        "[camera]\nposition = [0.3, 1.0, 0.95]\nlook_at = [-0.2, 0.8, -1]\nfov = 75\nwidth = 24\nheight = 24\n\
         [world]\nbackground = [0.4, 0.5, 0.7]\n\
         [[lights]]\ntype = \"directional\"\ndirection = [1, -0.6, -0.25]\nirradiance = [3, 2.8, 2.5]\n\
         [materials.wall]\ndiffuse = 0.7\n\
         [materials.floor]\ndiffuse = [0.6, 0.45, 0.3]\n\
         [materials.ball]\ndiffuse = 0.2\nspecular = 0.6\nroughness = 0.3\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0.3, 0.35, -0.4]\nradius = 0.35\nmaterial = \"ball\"\n",
    );
    let (lo, hi) = (-1.0f32, 1.0f32);
    // Floor, ceiling, back, right and front walls.
    text += &quad(
        [[lo, 0.0, lo], [lo, 0.0, hi], [hi, 0.0, hi], [hi, 0.0, lo]],
        "floor",
    );
    text += &quad(
        [[lo, 2.0, lo], [hi, 2.0, lo], [hi, 2.0, hi], [lo, 2.0, hi]],
        "wall",
    );
    text += &quad(
        [[lo, 0.0, lo], [hi, 0.0, lo], [hi, 2.0, lo], [lo, 2.0, lo]],
        "wall",
    );
    text += &quad(
        [[hi, 0.0, lo], [hi, 0.0, hi], [hi, 2.0, hi], [hi, 2.0, lo]],
        "wall",
    );
    text += &quad(
        [[lo, 0.0, hi], [lo, 2.0, hi], [hi, 2.0, hi], [hi, 0.0, hi]],
        "wall",
    );
    // The left wall around a window over y in [0.8, 1.6] and z in [-0.6, 0.2].
    for (y0, y1, z0, z1) in [
        (0.0, 0.8, lo, hi),
        (1.6, 2.0, lo, hi),
        (0.8, 1.6, lo, -0.6),
        (0.8, 1.6, 0.2, hi),
    ] {
        text += &quad(
            [[lo, y0, z0], [lo, y1, z0], [lo, y1, z1], [lo, y0, z1]],
            "wall",
        );
    }
    let scene = parse(&text);
    assert!(scene.background.max_element() > 0.0 && !scene.lights.is_empty());
    agree(
        &scene,
        [
            ("path", Technique::Path, 32),
            ("light", Technique::Light, 32),
            ("bdpt", Technique::Bdpt, 16),
        ],
    );
}

/// `scenes/window-room.toml` (a furnished room lit through a window by a lat-long sky map
/// and a sun) loads with both lights, and path tracing and BDPT agree on it at 64×48,
/// 8 seeds each (a sun 5% brighter for one of them fails, at z = -4.4).
#[test]
fn path_and_bidirectional_agree_in_the_window_room() {
    let mut scene = Scene::load(&manifest("scenes/window-room.toml")).unwrap();
    assert!(scene.environment.is_some() && !scene.lights.is_empty());
    scene.camera.width = 64;
    scene.camera.height = 48;
    agree(
        &scene,
        [("path", Technique::Path, 16), ("bdpt", Technique::Bdpt, 8)],
    );
}

/// Balls on a floor under an environment map with a bright "sun" texel and no other light:
/// path tracing, light tracing and BDPT agree, 8 seeds each.
#[test]
fn path_light_and_bidirectional_agree_under_an_environment_map() {
    use raylink::math::{Mat3, Rgb};
    let mut scene = parse(
        "[camera]\nposition = [0, 1.2, 3]\nlook_at = [0, 0.3, 0]\nfov = 50\nwidth = 24\nheight = 24\n\
         [materials.ground]\ndiffuse = 0.5\n\
         [materials.red]\ndiffuse = [0.7, 0.2, 0.1]\n\
         [materials.gloss]\ndiffuse = 0.1\nspecular = 0.7\nroughness = 0.2\n\
         [[shapes]]\ntype = \"quad\"\nvertices = [[-3, 0, -3], [-3, 0, 3], [3, 0, 3], [3, 0, -3]]\nmaterial = \"ground\"\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [-0.5, 0.4, 0]\nradius = 0.4\nmaterial = \"red\"\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0.5, 0.4, -0.2]\nradius = 0.4\nmaterial = \"gloss\"\n",
    );
    let n = 16;
    let mut map = Image::new(n, n);
    for y in 0..n {
        for x in 0..n {
            let v = 0.2 + (x as f32 / n as f32) + 0.5 * (y as f32 / n as f32);
            let sun = if (x, y) == (5, 6) { 60.0 } else { 0.0 };
            map.set(x, y, Rgb::new(0.5 * v + sun, 0.7 * v + sun, v + sun));
        }
    }
    let env = raylink::scene::Environment::new(map, "sky".into(), Mat3::IDENTITY, Rgb::ONE)
        .unwrap_or_else(|e| panic!("{e}"));
    scene.environment = Some(std::sync::Arc::new(env));
    agree(
        &scene,
        [
            ("path", Technique::Path, 32),
            ("light", Technique::Light, 128),
            ("bdpt", Technique::Bdpt, 16),
        ],
    );
}
