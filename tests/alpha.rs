//! Alpha cut-outs: a masked leaf between a point light and a floor casts the shadow of its
//! mask (the floor's radiance where light passes is the analytic ρ/π · I cos θ / r², zero
//! where it is blocked) and camera rays see through its holes, on both backends; fractional
//! alpha blocks that fraction of rays, the same rays on both backends, deterministically.
#![cfg(feature = "embree")]

#[path = "common/render.rs"]
mod render_common;

use raylink::accel::bvh::BvhAccel;
use raylink::accel::embree::EmbreeAccel;
use raylink::accel::Accel;
use raylink::image::Image;
use raylink::math::{Ray, Rng, Vec2, Vec3};
use raylink::scene::texture::{Encoding, ImageTexture, UvMapping};
use raylink::scene::{Alpha, Scene};
use raylink::{Backend, Control, Technique};
use render_common::{boxed, image, View};
use std::path::Path;
use std::sync::Arc;

fn parse(text: &str) -> Scene {
    raylink::scene::toml::from_str(text, Path::new("alpha.toml")).unwrap_or_else(|e| panic!("{e}"))
}

fn render(scene: &Scene, backend: Backend, threads: usize, spp: u32) -> Image {
    let view = View::of(scene, 3, Some(threads), backend);
    image(scene, Technique::Path(boxed(1, spp)), view)
}

/// An 8x8 binary PGM: opaque (255) in the texels whose u < 0.5 xor v < 0.5 (row 0 is the
/// top of the image, v = 1), so on the leaf the quadrants x < 0 xor y < 0 are opaque.
fn checker_mask(dir: &Path) -> Arc<ImageTexture> {
    let mut data = b"P5\n8 8\n255\n".to_vec();
    for row in 0..8 {
        for col in 0..8 {
            let opaque = (col < 4) ^ (row >= 4);
            data.push(if opaque { 255 } else { 0 });
        }
    }
    let path = dir.join("mask.pgm");
    std::fs::write(&path, data).unwrap();
    let texture = ImageTexture::load(
        &path,
        "mask.pgm".into(),
        Encoding::Linear,
        1.0,
        false,
        UvMapping::default(),
    )
    .unwrap();
    Arc::new(texture)
}

const WIDTH: u32 = 40;
const SIZE: f64 = 5.0;
const INTENSITY: f64 = 3.0;
const ALBEDO: f64 = 0.8;

/// A white diffuse floor at z = 0, a black leaf quad over [-1, 1]² at z = 1 with the checker
/// mask, a point light at (0, 0, 2), an orthographic camera looking down over [-2.5, 2.5]².
fn leaf_scene(dir: &Path) -> Scene {
    let mut scene = parse(&format!(
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nwidth = {WIDTH}\nheight = {WIDTH}\n\
         projection = \"orthographic\"\nsize = {SIZE}\n\
         [materials.floor]\ndiffuse = {ALBEDO}\nphong_exponent = 0\n\
         [materials.leaf]\ndiffuse = 0\nspecular = 0\nphong_exponent = 0\n\
         [[shapes]]\ntype = \"quad\"\nvertices = [[-5, -5, 0], [5, -5, 0], [5, 5, 0], [-5, 5, 0]]\nmaterial = \"floor\"\n\
         [[shapes]]\ntype = \"quad\"\nvertices = [[-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]]\nmaterial = \"leaf\"\n\
         [[lights]]\ntype = \"point\"\nposition = [0, 0, 2]\nintensity = {INTENSITY}\n"
    ));
    scene.shapes[1].alpha = Some(Alpha::Image(checker_mask(dir)));
    scene
}

/// The floor's radiance at (x, y) with nothing in the way: ρ/π · I cos θ / r².
fn unshadowed(x: f64, y: f64) -> f64 {
    let d2 = x * x + y * y + 4.0;
    let cos = 2.0 / d2.sqrt();
    ALBEDO / std::f64::consts::PI * INTENSITY * cos / d2
}

/// Pixel (px, py)'s centre in world (x, y): x right, y up.
fn world(px: u32, py: u32) -> (f64, f64) {
    let pixel = SIZE / WIDTH as f64;
    (
        (px as f64 + 0.5 - WIDTH as f64 / 2.0) * pixel,
        -(py as f64 + 0.5 - WIDTH as f64 / 2.0) * pixel,
    )
}

/// The unshadowed radiance averaged over a pixel.
fn pixel_unshadowed(px: u32, py: u32) -> f64 {
    let (n, pixel) = (16, SIZE / WIDTH as f64);
    let (cx, cy) = world(px, py);
    let mut sum = 0.0;
    for i in 0..n {
        for j in 0..n {
            let dx = ((i as f64 + 0.5) / n as f64 - 0.5) * pixel;
            let dy = ((j as f64 + 0.5) / n as f64 - 0.5) * pixel;
            sum += unshadowed(cx + dx, cy + dy);
        }
    }
    sum / (n * n) as f64
}

fn grey(image: &Image, px: u32, py: u32) -> f64 {
    let c = image.get(px, py);
    (c.x + c.y + c.z) as f64 / 3.0
}

/// Floor points seen through the leaf (|x|, |y| < 1) and beside it (1 < |x|, |y| < 2), away
/// from the mask's quadrant edges and the leaf's border (where the bilinear lookup blends
/// texels): lit where x and y have the same sign, black elsewhere (shadowed, or the opaque
/// black leaf in front).
#[test]
fn a_masked_leaf_casts_its_masks_shadow_and_shows_its_holes() {
    let dir = tempfile::tempdir().unwrap();
    let scene = leaf_scene(dir.path());
    let mut images = Vec::new();
    for backend in Backend::ALL {
        let image = render(&scene, backend, 2, 16);
        let (mut lit, mut dark) = (0, 0);
        for py in 0..WIDTH {
            for px in 0..WIDTH {
                let (x, y) = world(px, py);
                let inside =
                    |c: f64| (0.3..0.7).contains(&c.abs()) || (1.3..1.7).contains(&c.abs());
                if !(inside(x) && inside(y)) {
                    continue;
                }
                let got = grey(&image, px, py);
                if (x > 0.0) == (y > 0.0) {
                    let want = pixel_unshadowed(px, py);
                    assert!(
                        (got / want - 1.0).abs() < 0.005,
                        "{backend}: lit floor at ({x}, {y}): {got} vs {want}"
                    );
                    lit += 1;
                } else {
                    assert_eq!(got, 0.0, "{backend}: light at ({x}, {y})");
                    dark += 1;
                }
            }
        }
        eprintln!("{backend}: {lit} lit and {dark} dark pixels checked");
        assert!(lit >= 40 && dark >= 40, "{lit} {dark}");
        images.push(image);
    }
    // The two backends agree everywhere, up to float noise at the mask's edges.
    let (e, b) = (&images[0], &images[1]);
    let mut differ = 0;
    for py in 0..WIDTH {
        for px in 0..WIDTH {
            if (grey(e, px, py) - grey(b, px, py)).abs() > 1e-4 {
                differ += 1;
            }
        }
    }
    assert!(differ <= 4, "{differ} pixels differ between the backends");
}

/// A 4x4 quad at z = 0 with constant alpha `a`, and one at z = 1 with alpha `b`.
fn layers(a: f32, b: f32) -> Scene {
    let mut scene = parse(
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nwidth = 32\nheight = 32\n\
         projection = \"orthographic\"\nsize = 3\n\
         [materials.white]\ndiffuse = 0.5\nphong_exponent = 0\n\
         [[shapes]]\ntype = \"quad\"\nvertices = [[-2, -2, 0], [2, -2, 0], [2, 2, 0], [-2, 2, 0]]\nmaterial = \"white\"\n\
         [[shapes]]\ntype = \"quad\"\nvertices = [[-2, -2, 1], [2, -2, 1], [2, 2, 1], [-2, 2, 1]]\nmaterial = \"white\"\n\
         [[lights]]\ntype = \"point\"\nposition = [0.3, 0.2, 3]\nintensity = 4\n",
    );
    scene.shapes[0].alpha = Some(Alpha::Constant(a));
    scene.shapes[1].alpha = Some(Alpha::Constant(b));
    scene
}

/// Rays from below both layers, upwards through them.
fn upward_rays(n: usize) -> Vec<Ray> {
    let mut rng = Rng::for_key(11, &[]);
    (0..n)
        .map(|_| {
            let origin = Vec3::new(rng.uniform() * 2.0 - 1.0, rng.uniform() * 2.0 - 1.0, -1.0);
            let dir = Vec3::new(rng.uniform() * 0.4 - 0.2, rng.uniform() * 0.4 - 0.2, 1.0);
            Ray::new(origin, dir)
        })
        .collect()
}

/// Binomial tolerance: five standard deviations of a count of n trials at probability p.
fn within_binomial(count: usize, n: usize, p: f64) -> bool {
    let sigma = (n as f64 * p * (1.0 - p)).sqrt();
    (count as f64 - n as f64 * p).abs() < 5.0 * sigma
}

#[test]
fn half_alpha_blocks_half_the_rays_on_both_backends_alike() {
    let n = 20_000;
    let rays = upward_rays(n);
    // One layer at alpha 0.5 (the other at 0: absent).
    let scene = layers(0.0, 0.5);
    let (embree, bvh) = (
        EmbreeAccel::build(&scene).unwrap(),
        BvhAccel::build(&scene).unwrap(),
    );
    let accels: [&dyn Accel; 2] = [&embree, &bvh];
    let blocked: Vec<Vec<bool>> = accels
        .iter()
        .map(|a| rays.iter().map(|r| a.occluded(r)).collect())
        .collect();
    let count = blocked[0].iter().filter(|&&b| b).count();
    eprintln!("alpha 0.5: {count} of {n} occlusion rays blocked");
    assert!(within_binomial(count, n, 0.5), "{count} of {n}");
    assert_eq!(blocked[0], blocked[1], "the backends block different rays");
    // Closest hits skip what occlusion skips: a hit on the layer exactly when blocked.
    for (a, blocked) in accels.iter().zip(&blocked) {
        for (r, &b) in rays.iter().zip(blocked) {
            let hit = a.intersect(r);
            assert_eq!(hit.is_some(), b);
            if let Some(h) = hit {
                assert_eq!(h.geom_id, 1);
            }
        }
    }
    // Two layers at 0.5 each: a ray passes both with probability 1/4 (independent tests).
    let scene = layers(0.5, 0.5);
    for accel in [
        Box::new(EmbreeAccel::build(&scene).unwrap()) as Box<dyn Accel>,
        Box::new(BvhAccel::build(&scene).unwrap()),
    ] {
        let passed = rays.iter().filter(|r| !accel.occluded(r)).count();
        let nearest_lower = rays
            .iter()
            .filter(|r| accel.intersect(r).is_some_and(|h| h.geom_id == 0))
            .count();
        eprintln!("two layers: {passed} of {n} pass, {nearest_lower} stop at the lower one");
        assert!(within_binomial(passed, n, 0.25), "{passed} of {n}");
        assert!(within_binomial(nearest_lower, n, 0.5), "{nearest_lower}");
    }
}

#[test]
fn stochastic_alpha_renders_the_same_on_any_thread_count() {
    let scene = layers(0.5, 0.5);
    for backend in Backend::ALL {
        let one = render(&scene, backend, 1, 4);
        let two = render(&scene, backend, 2, 4);
        assert!(
            one.pixels == two.pixels,
            "{backend}: 1 and 2 threads differ"
        );
        // And the layers are half there: neither black nor fully lit everywhere.
        let mean = one.pixels.iter().map(|p| p.x as f64).sum::<f64>() / one.pixels.len() as f64;
        assert!(mean > 0.0, "{backend}: black image");
    }
}

#[test]
fn an_alpha_images_first_channel_is_the_alpha() {
    let dir = tempfile::tempdir().unwrap();
    let mask = checker_mask(dir.path());
    let alpha = Alpha::Image(mask);
    assert_eq!(alpha.value(Vec2::new(0.25, 0.25)), 0.0);
    assert_eq!(alpha.value(Vec2::new(0.25, 0.75)), 1.0);
    assert_eq!(alpha.value(Vec2::new(0.75, 0.25)), 1.0);
    assert_eq!(alpha.value(Vec2::new(0.75, 0.75)), 0.0);
}

#[path = "common/pbrt.rs"]
mod pbrt_common;

/// A lit white floor seen from the front, with `occluder` (a shape statement) between the
/// light and the floor and between the camera and the floor.
fn pbrt_scene(occluder: &str) -> Scene {
    pbrt_common::world(&format!(
        "LightSource \"point\" \"rgb I\" [8 8 8] \"point3 from\" [0 0 3]\n\
         Material \"diffuse\" \"rgb reflectance\" [0.7 0.7 0.7]\n\
         Shape \"bilinearmesh\" \"point3 P\" [-3 -3 -1  3 -3 -1  -3 3 -1  3 3 -1]\n\
         AttributeBegin\nTranslate 0 0 1\n{occluder}AttributeEnd\n"
    ))
}

#[test]
fn pbrt_alpha_zero_renders_as_if_the_shape_were_absent() {
    let disk = "Shape \"disk\" \"float radius\" 1.5";
    let absent = pbrt_common::whitted_render(&pbrt_scene(""), 24);
    let cut = pbrt_scene(&format!("{disk} \"float alpha\" 0\n"));
    assert!(cut.warnings.is_empty(), "{:?}", cut.warnings);
    assert!(matches!(cut.shapes[1].alpha, Some(Alpha::Constant(a)) if a == 0.0));
    let cut = pbrt_common::whitted_render(&cut, 24);
    assert!(absent.pixels == cut.pixels, "alpha 0 changes the image");
    // The opaque disk does change it (the comparison can fail).
    let opaque = pbrt_common::whitted_render(&pbrt_scene(&format!("{disk}\n")), 24);
    assert!(absent.pixels != opaque.pixels);
}

#[test]
fn pbrt_alpha_textures_are_constants_and_image_maps() {
    let dir = tempfile::tempdir().unwrap();
    let mut pgm = b"P5\n2 1\n255\n".to_vec();
    pgm.extend([0, 255]);
    let scene = |shape_alpha: &str| {
        pbrt_common::load_in(
            dir.path(),
            &format!(
                "{}Texture \"half\" \"float\" \"constant\" \"float value\" 0.5\n\
                 Texture \"mask\" \"float\" \"imagemap\" \"string filename\" \"mask.pgm\"\n\
                 Texture \"checks\" \"float\" \"checkerboard\"\n\
                 {} {shape_alpha}\n",
                pbrt_common::HEADER,
                pbrt_common::TRI.trim_end()
            ),
            &[("mask.pgm", &pgm)],
        )
    };
    let s = scene("\"texture alpha\" \"half\"").unwrap();
    assert!(matches!(s.shapes[0].alpha, Some(Alpha::Constant(a)) if a == 0.5));
    let s = scene("\"texture alpha\" \"mask\"").unwrap();
    match &s.shapes[0].alpha {
        Some(Alpha::Image(image)) => {
            // Texel centres: the left one 0, the right one 1 (first channel, linear).
            assert_eq!(
                s.shapes[0]
                    .alpha
                    .as_ref()
                    .unwrap()
                    .value(Vec2::new(0.25, 0.5)),
                0.0
            );
            assert_eq!(
                s.shapes[0]
                    .alpha
                    .as_ref()
                    .unwrap()
                    .value(Vec2::new(0.75, 0.5)),
                1.0
            );
            assert_eq!(image.file, Path::new("mask.pgm"));
        }
        other => panic!("{other:?}"),
    }
    assert!(s.inputs.iter().any(|p| p.ends_with("mask.pgm")));
    let s = scene("\"float alpha\" 1").unwrap();
    assert!(s.shapes[0].alpha.is_none() && s.warnings.is_empty());
    let s = scene("\"texture alpha\" \"checks\"").unwrap();
    assert!(s.shapes[0].alpha.is_none());
    assert!(
        s.warnings.iter().any(|w| w.contains("cut-out")),
        "{:?}",
        s.warnings
    );
    let e = scene("\"texture alpha\" \"nothing\"")
        .unwrap_err()
        .to_string();
    assert!(e.contains("no float texture named \"nothing\""), "{e}");
}

/// The TOML format's `alpha = 0.5` and `alpha = { image = { .. } }`, and the TOML the pbrt
/// converter writes keeps them.
#[test]
fn toml_alpha_reads_and_survives_conversion() {
    let dir = tempfile::tempdir().unwrap();
    checker_mask(dir.path());
    let main = dir.path().join("leaves.toml");
    std::fs::write(
        &main,
        "[camera]\nposition = [0, 1, 5]\nlook_at = [0, 0, 0]\n\
         [materials.leaf]\ndiffuse = 0.5\n\
         [[shapes]]\ntype = \"quad\"\nvertices = [[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]]\n\
         material = \"leaf\"\nalpha = { image = { file = \"mask.pgm\", encoding = \"linear\" } }\n\
         [[shapes]]\ntype = \"sphere\"\nmaterial = \"leaf\"\nalpha = 0.25\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [3, 0, 0]\nmaterial = \"leaf\"\nalpha = 1\n",
    )
    .unwrap();
    let check = |scene: &Scene| {
        match &scene.shapes[0].alpha {
            Some(a @ Alpha::Image(_)) => {
                assert_eq!(a.value(Vec2::new(0.25, 0.75)), 1.0);
                assert_eq!(a.value(Vec2::new(0.25, 0.25)), 0.0);
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(scene.shapes[1].alpha, Some(Alpha::Constant(a)) if a == 0.25));
        assert!(scene.shapes[2].alpha.is_none());
    };
    let scene = Scene::load(&main).unwrap();
    check(&scene);
    assert!(scene.inputs.iter().any(|p| p.ends_with("mask.pgm")));
    let out = dir.path().join("written.toml");
    raylink::scene::convert::write_toml(&scene, &out).unwrap();
    check(&Scene::load(&out).unwrap());
}

/// An animation's accel moved to the next frame keeps (or drops) the cut-outs of that frame.
#[test]
fn dynamic_accels_follow_alpha_between_frames() {
    let rays = upward_rays(2000);
    let control = Control::default();
    let blocked = |a: &dyn Accel| rays.iter().filter(|r| a.occluded(r)).count();
    for backend in Backend::ALL {
        let half = layers(0.0, 0.5);
        let mut accel = raylink::accel::build_dynamic(&half, backend, &control).unwrap();
        let first = blocked(accel.as_ref());
        accel.update(&half).unwrap();
        assert_eq!(blocked(accel.as_ref()), first, "{backend}");
        let mut opaque = half.clone();
        opaque.shapes[1].alpha = None;
        accel.update(&opaque).unwrap();
        assert_eq!(blocked(accel.as_ref()), rays.len(), "{backend}");
        accel.update(&half).unwrap();
        assert_eq!(blocked(accel.as_ref()), first, "{backend}");
        assert!(first < rays.len() * 3 / 4, "{backend}: {first}");
    }
}

/// Closest hits on random rays through masked shapes of every kind (a sphere, whose back is
/// reached through a hole in its front, a quad, and a mesh with uvs) agree between the
/// backends: the same shape at the same distance.
#[test]
fn backends_agree_on_masked_shapes_of_every_kind() {
    let dir = tempfile::tempdir().unwrap();
    let mut scene = parse(
        "[camera]\nposition = [0, 0, 6]\nlook_at = [0, 0, 0]\n\
         [materials.white]\ndiffuse = 0.5\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [-1.5, 0, 0]\nradius = 1\nmaterial = \"white\"\n\
         [[shapes]]\ntype = \"quad\"\nvertices = [[0, -1, 0], [2, -1, 0], [2, 1, 0], [0, 1, 0]]\nmaterial = \"white\"\n\
         [[shapes]]\ntype = \"mesh\"\npositions = [[-1, -1, -2], [1, -1, -2], [0, 2, -2]]\n\
         indices = [[0, 1, 2]]\nuvs = [[0, 0], [3, 0], [0, 3]]\nmaterial = \"white\"\n",
    );
    let mask = Alpha::Image(checker_mask(dir.path()));
    for s in &mut scene.shapes {
        s.alpha = Some(mask.clone());
    }
    let (embree, bvh) = (
        EmbreeAccel::build(&scene).unwrap(),
        BvhAccel::build(&scene).unwrap(),
    );
    let mut rng = Rng::for_key(5, &[]);
    let (n, mut hits, mut differ) = (20_000, [0usize; 3], 0);
    for _ in 0..n {
        let origin = Vec3::new(rng.uniform() * 6.0 - 3.0, rng.uniform() * 6.0 - 3.0, 4.0);
        let target = Vec3::new(rng.uniform() * 4.0 - 2.5, rng.uniform() * 3.0 - 1.5, -1.0);
        let ray = Ray::new(origin, target - origin);
        match (embree.intersect(&ray), bvh.intersect(&ray)) {
            (None, None) => {}
            (Some(e), Some(b)) if e.geom_id == b.geom_id && (e.t - b.t).abs() < 1e-4 * e.t => {
                hits[e.geom_id as usize] += 1;
            }
            _ => differ += 1,
        }
    }
    eprintln!("hits per shape {hits:?}, {differ} of {n} rays differ");
    assert!(hits.iter().all(|&h| h > 500), "{hits:?}");
    assert!(differ <= n / 1000, "{differ} of {n} rays differ");
}
