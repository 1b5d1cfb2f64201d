//! The scene description. Every reader (native TOML, OBJ, later pbrt) produces a [`Scene`];
//! integrators never know which file it came from. Geometry is stored in world space
//! (readers apply transforms when they load), except objects placed by instances, stored
//! once in their own space ([`instance`]).

pub mod alpha;
pub mod animation;
pub mod camera;
pub mod convert;
pub mod environment;
mod hash;
pub mod instance;
pub mod lights;
pub mod loop_subdivision;
pub mod materials;
pub mod media;
pub mod motion;
pub mod normal_detail;
pub mod obj;
pub mod pbrt;
pub mod ply;
pub mod portal;
pub mod settings;
pub mod shapes;
pub mod texture;
pub mod toml;

pub use crate::bsdf::{Coating, Conductor};
pub use alpha::Alpha;
pub use camera::{Camera, CameraProblem, Projection, MAX_COORDINATE, MAX_RESOLUTION};
pub use environment::Environment;
pub use hash::scene_hash;
pub use instance::{Instance, Prototype};
pub use lights::Light;
pub use materials::{Classic, Material, Mix, RoughnessMap, Surface};
pub use normal_detail::NormalDetail;
pub use portal::Portal;
pub use settings::{SettingSource, Settings as RenderSettings};
pub use shapes::{
    lerp, sphere_uv, Geometry, Primitives, QuadMesh, Shape, ShapeModel, Sphere, SurfacePoint,
    Tangents, TriangleMesh, UvMap,
};
pub use texture::Texture;

use crate::math::{Rgb, Vec3};
use camera::show;
use std::path::{Path, PathBuf};
use std::sync::Arc;

#[derive(Clone, Debug)]
pub struct Scene {
    /// The file the scene was read from (for messages and image metadata).
    pub source: PathBuf,
    pub camera: Camera,
    pub materials: Vec<Material>,
    /// Each shape refers to a material by index into `materials`.
    pub shapes: Vec<Shape>,
    /// Objects placed by instances, each stored once in its own space.
    pub prototypes: instance::Prototypes,
    /// Placements of `prototypes`.
    pub instances: Vec<Instance>,
    /// Point and directional lights. Shapes whose material emits are area lights as well.
    pub lights: Vec<Light>,
    /// Participating media; shapes' [`media::MediumInterface`]s and `camera_medium` refer
    /// to them by index.
    pub media: Vec<media::Medium>,
    /// The medium the camera sits in (`None`: vacuum).
    pub camera_medium: Option<u32>,
    /// Whitted's ambient intensity Ia; a material's ambient coefficient scales it.
    pub ambient: Rgb,
    /// Radiance of rays that leave the scene, where `environment` is `None`.
    pub background: Rgb,
    /// An environment map lighting the scene from infinitely far away; rays that leave the
    /// scene take their radiance from it instead of `background`.
    pub environment: Option<Arc<Environment>>,
    /// Render settings given in the file; command-line options override them.
    pub settings: RenderSettings,
    /// Where the file gives each of its settings (for messages).
    pub setting_sources: Vec<SettingSource>,
    /// The image file the scene names (pbrt's `Film "filename"`), as written in the file:
    /// like pbrt-v4, the command line takes it relative to the current directory. `raylink
    /// render` writes it when no `-o` is given.
    pub output: Option<PathBuf>,
    /// The colour space the scene asks its linear outputs in (pbrt-v4's `ColorSpace` in
    /// effect at its `Film`); `None`: linear sRGB. The command line's `--color-space` wins.
    pub color_space: Option<&'static crate::spectrum::ColorSpace>,
    /// Every file the scene was read from: the scene file, what it includes, its meshes,
    /// textures and environment map (so that no output overwrites one of them).
    pub inputs: Vec<PathBuf>,
    /// What the reader could not represent exactly and replaced by the closest substitute,
    /// one line each, `FILE:LINE: message` (for `raylink render` to print).
    pub warnings: Vec<String>,
}

impl Scene {
    /// The axis-aligned box around every shape, `None` without shapes.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for shape in &self.shapes {
            let (a, b) = shape.bounds_over_shutter();
            lo = lo.min(a);
            hi = hi.max(b);
        }
        let own_boxes: Vec<_> = self.prototypes.iter().map(|p| p.bounds()).collect();
        for instance in &self.instances {
            let own = own_boxes[instance.prototype as usize];
            if own.0.x <= own.1.x {
                let (a, b) = instance.world_bounds(own);
                lo = lo.min(a);
                hi = hi.max(b);
            }
        }
        (lo.x <= hi.x).then_some((lo, hi))
    }

    /// Triangles (a quad counts as two) and spheres stored: the scene's own shapes, each
    /// prototype once, and one per instance (its place in the top-level structure).
    pub fn primitive_count(&self) -> usize {
        self.shapes
            .iter()
            .map(|s| s.geometry.primitive_count())
            .sum::<usize>()
            + self
                .prototypes
                .iter()
                .map(|p| p.primitive_count())
                .sum::<usize>()
            + self.instances.len()
    }

    /// An error about a setting this scene's file gives, as one naming the file, line and
    /// key; any other error as it is.
    pub fn locate(&self, error: crate::error::Error) -> crate::error::Error {
        match error {
            crate::error::Error::Setting { name, detail } => {
                match self.setting_sources.iter().find(|s| s.setting == name) {
                    Some(s) => crate::error::Error::input(
                        s.file.as_ref().unwrap_or(&self.source),
                        format!("line {}: {} {detail}", s.line, s.key),
                    ),
                    None => crate::error::Error::Setting { name, detail },
                }
            }
            other => other,
        }
    }

    /// Refuses a scene whose shapes or lights reach past [`MAX_COORDINATE`]: rays would start
    /// (or their lengths overflow) where the backends cannot trace them (Embree aborts).
    pub fn check_extent(&self) -> crate::error::Result<()> {
        let far = |v: Vec3| !v.is_finite() || v.abs().max_element() > MAX_COORDINATE;
        if let Some((lo, hi)) = self.bounds() {
            if far(lo) || far(hi) {
                return Err(crate::error::Error::input(
                    &self.source,
                    format!(
                        "the shapes reach from {} to {}: raylink traces scenes within \
                         {MAX_COORDINATE:e} units of the origin",
                        show(lo),
                        show(hi)
                    ),
                ));
            }
        }
        if let Some(p) = self
            .lights
            .iter()
            .filter_map(|l| l.position())
            .find(|&p| far(p))
        {
            return Err(crate::error::Error::input(
                &self.source,
                format!(
                    "a light at {}: raylink traces scenes within {MAX_COORDINATE:e} units of the \
                     origin",
                    show(p)
                ),
            ));
        }
        Ok(())
    }

    /// Reads a scene file, choosing the reader by extension.
    pub fn load(path: &Path) -> crate::error::Result<Scene> {
        Scene::load_with(path, &crate::control::Control::default())
    }

    /// [`load`](Self::load) under a job's controls: a cancel stops the reading (between
    /// statements of a pbrt file, between shapes of a TOML one) with
    /// [`Error::Cancelled`](crate::error::Error::Cancelled), and the memory budget bounds it while it
    /// reads: the geometry read so far with its intersection structures (a pbrt object
    /// instance counted before it is copied), and a pbrt file's text and tokens, are checked
    /// against it ([`Error::Memory`](crate::error::Error::Memory)). A pbrt scene's text has fixed
    /// limits besides ([`pbrt::MAX_SCENE_TEXT`], [`pbrt::MAX_INCLUDES`]).
    pub fn load_with(
        path: &Path,
        control: &crate::control::Control,
    ) -> crate::error::Result<Scene> {
        Scene::load_with_animation(path, control).map(|(scene, _)| scene)
    }

    /// [`Scene::load_with`], and the keyframes of a native TOML scene that has them, from
    /// one reading of the file.
    pub fn load_with_animation(
        path: &Path,
        control: &crate::control::Control,
    ) -> crate::error::Result<(Scene, Option<animation::Animation>)> {
        let phase = control.phase("reading", None, "");
        let (scene, animation) = match path.extension().and_then(|e| e.to_str()) {
            Some("toml") => animation::read_with_animation(path, control),
            Some("pbrt") => pbrt::read(path, control).map(|s| (s, None)),
            _ => Err(crate::error::Error::input(
                path,
                "unknown scene format: expected a .toml or .pbrt scene file",
            )),
        }?;
        scene.check_extent()?;
        let placed = if scene.has_instances() {
            format!(
                ", {} instances of {} objects",
                scene.instances.len(),
                scene.prototypes.len()
            )
        } else {
            String::new()
        };
        phase.end(&format!(
            "{}: {} shapes, {} primitives{placed}",
            path.display(),
            scene.shapes.len(),
            scene.primitive_count()
        ));
        Ok((scene, animation))
    }
}

/// Why a mesh file's normal cannot be used (not finite, zero, or of a length that overflows),
/// as the native format refuses an inline mesh's: the rest of "the normal ... ".
pub(crate) fn check_normal(n: Vec3) -> Result<(), String> {
    if !n.is_finite() {
        Err(format!("must be finite, got {}", show(n)))
    } else if !n.length().is_finite() {
        Err(format!("has a length that overflows, got {}", show(n)))
    } else if n.length_squared() == 0.0 || n.normalize_or_zero() == Vec3::ZERO {
        Err(format!("must not be zero, got {}", show(n)))
    } else {
        Ok(())
    }
}
