//! The Whitted integrator against closed-form answers, on scenes built in code, rendered
//! through the job API. (The answers along single rays, which call the integrator itself,
//! are unit tests in src/tests/whitted.rs.)

use raylink::math::{Rgb, Vec3};
use raylink::scene::{
    Camera, Classic, Geometry, Light, Material, QuadMesh, Scene, Shape, Sphere, Texture,
};
use raylink::{
    Backend, Control, Image, Job, RenderStats, Renderer, Settings, Technique, TechniqueKind,
};
use std::f32::consts::PI;

#[path = "../src/tests/whitted_scenes.rs"]
mod scenes;
use scenes::{add_material, diffuse, empty_scene, floor, quad};

/// Whitted's integrator with its defaults and `settings` (sampling, area samples).
fn whitted_settings(settings: Settings) -> Technique {
    Technique::create(&Settings {
        integrator: Some(TechniqueKind::Whitted),
        ..settings
    })
    .unwrap()
}

/// Whitted with uniform `n`×`n` supersampling and `area_samples` shadow rays per area light.
fn whitted(n: u32, area_samples: u32) -> Technique {
    whitted_settings(Settings {
        spp: Some(n * n),
        area_samples: Some(area_samples),
        ..Settings::default()
    })
}

/// Renders the camera's view at `size` with `technique` through the job API.
fn render(
    scene: &Scene,
    technique: Technique,
    (width, height): (u32, u32),
    seed: u64,
    threads: Option<usize>,
) -> (Image, RenderStats) {
    let job = Job {
        width,
        height,
        seed,
        threads,
        region: None,
        accel: Backend::Embree,
        ..Job::new(scene, technique)
    };
    let control = Control::default();
    let rendered = Renderer::new(scene.clone(), job, &control)
        .unwrap()
        .render(&control)
        .unwrap();
    (rendered.image, rendered.stats)
}

fn close(a: Rgb, b: Rgb, rel: f32) -> bool {
    (a - b).abs().max_element() <= rel * b.abs().max_element().max(1e-6)
}

/// A diffuse plane lit by a point light: pixels equal kd/π·(N·L)·I/r² + ka·Ia, read from a
/// rendered image at pixel centres.
#[test]
fn diffuse_plane_under_point_light_matches_lambert() {
    let mut scene = empty_scene();
    let kd = Rgb::new(0.7, 0.5, 0.3);
    let m = add_material(&mut scene, diffuse(kd));
    floor(&mut scene, 0.0, 20.0, m);
    let light_pos = Vec3::new(1.0, 3.0, -0.5);
    let intensity = Rgb::new(20.0, 15.0, 10.0);
    scene
        .lights
        .push(Light::Point(raylink::scene::lights::PointLight {
            position: light_pos,
            intensity,
            spectrum: None,
        }));
    scene.ambient = Rgb::splat(0.1);
    let (image, _) = render(&scene, whitted(1, 16), (64, 48), 1, Some(2));
    let basis = scene.camera.basis();
    let mut checked = 0;
    for (x, y) in [(32, 24), (5, 40), (60, 30), (20, 10), (50, 45)] {
        let ray = basis.ray(x as f32 + 0.5, y as f32 + 0.5);
        let t = -ray.origin.y / ray.dir.y;
        assert!(t > 0.0, "pixel ({x},{y}) must see the plane");
        let p = ray.at(t);
        let to = light_pos - p;
        let cos = to.normalize().y;
        let expected = kd / PI * intensity * cos / to.length_squared() + kd * scene.ambient;
        let got = image.get(x, y);
        assert!(
            close(got, expected, 1e-4),
            "pixel ({x},{y}): {got} vs {expected}"
        );
        checked += 1;
    }
    assert_eq!(checked, 5);
}

/// A scene with every random element (glossy, frosted, area light) rendered adaptively.
fn busy_scene() -> Scene {
    let mut scene = empty_scene();
    let checker = add_material(
        &mut scene,
        Material::classic(
            "",
            Classic {
                diffuse: Texture::Checker {
                    even: Rgb::new(0.8, 0.1, 0.1),
                    odd: Rgb::new(0.9, 0.9, 0.2),
                    size: 0.5,
                },
                ..Classic::default()
            },
        ),
    );
    floor(&mut scene, 0.0, 10.0, checker);
    let glossy = add_material(
        &mut scene,
        Material::classic(
            "",
            Classic {
                diffuse: Texture::Constant(Rgb::splat(0.1)),
                specular: Rgb::splat(0.7),
                roughness: 0.05,
                ..Classic::default()
            },
        ),
    );
    let frosted = add_material(
        &mut scene,
        Material::classic(
            "",
            Classic {
                diffuse: Texture::Constant(Rgb::ZERO),
                specular: Rgb::splat(0.1),
                transmission: Rgb::splat(0.9),
                roughness: 0.03,
                ..Classic::default()
            },
        ),
    );
    for (center, m) in [
        (Vec3::new(-0.8, 0.7, 0.0), glossy),
        (Vec3::new(0.8, 0.7, 0.5), frosted),
    ] {
        scene.shapes.push(Shape {
            media: None,
            geometry: Geometry::Sphere(Sphere {
                center,
                radius: 0.7,
            }),
            material: m,
            alpha: None,
            motion: None,
        });
    }
    let lamp = add_material(
        &mut scene,
        Material::classic(
            "",
            Classic {
                diffuse: Texture::Constant(Rgb::ZERO),
                ..Classic::default()
            },
        )
        .emitting(Rgb::splat(8.0)),
    );
    quad(
        &mut scene,
        [
            Vec3::new(-0.5, 3.0, -0.5),
            Vec3::new(0.5, 3.0, -0.5),
            Vec3::new(0.5, 3.0, 0.5),
            Vec3::new(-0.5, 3.0, 0.5),
        ],
        lamp,
    );
    scene
        .lights
        .push(Light::Point(raylink::scene::lights::PointLight {
            position: Vec3::new(3.0, 4.0, 3.0),
            intensity: Rgb::splat(10.0),
            spectrum: None,
        }));
    scene.ambient = Rgb::splat(0.05);
    scene.background = Rgb::new(0.1, 0.2, 0.4);
    scene
}

#[test]
fn image_is_bit_identical_for_any_thread_count() {
    let scene = busy_scene();
    // Area samples 4; the default adaptive sampling, then uniform 2x2.
    for spp in [None, Some(4)] {
        let technique = whitted_settings(Settings {
            spp,
            area_samples: Some(4),
            ..Settings::default()
        });
        let images: Vec<_> = [1, 2, 3]
            .into_iter()
            .map(|threads| render(&scene, technique.clone(), (120, 90), 42, Some(threads)))
            .collect();
        for (image, stats) in &images[1..] {
            assert_eq!(image.pixels, images[0].0.pixels, "{technique:?}");
            assert_eq!(stats.rays, images[0].1.rays);
        }
        // And a different seed does change the noisy parts.
        assert_ne!(
            render(&scene, technique.clone(), (120, 90), 43, Some(2))
                .0
                .pixels,
            images[0].0.pixels
        );
    }
}
