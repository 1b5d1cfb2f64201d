//! The Whitted integrator against closed-form answers along single rays, on scenes built in
//! code (moved from tests/whitted.rs: they call the integrator itself; the rendered images
//! are checked there, through the job API).

use crate::accel::{self, Backend};
use crate::control::Control;
use crate::integrators::whitted::{Whitted, WhittedOptions};
use crate::math::{Ray, Rgb, Rng, Vec3};
use crate::scene::{Camera, Classic, Geometry, Light, Material, QuadMesh, Scene, Shape, Texture};
use crate::transport::{Context, Integrator, RayStats};
use std::f32::consts::PI;

#[path = "whitted_scenes.rs"]
pub(super) mod scenes;
use scenes::{add_material, diffuse, diffuse_classic, empty_scene, floor, quad};

fn radiance(scene: &Scene, ray: Ray, options: WhittedOptions) -> Rgb {
    let accel = accel::build(scene, Backend::Embree, &Control::default()).unwrap();
    let ctx = Context::new(scene, accel.as_ref());
    let mut rng = Rng::for_key(0, &[]);
    Whitted::new(options)
        .radiance(&ctx, &ray, &mut rng, &mut RayStats::default())
        .radiance
}

fn close(a: Rgb, b: Rgb, rel: f32) -> bool {
    (a - b).abs().max_element() <= rel * b.abs().max_element().max(1e-6)
}

/// A mirror at 45° shows the (emissive) wall it faces, scaled by ks.
#[test]
fn mirror_shows_the_colour_it_faces() {
    let mut scene = empty_scene();
    let mirror = add_material(
        &mut scene,
        Material::classic(
            "",
            Classic {
                diffuse: Texture::Constant(Rgb::ZERO),
                specular: Rgb::splat(0.8),
                phong_exponent: 0.0,
                ..Classic::default()
            },
        ),
    );
    let wall_emission = Rgb::new(0.2, 0.5, 0.9);
    let wall = add_material(
        &mut scene,
        Material::classic(
            "",
            Classic {
                diffuse: Texture::Constant(Rgb::ZERO),
                ..Classic::default()
            },
        )
        .emitting(wall_emission),
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
        Material::classic(
            "",
            Classic {
                ambient: Some(Rgb::new(0.3, 0.2, 0.1)),
                ..diffuse_classic(kd)
            },
        ),
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
    scene
        .lights
        .push(Light::Point(crate::scene::lights::PointLight {
            position: light,
            intensity: Rgb::splat(30.0),
            spectrum: None,
        }));
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
    let glass = Material::classic(
        "",
        Classic {
            diffuse: Texture::Constant(Rgb::ZERO),
            transmission: kt,
            ior: 1.0,
            ..Classic::default()
        },
    );
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
        Material::classic(
            "",
            Classic {
                diffuse: Texture::Constant(Rgb::ZERO),
                specular: Rgb::splat(0.25),
                transmission: Rgb::splat(1.0),
                ior: 1.5,
                phong_exponent: 0.0,
                ..Classic::default()
            },
        ),
    );
    let sky = Rgb::new(1.0, 2.0, 3.0);
    let sky_m = add_material(
        &mut scene,
        Material::classic(
            "",
            Classic {
                diffuse: Texture::Constant(Rgb::ZERO),
                ..Classic::default()
            },
        )
        .emitting(sky),
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
        Material::classic(
            "",
            Classic {
                diffuse: Texture::Constant(Rgb::ZERO),
                ..Classic::default()
            },
        )
        .emitting(floor_glow),
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

/// A translucent sheet (kdt, no kd) seen from above shows kdt/π·|N·L|·I/r² of a point light
/// below it, and nothing of one above it; without kdt the light below is not seen.
#[test]
fn a_translucent_sheet_passes_the_light_behind_it() {
    let kdt = Rgb::new(0.5, 0.3, 0.1);
    let sheet = |kdt: Rgb, light: Vec3| {
        let mut scene = empty_scene();
        let m = add_material(
            &mut scene,
            Material::classic(
                "",
                Classic {
                    diffuse_transmission: Texture::Constant(kdt),
                    ..diffuse_classic(Rgb::ZERO)
                },
            ),
        );
        floor(&mut scene, 1.0, 4.0, m);
        scene
            .lights
            .push(Light::Point(crate::scene::lights::PointLight {
                position: light,
                intensity: Rgb::splat(20.0),
                spectrum: None,
            }));
        scene
    };
    let view = Ray::new(Vec3::new(0.3, 3.0, 0.2), Vec3::NEG_Y);
    let below = Vec3::new(0.0, -1.0, 0.0);
    let got = radiance(&sheet(kdt, below), view, WhittedOptions::default());
    let to = below - Vec3::new(0.3, 1.0, 0.2);
    let expected = kdt / PI * 20.0 * (-to.normalize().y) / to.length_squared();
    assert!(close(got, expected, 1e-4), "{got} vs {expected}");
    let above = Vec3::new(0.0, 2.0, 0.0);
    let got = radiance(&sheet(kdt, above), view, WhittedOptions::default());
    assert_eq!(got, Rgb::ZERO);
    let got = radiance(&sheet(Rgb::ZERO, below), view, WhittedOptions::default());
    assert_eq!(got, Rgb::ZERO);
}
