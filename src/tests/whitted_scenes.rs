//! The scenes of the Whitted tests, built in code, that both the library's tests
//! (`src/tests/whitted.rs`, answers along single rays) and the command line's
//! (`tests/whitted.rs`, which includes this file, rendered images) use. The including module
//! imports the scene types.

use super::{Camera, Classic, Geometry, Material, QuadMesh, Rgb, Scene, Shape, Texture, Vec3};

pub(crate) fn camera() -> Camera {
    Camera {
        position: Vec3::new(0.0, 4.0, 6.0),
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        fov_deg: 40.0,
        width: 64,
        height: 48,
        projection: Default::default(),
    }
}

pub(crate) fn empty_scene() -> Scene {
    Scene {
        media: Vec::new(),
        camera_medium: None,
        source: "test".into(),
        camera: camera(),
        materials: Vec::new(),
        shapes: Vec::new(),
        prototypes: Vec::new(),
        instances: Vec::new(),
        lights: Vec::new(),
        ambient: Rgb::ZERO,
        background: Rgb::ZERO,
        settings: Default::default(),
        setting_sources: Vec::new(),
        output: None,
        color_space: None,
        inputs: Vec::new(),
        environment: None,
        warnings: Vec::new(),
    }
}

pub(crate) fn add_material(scene: &mut Scene, m: Material) -> usize {
    scene.materials.push(m);
    scene.materials.len() - 1
}

/// A quad from four corners (normal (b-a) x (c-a)).
pub(crate) fn quad(scene: &mut Scene, corners: [Vec3; 4], material: usize) {
    scene.shapes.push(Shape {
        media: None,
        geometry: Geometry::Quads(QuadMesh {
            positions: corners.to_vec(),
            indices: vec![[0, 1, 2, 3]],
        }),
        material,
        alpha: None,
        motion: None,
    });
}

/// The plane y = `y` from -s to s, facing up.
pub(crate) fn floor(scene: &mut Scene, y: f32, s: f32, material: usize) {
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

pub(crate) fn diffuse(kd: Rgb) -> Material {
    Material::classic("", diffuse_classic(kd))
}

/// The classic terms of [`diffuse`].
pub(crate) fn diffuse_classic(kd: Rgb) -> Classic {
    Classic {
        diffuse: Texture::Constant(kd),
        specular: Rgb::ZERO,
        ..Classic::default()
    }
}
