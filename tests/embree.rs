//! The Embree wrapper on geometry whose answers are known in closed form.
#![cfg(feature = "embree")]

use raylink::accel::embree::{Device, Scene};
use raylink::math::{Ray, Vec3, Vec4};
use raylink::platform::{flush_denormals_enabled, set_flush_denormals};

fn ray(o: [f32; 3], d: [f32; 3]) -> Ray {
    Ray::new(Vec3::from(o), Vec3::from(d))
}

/// Geometry 0: triangle (0,0,0),(1,0,0),(0,1,0) in z = 0. Geometry 1: a sphere of radius 1 at
/// (5,0,0). Geometry 2: the unit quad in the plane x = -3, two quads (the second at y = 2).
fn scene(device: &Device) -> Scene {
    let mut s = Scene::new(device).unwrap();
    let t = s
        .attach_triangles(&[Vec3::ZERO, Vec3::X, Vec3::Y], &[[0, 1, 2]])
        .unwrap();
    let sp = s.attach_spheres(&[Vec4::new(5.0, 0.0, 0.0, 1.0)]).unwrap();
    let quad = |y: f32| {
        [
            Vec3::new(-3.0, y, 0.0),
            Vec3::new(-3.0, y, 1.0),
            Vec3::new(-3.0, y + 1.0, 1.0),
            Vec3::new(-3.0, y + 1.0, 0.0),
        ]
    };
    let positions: Vec<Vec3> = quad(0.0).into_iter().chain(quad(2.0)).collect();
    let q = s
        .attach_quads(&positions, &[[0, 1, 2, 3], [4, 5, 6, 7]])
        .unwrap();
    assert_eq!((t, sp, q), (0, 1, 2));
    s.commit().unwrap();
    s
}

#[test]
fn triangle_hit_reports_t_barycentrics_ids_and_winding_normal() {
    let device = Device::new().unwrap();
    let s = scene(&device);
    let hit = s
        .intersect(&ray([0.25, 0.125, 2.0], [0.0, 0.0, -1.0]))
        .expect("hit");
    assert!((hit.t - 2.0).abs() < 1e-6, "t = {}", hit.t);
    // u weights vertex 1 (x axis), v vertex 2 (y axis).
    assert!(
        (hit.u - 0.25).abs() < 1e-6 && (hit.v - 0.125).abs() < 1e-6,
        "{hit:?}"
    );
    assert_eq!((hit.geom_id, hit.prim_id), (0, 0));
    // (v1 - v0) x (v2 - v0) = x × y = +z.
    let n = hit.ng.normalize();
    assert!((n - Vec3::Z).length() < 1e-6, "ng = {}", hit.ng);
}

#[test]
fn misses_and_range_limits() {
    let device = Device::new().unwrap();
    let s = scene(&device);
    assert!(s
        .intersect(&ray([0.75, 0.75, 2.0], [0.0, 0.0, -1.0]))
        .is_none());
    assert!(s
        .intersect(&ray([0.25, 0.25, 2.0], [0.0, 0.0, 1.0]))
        .is_none());
    let mut short = ray([0.25, 0.25, 2.0], [0.0, 0.0, -1.0]);
    short.tmax = 1.5;
    assert!(s.intersect(&short).is_none());
    short.tmax = 2.5;
    assert!(s.intersect(&short).is_some());
}

#[test]
fn sphere_hits_from_outside_and_inside_with_outward_normal() {
    let device = Device::new().unwrap();
    let s = scene(&device);
    let outside = s
        .intersect(&ray([5.0, 0.0, 4.0], [0.0, 0.0, -1.0]))
        .expect("hit");
    assert_eq!(outside.geom_id, 1);
    assert!((outside.t - 3.0).abs() < 1e-5, "t = {}", outside.t);
    assert!((outside.ng.normalize() - Vec3::Z).length() < 1e-4);
    let inside = s
        .intersect(&ray([5.0, 0.0, 0.0], [1.0, 0.0, 0.0]))
        .expect("hit");
    assert!((inside.t - 1.0).abs() < 1e-5, "t = {}", inside.t);
    assert!(
        (inside.ng.normalize() - Vec3::X).length() < 1e-4,
        "ng = {}",
        inside.ng
    );
}

#[test]
fn quads_report_their_primitive() {
    let device = Device::new().unwrap();
    let s = scene(&device);
    let first = s
        .intersect(&ray([0.0, 0.5, 0.5], [-1.0, 0.0, 0.0]))
        .expect("hit");
    let second = s
        .intersect(&ray([0.0, 2.5, 0.5], [-1.0, 0.0, 0.0]))
        .expect("hit");
    assert_eq!((first.geom_id, first.prim_id), (2, 0));
    assert_eq!((second.geom_id, second.prim_id), (2, 1));
    assert!((first.t - 3.0).abs() < 1e-6);
    // Winding (0,0,0)->(0,0,1)->(0,1,1): (v1-v0) x (v2-v0) = z × (y+z) = -x.
    assert!(
        (first.ng.normalize() + Vec3::X).length() < 1e-5,
        "ng = {}",
        first.ng
    );
    assert!(s
        .intersect(&ray([0.0, 1.5, 0.5], [-1.0, 0.0, 0.0]))
        .is_none());
}

#[test]
fn occlusion_respects_segment_ends() {
    let device = Device::new().unwrap();
    let s = scene(&device);
    let through = Ray::segment(Vec3::new(0.25, 0.25, 1.0), Vec3::new(0.25, 0.25, -1.0));
    assert!(s.occluded(&through));
    let before = Ray::segment(Vec3::new(0.25, 0.25, 1.0), Vec3::new(0.25, 0.25, 0.5));
    assert!(!s.occluded(&before));
    let beside = Ray::segment(Vec3::new(2.0, 2.0, 1.0), Vec3::new(2.0, 2.0, -1.0));
    assert!(!s.occluded(&beside));
}

#[test]
fn uncommitted_changes_hide_the_scene_until_commit() {
    let device = Device::new().unwrap();
    let mut s = scene(&device);
    s.attach_spheres(&[Vec4::new(0.0, 0.0, -5.0, 1.0)]).unwrap();
    let r = ray([0.25, 0.125, 2.0], [0.0, 0.0, -1.0]);
    assert!(s.intersect(&r).is_none());
    s.commit().unwrap();
    assert!(s.intersect(&r).is_some());
}

#[test]
fn invalid_calls_surface_as_errors() {
    let err = Device::with_config("threads=banana")
        .err()
        .expect("bad config is an error");
    assert!(err.to_string().contains("embree"), "{err}");
    let device = Device::new().unwrap();
    let mut s = Scene::new(&device).unwrap();
    let err = s
        .attach_triangles(&[Vec3::ZERO, Vec3::X, Vec3::Y], &[[0, 1, 3]])
        .unwrap_err();
    assert!(err.to_string().contains("out of range"), "{err}");
    assert!(s.attach_spheres(&[Vec4::new(0.0, 0.0, 0.0, -1.0)]).is_err());
    assert!(s
        .attach_triangles(&[Vec3::NAN, Vec3::X, Vec3::Y], &[[0, 1, 2]])
        .is_err());
}

#[test]
fn queries_agree_across_threads() {
    let device = Device::new().unwrap();
    let s = scene(&device);
    let rays: Vec<Ray> = (0..1000)
        .map(|i| {
            let a = i as f32 * 0.0137;
            ray([0.3 * a.cos(), 0.3 * a.sin() + 0.3, 2.0], [0.0, 0.0, -1.0])
        })
        .collect();
    let serial: Vec<_> = rays.iter().map(|r| s.intersect(r)).collect();
    let parallel: Vec<_> = std::thread::scope(|scope| {
        let handles: Vec<_> = rays
            .chunks(250)
            .map(|chunk| scope.spawn(|| chunk.iter().map(|r| s.intersect(r)).collect::<Vec<_>>()))
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap())
            .collect()
    });
    assert_eq!(serial, parallel);
}

#[test]
fn flush_to_zero_is_set_per_thread() {
    std::thread::spawn(|| {
        assert!(!flush_denormals_enabled());
        set_flush_denormals();
        assert!(flush_denormals_enabled());
    })
    .join()
    .unwrap();
}

#[test]
fn version_is_the_installed_embree() {
    let v = Device::new().unwrap().version();
    assert!(v.starts_with("3.") || v.starts_with("4."), "{v}");
}
