//! Environment portals: the window room renders the same with and without its portal, with
//! less noise with it; pbrt-v4's `"point3 portal"` is read (and kept by `convert`); portals
//! that are not rectangles are refused with one line.

#[path = "common/render.rs"]
mod render_common;

mod common;

use common::{assert_clean_failure_of, raylink};
use raylink::image::Image;
use raylink::math::Vec3;
use raylink::scene::Scene;
use raylink::{Backend, Technique};
use render_common::{boxed, image, View};
use std::path::Path;
use std::sync::Arc;

mod agreement;

fn manifest(p: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(p)
}

fn render(scene: &Scene, seed: u64) -> Image {
    image(
        scene,
        Technique::Path(boxed(5, 16)),
        View::of(scene, seed, None, Backend::Embree),
    )
}

/// The window room (its sky entering through a portal on the window) and the same room
/// without the portal: path tracing agrees (8 seeds each, 48×36, every pixel compared);
/// the portal lowers the variance of the pixels the sky lights most. A portal whose
/// density is off by a constant factor fails the agreement.
#[test]
fn the_portal_changes_the_noise_not_the_image() {
    let mut with = Scene::load(&manifest("scenes/window-room.toml")).unwrap();
    let portal = with.environment.as_ref().and_then(|e| e.portal.clone());
    assert!(portal.is_some(), "the window room has a portal");
    with.camera.width = 48;
    with.camera.height = 36;
    let mut without = with.clone();
    let mut env = (**without.environment.as_ref().unwrap()).clone();
    env.portal = None;
    without.environment = Some(Arc::new(env));
    let results = agreement::over_seeds(
        [("portal", &with), ("no portal", &without)],
        |scene, seed| render(scene, seed),
    );
    agreement::assert_agree(&results, |_, _, _| true);
    // The variance of the mean summed over the image, with and without.
    let noise = |k: usize| results[k].2.iter().sum::<f64>();
    let ratio = noise(0) / noise(1);
    eprintln!("variance with the portal / without: {ratio:.3}");
    assert!(ratio < 0.9, "the portal did not lower the noise: {ratio}");
}

const PBRT_ROOM: &str = "LookAt 0 1 3  0 1 0  0 1 0\nCamera \"perspective\" \"float fov\" 60\n\
    Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\nWorldBegin\n\
    LightSource \"infinite\" \"string filename\" \"sky.exr\" PORTAL\n\
    Shape \"bilinearmesh\" \"point3 P\" [-2 0 -2  2 0 -2  -2 0 2  2 0 2]\n";

fn write_sky(dir: &Path) {
    let mut sky = Image::new(8, 8);
    sky.pixels.fill(raylink::math::Rgb::ONE);
    raylink::write_image(&dir.join("sky.exr"), &sky, &[], &Default::default()).unwrap();
}

/// pbrt-v4's portal (four points in world space) is read as it is given, and `raylink
/// convert` writes it into the TOML scene, which reads back the same portal.
#[test]
fn pbrt_portals_are_read_and_converted() {
    let dir = tempfile::tempdir().unwrap();
    write_sky(dir.path());
    let file = dir.path().join("room.pbrt");
    let corners = "[-1 0.5 -2  -1 1.5 -2  1 1.5 -2  1 0.5 -2]";
    std::fs::write(
        &file,
        PBRT_ROOM.replace("PORTAL", &format!("\"point3 portal\" {corners}")),
    )
    .unwrap();
    let scene = Scene::load(&file).unwrap_or_else(|e| panic!("{e}"));
    let portal = scene.environment.as_ref().unwrap().portal.clone().unwrap();
    // pbrt's camera is left-handed, so the reader mirrors the world across the camera's
    // x; the portal is mirrored with it, its corners listed the other way round so that
    // it faces out as in pbrt-v4: (corner 3 - corner 0) x (corner 1 - corner 0) is +z.
    let want = [
        Vec3::new(1.0, 0.5, -2.0),
        Vec3::new(-1.0, 0.5, -2.0),
        Vec3::new(-1.0, 1.5, -2.0),
        Vec3::new(1.0, 1.5, -2.0),
    ];
    assert_eq!(portal.corners, want);
    assert!((portal.normal() - Vec3::Z).length() < 1e-6);
    let toml = dir.path().join("room.toml");
    let out = raylink(&[
        "convert",
        file.to_str().unwrap(),
        "-o",
        toml.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", common::stderr(&out));
    let converted = Scene::load(&toml).unwrap_or_else(|e| panic!("{e}"));
    let back = converted
        .environment
        .as_ref()
        .unwrap()
        .portal
        .clone()
        .unwrap();
    assert_eq!(back.corners, want);
}

/// A portal that is not a rectangle, or not four points, or one on a light without a
/// map, is refused: exit 2, one line naming the file and the problem, nothing written.
#[test]
fn portals_that_are_not_rectangles_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    write_sky(dir.path());
    let out_file = dir.path().join("never.exr");
    let run = |name: &str, text: String, needles: &[&str]| {
        let file = dir.path().join(name);
        std::fs::write(&file, text).unwrap();
        let out = raylink(&[
            "render",
            file.to_str().unwrap(),
            "-o",
            out_file.to_str().unwrap(),
            "--quiet",
        ]);
        let mut all = vec![name];
        all.extend_from_slice(needles);
        assert_clean_failure_of(name, &out, &all);
        assert!(!out_file.exists());
    };
    let toml = |portal: &str| {
        format!(
            "[camera]\nposition = [0, 1, 3]\nlook_at = [0, 1, 0]\nwidth = 8\nheight = 8\n\
             [world]\nenvironment = {{ file = \"sky.exr\", portal = {portal} }}\n\
             [materials.m]\n[[shapes]]\ntype = \"sphere\"\nmaterial = \"m\"\n"
        )
    };
    run(
        "kite.toml",
        toml("[[-1, 0.5, -2], [-1, 1.5, -2], [1.4, 1.5, -2], [1, 0.5, -2]]"),
        &["line 7", "environment.portal", "rectangle"],
    );
    run(
        "flat.toml",
        toml("[[0, 0, 0], [0, 0, 0], [1, 0, 0], [1, 0, 0]]"),
        &["line 7", "environment.portal", "no area"],
    );
    run(
        "three.toml",
        toml("[[0, 0, 0], [0, 1, 0], [1, 1, 0]]"),
        &["line 7", "portal"],
    );
    let pbrt = |portal: &str| PBRT_ROOM.replace("PORTAL", portal);
    run(
        "kite.pbrt",
        pbrt("\"point3 portal\" [-1 0.5 -2  -1 1.5 -2  1.4 1.5 -2  1 0.5 -2]"),
        &["line 5", "\"portal\"", "rectangle"],
    );
    run(
        "short.pbrt",
        pbrt("\"point3 portal\" [-1 0.5 -2  -1 1.5 -2  1 1.5 -2]"),
        &["line 5", "four points"],
    );
    run(
        "constant.pbrt",
        PBRT_ROOM
            .replace("\"string filename\" \"sky.exr\"", "\"rgb L\" [1 1 1]")
            .replace(
                "PORTAL",
                "\"point3 portal\" [-1 0.5 -2  -1 1.5 -2  1 1.5 -2  1 0.5 -2]",
            ),
        &["line 5", "needs an environment map"],
    );
}
