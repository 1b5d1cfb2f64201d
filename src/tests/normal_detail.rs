//! Normal maps and bump maps against geometry: a flat plane whose normal map or bump map
//! encodes sinusoidal ridges shades as the plane displaced into those ridges.

use super::whitted::scenes::{add_material, diffuse, empty_scene};
use crate::accel::{self, Backend};
use crate::control::Control;
use crate::image::Image;
use crate::integrators::whitted::{Whitted, WhittedOptions};
use crate::math::{Ray, Rgb, Rng, Vec2, Vec3};
use crate::scene::texture::{Encoding, ImageTexture, UvMapping};
use crate::scene::{Geometry, Light, NormalDetail, Scene, Shape, Sphere, Texture, TriangleMesh};
use crate::transport::{Context, Integrator, RayStats};
use std::f32::consts::TAU;
use std::sync::Arc;

/// Ridges h(x) = A sin(kx) across the square [-1, 1]² of the plane y = 0: slopes up to
/// A·k = 0.25 (14°).
const A: f32 = 0.02;
const K: f32 = TAU / 0.5;

fn height(x: f32) -> f32 {
    A * (K * x).sin()
}

fn slope(x: f32) -> f32 {
    A * K * (K * x).cos()
}

fn true_normal(x: f32) -> Vec3 {
    Vec3::new(-slope(x), 1.0, 0.0).normalize()
}

/// The square as a grid of `n` × 2 cells, lifted by `lift(x)`, with (u, v) = ((x + 1)/2,
/// (z + 1)/2): u along +x, v along +z.
fn grid(n: usize, lift: impl Fn(f32) -> f32) -> Geometry {
    let mut mesh = TriangleMesh::default();
    for i in 0..=n {
        for j in 0..=2 {
            let u = i as f32 / n as f32;
            let v = j as f32 / 2.0;
            let x = 2.0 * u - 1.0;
            mesh.positions.push(Vec3::new(x, lift(x), 2.0 * v - 1.0));
            mesh.uvs.get_or_insert_with(Vec::new).push(Vec2::new(u, v));
        }
    }
    for i in 0..n as u32 {
        for j in 0..2u32 {
            let a = i * 3 + j;
            let (b, c, d) = (a + 3, a + 4, a + 1);
            // Wound so that the geometric normal faces +y.
            mesh.indices.push([a, d, c]);
            mesh.indices.push([a, c, b]);
        }
    }
    Geometry::Triangles(mesh)
}

/// A texture image of `width` × 2 texels whose column i holds `value(x)` at the texel
/// centre's x.
fn image(width: u32, value: impl Fn(f32) -> Rgb) -> Image {
    let mut img = Image::new(width, 2);
    for i in 0..width {
        let x = 2.0 * (i as f32 + 0.5) / width as f32 - 1.0;
        for j in 0..2 {
            img.pixels[(j * width + i) as usize] = value(x);
        }
    }
    img
}

fn texture(img: Image) -> Arc<ImageTexture> {
    Arc::new(ImageTexture::from_image(
        img,
        "generated".into(),
        Encoding::Linear,
        1.0,
        false,
        UvMapping::default(),
    ))
}

/// The tangent-space normal map of the ridges: ∂p/∂u is +x and the plane's normal +y, so
/// the frame's y axis is +y × +x = −z, and a world normal (nx, ny, 0) is (nx, 0, ny) there.
fn normal_map() -> NormalDetail {
    NormalDetail::Map(texture(image(1024, |x| {
        let n = true_normal(x);
        (Vec3::new(n.x, 0.0, n.y) + Vec3::ONE) * 0.5
    })))
}

fn bump_map() -> NormalDetail {
    NormalDetail::Bump(Texture::Image(texture(image(1024, |x| {
        Rgb::splat(height(x))
    }))))
}

/// A scene of one matte surface under a distant light 30° off the vertical, across the
/// ridges (so the shading follows their slope, and no ridge shadows another).
fn scene(geometry: Geometry, detail: Option<NormalDetail>) -> Scene {
    let mut scene = empty_scene();
    let m = add_material(
        &mut scene,
        crate::scene::Material {
            normal_detail: detail,
            ..diffuse(Rgb::splat(0.5))
        },
    );
    scene.shapes.push(Shape {
        media: None,
        geometry,
        material: m,
        alpha: None,
        motion: None,
    });
    let to_light = Vec3::new(0.5, 3f32.sqrt() / 2.0, 0.0);
    scene.lights.push(Light::Directional(
        crate::scene::lights::DirectionalLight::new(-to_light, Rgb::ONE),
    ));
    scene
}

/// Vertical rays down onto the square at `n` points across the ridges.
fn probes(n: usize) -> impl Iterator<Item = (f32, Ray)> {
    (0..n).map(move |i| {
        let x = -0.9 + 1.8 * (i as f32 + 0.5) / n as f32;
        (x, Ray::new(Vec3::new(x, 1.0, 0.13), Vec3::NEG_Y))
    })
}

/// The shading normal each probe finds.
fn shading_normals(scene: &Scene, n: usize) -> Vec<(f32, Vec3)> {
    let accel = accel::build(scene, Backend::Embree, &Control::default()).unwrap();
    let ctx = Context::new(scene, accel.as_ref());
    probes(n)
        .map(|(x, ray)| {
            let sp = ctx.intersect(&ray, &mut RayStats::default()).unwrap();
            (x, sp.ns)
        })
        .collect()
}

/// Whitted's radiance along each probe.
fn radiances(scene: &Scene, n: usize) -> Vec<f32> {
    let accel = accel::build(scene, Backend::Embree, &Control::default()).unwrap();
    let ctx = Context::new(scene, accel.as_ref());
    let whitted = Whitted::new(WhittedOptions::default());
    probes(n)
        .map(|(_, ray)| {
            let mut rng = Rng::for_key(0, &[]);
            whitted
                .radiance(&ctx, &ray, &mut rng, &mut RayStats::default())
                .radiance
                .x
        })
        .collect()
}

fn worst_angle_deg(found: &[(f32, Vec3)]) -> f32 {
    found
        .iter()
        .map(|&(x, n)| n.dot(true_normal(x)).clamp(-1.0, 1.0).acos().to_degrees())
        .fold(0.0, f32::max)
}

fn flat() -> Geometry {
    grid(1, |_| 0.0)
}

#[test]
fn a_normal_map_gives_the_ridges_normals() {
    let found = shading_normals(&scene(flat(), Some(normal_map())), 200);
    let worst = worst_angle_deg(&found);
    assert!(worst < 0.5, "worst angle to the ridges' normal {worst:.3}°");
    // Without the map the plane's normal is up to 14° off: the comparison can fail.
    let plain = worst_angle_deg(&shading_normals(&scene(flat(), None), 200));
    assert!(plain > 10.0, "{plain}");
}

#[test]
fn a_bump_map_gives_the_ridges_normals() {
    let found = shading_normals(&scene(flat(), Some(bump_map())), 200);
    let worst = worst_angle_deg(&found);
    // The bump map differentiates the bilinear height: about 1% of the slope off.
    assert!(worst < 0.5, "worst angle to the ridges' normal {worst:.3}°");
}

/// The shading of the plane with either map matches the displaced geometry (2,000 facets
/// across the ridges, so its facets' normals are within 0.2° of the true ones) within 1%.
#[test]
fn a_mapped_plane_shades_as_the_displaced_plane() {
    let n = 120;
    let displaced = radiances(&scene(grid(2000, height), None), n);
    let flat_plane = radiances(&scene(flat(), None), n);
    for (name, detail) in [("normal map", normal_map()), ("bump map", bump_map())] {
        let mapped = radiances(&scene(flat(), Some(detail)), n);
        let worst = mapped
            .iter()
            .zip(&displaced)
            .map(|(a, b)| (a - b).abs() / b)
            .fold(0.0, f32::max);
        println!("{name}: worst relative difference {worst:.5}");
        assert!(worst < 0.01, "{name}: {worst}");
    }
    let plain = flat_plane
        .iter()
        .zip(&displaced)
        .map(|(a, b)| (a - b).abs() / b)
        .fold(0.0, f32::max);
    assert!(
        plain > 0.1,
        "the flat plane is {plain} off: the test cannot tell"
    );
}

/// Bump mapping on a sphere of radius 1 with a displacement h(θ) = 0.3 + 0.1 cos 2θ that
/// varies with latitude: the shading normal is the normal of the displaced sphere
/// r = 1 + h(θ), ∝ (1 + h) r̂ − h′(θ) θ̂. The tangents' growth with the displacement (the
/// ∂n/∂v term) matters: without it the normal turns up to 2.6° further.
#[test]
fn a_bump_map_on_a_sphere_gives_the_displaced_spheres_normals() {
    let h = |theta: f32| 0.3 + 0.1 * (2.0 * theta).cos();
    let dh = |theta: f32| -0.2 * (2.0 * theta).sin();
    // Rows along v, v = 0 the bottom row; θ = πv.
    let rows = 2048;
    let mut img = Image::new(2, rows);
    for j in 0..rows {
        let v = 1.0 - (j as f32 + 0.5) / rows as f32;
        let value = Rgb::splat(h(std::f32::consts::PI * v));
        img.pixels[(j * 2) as usize] = value;
        img.pixels[(j * 2 + 1) as usize] = value;
    }
    let mut scene = scene(
        Geometry::Sphere(Sphere {
            center: Vec3::ZERO,
            radius: 1.0,
        }),
        Some(NormalDetail::Bump(Texture::Image(texture(img)))),
    );
    scene.lights.clear();
    let accel = accel::build(&scene, Backend::Embree, &Control::default()).unwrap();
    let ctx = Context::new(&scene, accel.as_ref());
    let (mut worst, mut turn) = (0.0f32, 0.0f32);
    for i in 0..60 {
        let a = i as f32 * 0.37;
        let target = Vec3::new(a.cos() * 0.6, (a * 1.3).sin() * 0.65, 0.0);
        let ray = Ray::new(target + Vec3::new(0.0, 0.0, 5.0), Vec3::NEG_Z);
        let sp = ctx.intersect(&ray, &mut RayStats::default()).unwrap();
        let r = sp.p.normalize();
        let theta = r.y.clamp(-1.0, 1.0).acos();
        let rho = (r.x * r.x + r.z * r.z).sqrt();
        let t_hat = Vec3::new(r.y * r.x / rho, -rho, r.y * r.z / rho);
        let expected = (r * (1.0 + h(theta)) - t_hat * dh(theta)).normalize();
        let without_growth = (r - t_hat * dh(theta)).normalize();
        worst = worst.max(sp.ns.dot(expected).clamp(-1.0, 1.0).acos().to_degrees());
        turn = turn.max(
            expected
                .dot(without_growth)
                .clamp(-1.0, 1.0)
                .acos()
                .to_degrees(),
        );
    }
    assert!(
        worst < 0.3,
        "worst angle to the displaced sphere's normal {worst}°"
    );
    assert!(turn > 2.0, "the growth term turns the normal only {turn}°");
}
