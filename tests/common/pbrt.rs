//! What the pbrt-v4 reader's tests share: small scenes written to files, the Bitterli box,
//! and a Whitted render. Included by tests/pbrt*.rs with `#[path]`; each uses a part.
#![allow(dead_code)]

use raylink::image::Image;
use raylink::math::Vec3;
use raylink::scene::Scene;
use raylink::{Backend, Control, Job, Renderer, Settings, Technique, TechniqueKind};
use std::path::{Path, PathBuf};

pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

pub fn bitterli() -> PathBuf {
    root().join("scenes/cornell-box-bitterli/scene-v4.pbrt")
}

/// Whitted with its defaults and uniform 2x2 supersampling, at `size`x`size`.
pub fn whitted_render(scene: &Scene, size: u32) -> Image {
    let technique = Technique::create(&Settings {
        integrator: Some(TechniqueKind::Whitted),
        spp: Some(4),
        ..Settings::default()
    })
    .unwrap();
    let job = Job {
        width: size,
        height: size,
        region: None,
        seed: 7,
        threads: Some(2),
        accel: Backend::Embree,
        ..Job::new(scene, technique)
    };
    let control = Control::default();
    Renderer::new(scene.clone(), job, &control)
        .unwrap()
        .render(&control)
        .unwrap()
        .image
}

/// A camera whose image is not mirrored with respect to raylink's (pbrt's `Scale -1 1 1`
/// idiom), so the world is not mirrored either.
pub const HEADER: &str = "Scale -1 1 1\nLookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\nWorldBegin\n";

pub const TRI: &str =
    "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] \"integer indices\" [0 1 2]\n";

/// Loads pbrt text written to a file `main.pbrt` in `dir` (with `files` beside it).
pub fn load_in(dir: &Path, text: &str, files: &[(&str, &[u8])]) -> raylink::Result<Scene> {
    for (name, data) in files {
        let p = dir.join(name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, data).unwrap();
    }
    let main = dir.join("main.pbrt");
    std::fs::write(&main, text).unwrap();
    Scene::load(&main)
}

pub fn load(text: &str) -> Scene {
    let dir = tempfile::tempdir().unwrap();
    load_in(dir.path(), text, &[]).unwrap_or_else(|e| panic!("{e}"))
}

pub fn world(body: &str) -> Scene {
    load(&format!("{HEADER}{body}"))
}

/// Points equal within 1e-5.
pub fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}
