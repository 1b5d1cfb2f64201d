//! The Whitted integrator against closed-form answers, on scenes built in code.

use raylink::accel::{self, Backend};
use raylink::integrators::whitted::{Whitted, WhittedOptions};
use raylink::integrators::{Context, Integrator, RayStats};
use raylink::math::{Ray, Rgb, Rng, Vec3};
use raylink::render::{render, PixelSampling, RenderOptions};
use raylink::scene::{Camera, Geometry, Light, Material, QuadMesh, Scene, Shape, Texture};
use std::f32::consts::PI;

fn camera() -> Camera {
    Camera {
        position: Vec3::new(0.0, 4.0, 6.0),
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        fov_deg: 40.0,
        width: 64,
        height: 48,
    }
}

fn empty_scene() -> Scene {
    Scene {
        source: "test".into(),
        camera: camera(),
        materials: Vec::new(),
        shapes: Vec::new(),
        lights: Vec::new(),
        ambient: Rgb::ZERO,
        background: Rgb::ZERO,
        settings: Default::default(),
        environment: None,
        warnings: Vec::new(),
    }
}

fn add_material(scene: &mut Scene, m: Material) -> usize {
    scene.materials.push(m);
    scene.materials.len() - 1
}

/// A quad from four corners (normal (b-a) x (c-a)).
fn quad(scene: &mut Scene, corners: [Vec3; 4], material: usize) {
    scene.shapes.push(Shape {
        geometry: Geometry::Quads(QuadMesh {
            positions: corners.to_vec(),
            indices: vec![[0, 1, 2, 3]],
        }),
        material,
    });
}

/// The plane y = `y` from -s to s, facing up.
fn floor(scene: &mut Scene, y: f32, s: f32, material: usize) {
    quad(
        scene,
        [
            Vec3::new(-s, y, -s),
            Vec3::new(-s, y, s),
            Vec3::new(s, y, s),
            Vec3::new(s, y, -s),
        ],
        material,
    );
}

fn diffuse(kd: Rgb) -> Material {
    Material {
        diffuse: Texture::Constant(kd),
        specular: Rgb::ZERO,
        ..Material::default()
    }
}

fn radiance(scene: &Scene, ray: Ray, options: WhittedOptions) -> Rgb {
    let accel = accel::build(scene, Backend::Embree).unwrap();
    let ctx = Context::new(scene, accel.as_ref());
    let mut rng = Rng::for_key(0, &[]);
    Whitted::new(options)
        .radiance(&ctx, &ray, &mut rng, &mut RayStats::default())
        .radiance
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
    scene.lights.push(Light::Point {
        position: light_pos,
        intensity,
    });
    scene.ambient = Rgb::splat(0.1);
    let options = RenderOptions {
        width: 64,
        height: 48,
        sampling: PixelSampling::Uniform { n: 1 },
        threads: Some(2),
        seed: 1,
        progress: false,
    };
    let accel = accel::build(&scene, Backend::Embree).unwrap();
    let ctx = Context::new(&scene, accel.as_ref());
    let (image, _) = render(&ctx, &Whitted::new(WhittedOptions::default()), &options).unwrap();
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

/// A mirror at 45° shows the (emissive) wall it faces, scaled by ks.
#[test]
fn mirror_shows_the_colour_it_faces() {
    let mut scene = empty_scene();
    let mirror = add_material(
        &mut scene,
        Material {
            diffuse: Texture::Constant(Rgb::ZERO),
            specular: Rgb::splat(0.8),
            phong_exponent: 0.0,
            ..Material::default()
        },
    );
    let wall_emission = Rgb::new(0.2, 0.5, 0.9);
    let wall = add_material(
        &mut scene,
        Material {
            diffuse: Texture::Constant(Rgb::ZERO),
            emission: wall_emission,
            ..Material::default()
        },
    );
    // Mirror through the origin, normal (0, 1, 1)/√2: a ray along -z reflects to +y.
    quad(
        &mut scene,
        [
            Vec3::new(-1.0, -1.0, 1.0),
            Vec3::new(1.0, -1.0, 1.0),
            Vec3::new(1.0, 1.0, -1.0),
            Vec3::new(-1.0, 1.0, -1.0),
        ],
        mirror,
    );
    // Emissive wall at y = 5 facing down.
    quad(
        &mut scene,
        [
            Vec3::new(-5.0, 5.0, -5.0),
            Vec3::new(5.0, 5.0, -5.0),
            Vec3::new(5.0, 5.0, 5.0),
            Vec3::new(-5.0, 5.0, 5.0),
        ],
        wall,
    );
    let ray = Ray::new(Vec3::new(0.1, 0.0, 3.0), Vec3::NEG_Z);
    let got = radiance(&scene, ray, WhittedOptions::default());
    assert!(close(got, 0.8 * wall_emission, 1e-5), "{got}");
    // With the tree cut at the camera ray, the reflection is not traced.
    let shallow = WhittedOptions {
        max_depth: 1,
        ..WhittedOptions::default()
    };
    assert_eq!(radiance(&scene, ray, shallow), Rgb::ZERO);
}

fn shadow_scene(blocker: Material) -> (Scene, Vec3) {
    let mut scene = empty_scene();
    let kd = Rgb::splat(0.6);
    let m = add_material(
        &mut scene,
        Material {
            ambient: Some(Rgb::new(0.3, 0.2, 0.1)),
            ..diffuse(kd)
        },
    );
    floor(&mut scene, 0.0, 20.0, m);
    let b = add_material(&mut scene, blocker);
    // A thin horizontal slab (two quads, both facing outward) between light and floor.
    let top = [
        Vec3::new(-1.0, 1.5, -1.0),
        Vec3::new(-1.0, 1.5, 1.0),
        Vec3::new(1.0, 1.5, 1.0),
        Vec3::new(1.0, 1.5, -1.0),
    ];
    quad(&mut scene, top, b);
    let bottom = top.map(|v| Vec3::new(v.x, 1.4, v.z));
    quad(&mut scene, [bottom[3], bottom[2], bottom[1], bottom[0]], b);
    let light = Vec3::new(0.0, 4.0, 0.0);
    scene.lights.push(Light::Point {
        position: light,
        intensity: Rgb::splat(30.0),
    });
    scene.ambient = Rgb::splat(0.5);
    (scene, light)
}

/// A point in shadow gets only the ambient term ka·Ia; a transmissive occluder attenuates the
/// light by kt at each surface the shadow ray crosses.
#[test]
fn shadowed_points_get_ambient_only_and_glass_attenuates() {
    let view = Ray::new(Vec3::new(0.3, 1.0, 0.2), Vec3::NEG_Y);
    let opaque = diffuse(Rgb::splat(0.5));
    let (scene, _) = shadow_scene(opaque);
    let got = radiance(&scene, view, WhittedOptions::default());
    let ambient = Rgb::new(0.3, 0.2, 0.1) * 0.5;
    assert!(close(got, ambient, 1e-6), "{got} vs {ambient}");

    let kt = Rgb::new(0.5, 0.8, 1.0);
    let glass = Material {
        diffuse: Texture::Constant(Rgb::ZERO),
        transmission: kt,
        ior: 1.0,
        ..Material::default()
    };
    let (scene, light) = shadow_scene(glass);
    let got = radiance(&scene, view, WhittedOptions::default());
    let p = Vec3::new(0.3, 0.0, 0.2);
    let to = light - p;
    let unshadowed = 0.6 / PI * 30.0 * to.normalize().y / to.length_squared();
    let expected = ambient + Rgb::splat(unshadowed) * kt * kt;
    assert!(close(got, expected, 1e-4), "{got} vs {expected}");
}

/// Inside glass (the ray meets the surface from behind its normal), a ray steeper than the
/// critical angle leaves and sees the sky; a grazing one is totally internally reflected,
/// so T = 0 and only ks·S remains.
#[test]
fn total_internal_reflection_inside_glass() {
    let mut scene = empty_scene();
    let glass = add_material(
        &mut scene,
        Material {
            diffuse: Texture::Constant(Rgb::ZERO),
            specular: Rgb::splat(0.25),
            transmission: Rgb::splat(1.0),
            ior: 1.5,
            phong_exponent: 0.0,
            ..Material::default()
        },
    );
    let sky = Rgb::new(1.0, 2.0, 3.0);
    let sky_m = add_material(
        &mut scene,
        Material {
            diffuse: Texture::Constant(Rgb::ZERO),
            emission: sky,
            ..Material::default()
        },
    );
    // Glass surface y = 1 facing up (the camera is inside, below it); the sky at y = 3
    // facing down; a dim floor far below sees the reflected rays.
    floor(&mut scene, 1.0, 50.0, glass);
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
    let floor_glow = Rgb::new(0.5, 0.0, 0.0);
    let floor_m = add_material(
        &mut scene,
        Material {
            diffuse: Texture::Constant(Rgb::ZERO),
            emission: floor_glow,
            ..Material::default()
        },
    );
    floor(&mut scene, -1.0, 50.0, floor_m);
    let options = WhittedOptions {
        max_depth: 3,
        ..WhittedOptions::default()
    };
    let at = |deg: f32| {
        let a = deg.to_radians();
        Ray::new(Vec3::ZERO, Vec3::new(a.sin(), a.cos(), 0.0))
    };
    // 30° < 41.8°: refracts out to the sky (kt), reflects down to the floor (ks).
    let steep = radiance(&scene, at(30.0), options.clone());
    assert!(close(steep, sky + 0.25 * floor_glow, 1e-5), "{steep}");
    // 60° > 41.8°: no transmission at all.
    let grazing = radiance(&scene, at(60.0), options.clone());
    assert!(close(grazing, 0.25 * floor_glow, 1e-5), "{grazing}");
    // With Fresnel weighting, total internal reflection sends everything into ks·S.
    let fresnel = WhittedOptions {
        fresnel: true,
        ..options
    };
    let grazing = radiance(&scene, at(60.0), fresnel);
    assert!(close(grazing, 0.25 * floor_glow, 1e-5), "{grazing}");
}

/// A scene with every random element (glossy, frosted, area light) rendered adaptively.
fn busy_scene() -> Scene {
    let mut scene = empty_scene();
    let checker = add_material(
        &mut scene,
        Material {
            diffuse: Texture::Checker {
                even: Rgb::new(0.8, 0.1, 0.1),
                odd: Rgb::new(0.9, 0.9, 0.2),
                size: 0.5,
            },
            ..Material::default()
        },
    );
    floor(&mut scene, 0.0, 10.0, checker);
    let glossy = add_material(
        &mut scene,
        Material {
            diffuse: Texture::Constant(Rgb::splat(0.1)),
            specular: Rgb::splat(0.7),
            roughness: 0.05,
            ..Material::default()
        },
    );
    let frosted = add_material(
        &mut scene,
        Material {
            diffuse: Texture::Constant(Rgb::ZERO),
            specular: Rgb::splat(0.1),
            transmission: Rgb::splat(0.9),
            roughness: 0.03,
            ..Material::default()
        },
    );
    for (center, m) in [
        (Vec3::new(-0.8, 0.7, 0.0), glossy),
        (Vec3::new(0.8, 0.7, 0.5), frosted),
    ] {
        scene.shapes.push(Shape {
            geometry: Geometry::Sphere {
                center,
                radius: 0.7,
            },
            material: m,
        });
    }
    let lamp = add_material(
        &mut scene,
        Material {
            diffuse: Texture::Constant(Rgb::ZERO),
            emission: Rgb::splat(8.0),
            ..Material::default()
        },
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
    scene.lights.push(Light::Point {
        position: Vec3::new(3.0, 4.0, 3.0),
        intensity: Rgb::splat(10.0),
    });
    scene.ambient = Rgb::splat(0.05);
    scene.background = Rgb::new(0.1, 0.2, 0.4);
    scene
}

#[test]
fn image_is_bit_identical_for_any_thread_count() {
    let scene = busy_scene();
    let accel = accel::build(&scene, Backend::Embree).unwrap();
    let ctx = Context::new(&scene, accel.as_ref());
    let whitted = Whitted::new(WhittedOptions {
        area_samples: 4,
        ..WhittedOptions::default()
    });
    for sampling in [PixelSampling::default(), PixelSampling::Uniform { n: 2 }] {
        let images: Vec<_> = [1, 2, 3]
            .into_iter()
            .map(|threads| {
                let options = RenderOptions {
                    width: 120,
                    height: 90,
                    sampling,
                    threads: Some(threads),
                    seed: 42,
                    progress: false,
                };
                render(&ctx, &whitted, &options).unwrap()
            })
            .collect();
        for (image, stats) in &images[1..] {
            assert_eq!(image.pixels, images[0].0.pixels, "{sampling:?}");
            assert_eq!(stats.rays, images[0].1.rays);
        }
        // And a different seed does change the noisy parts.
        let other = RenderOptions {
            width: 120,
            height: 90,
            sampling,
            threads: Some(2),
            seed: 43,
            progress: false,
        };
        assert_ne!(
            render(&ctx, &whitted, &other).unwrap().0.pixels,
            images[0].0.pixels
        );
    }
}
