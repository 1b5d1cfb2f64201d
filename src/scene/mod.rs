//! The scene description. Every reader (native TOML, OBJ, later pbrt) produces a [`Scene`];
//! integrators never know which file it came from. Geometry is stored in world space:
//! readers apply transforms when they load.

pub mod camera;
mod geometry;
pub mod light;
mod material;
pub mod obj;
pub mod settings;
pub mod toml;

pub use camera::{Camera, MAX_RESOLUTION};
pub use geometry::{Geometry, QuadMesh, Shape, SurfacePoint, TriangleMesh};
pub use light::Light;
pub use material::{Material, Texture};
pub use settings::RenderSettings;

use crate::math::Rgb;
use std::path::{Path, PathBuf};

#[derive(Clone, Debug)]
pub struct Scene {
    /// The file the scene was read from (for messages and image metadata).
    pub source: PathBuf,
    pub camera: Camera,
    pub materials: Vec<Material>,
    /// Each shape refers to a material by index into `materials`.
    pub shapes: Vec<Shape>,
    /// Point and directional lights. Shapes whose material emits are area lights as well.
    pub lights: Vec<Light>,
    /// Whitted's ambient intensity Ia; a material's ambient coefficient scales it.
    pub ambient: Rgb,
    /// Radiance of rays that leave the scene.
    pub background: Rgb,
    /// Render settings given in the file; command-line options override them.
    pub settings: RenderSettings,
}

impl Scene {
    /// Reads a scene file, choosing the reader by extension.
    pub fn load(path: &Path) -> crate::Result<Scene> {
        match path.extension().and_then(|e| e.to_str()) {
            Some("toml") => toml::read(path),
            _ => Err(crate::Error::input(
                path,
                "unknown scene format: expected a .toml scene file",
            )),
        }
    }
}
