//! The scene builder: the parser's target that keeps pbrt's graphics state and makes the
//! scene. Its side of each statement is in `statements.rs`, the world block's in the files
//! `mod.rs` names; here, what it holds and how the scene is finished.

use super::cost::{self, Cost};
use super::limits::Held;
use super::motion::Timing;
use super::options::CameraDef;
use super::state::{Block, GraphicsState};
use super::Loc;
use crate::control::MemoryBudget;
use crate::math::Rgb;
use crate::scene::environment::Environment;
use crate::scene::{
    Camera, Instance, Light, Material, Prototype, RenderSettings, Scene, SettingSource, Shape,
    Texture,
};
use glam::DMat4;
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Float textures: constants, textures raylink evaluates where a parameter takes one
/// (their value in the first channel), and classes it cannot evaluate.
#[derive(Clone, Debug)]
pub(super) enum FloatTexture {
    Constant(f64),
    Varying(Texture),
    Unsupported,
}

/// The graphics state, the rendering options, and the scene made so far.
pub(super) struct Builder {
    pub(super) state: GraphicsState,
    pub(super) stack: Vec<(Block, GraphicsState, Loc)>,
    pub(super) world: bool,
    pub(super) coordinate_systems: HashMap<String, DMat4>,
    pub(super) named_materials: HashMap<String, usize>,
    pub(super) textures: HashMap<String, Texture>,
    pub(super) float_textures: HashMap<String, FloatTexture>,
    pub(super) objects: HashMap<String, cost::Object>,
    /// The object being defined: its name and shapes (in the definition's world space).
    pub(super) object: Option<(String, Vec<Shape>)>,
    /// The objects placed so far, each once, and their placements.
    pub(super) prototypes: Vec<Prototype>,
    pub(super) instances: Vec<Instance>,
    pub(super) materials: Vec<Material>,
    pub(super) default_material: Option<usize>,
    pub(super) emissive: HashMap<(usize, [u32; 3], bool), usize>,
    /// Area lights' textures (`None`: a plain light), by their (radiance, two-sided) in
    /// the graphics state, which tells them apart.
    pub(super) area_textures: HashMap<([u32; 3], bool), Option<Texture>>,
    pub(super) shapes: Vec<Shape>,
    pub(super) lights: Vec<Light>,
    /// The media made (`MakeNamedMedium`), and each name's medium (`None`: left out).
    pub(super) media: Vec<crate::scene::media::Medium>,
    pub(super) medium_names: HashMap<String, Option<u32>>,
    /// The outside medium's name when `Camera` was given: the camera's medium.
    pub(super) camera_medium: String,
    pub(super) background: Rgb,
    pub(super) environment: Option<Arc<Environment>>,
    pub(super) camera: Option<CameraDef>,
    /// raylink's camera, made at WorldBegin.
    pub(super) camera_value: Option<Camera>,
    pub(super) resolution: (u32, u32),
    pub(super) settings: RenderSettings,
    /// Where the file gives each of `settings`, to report a bad value at its line.
    pub(super) setting_sources: Vec<SettingSource>,
    /// `Film "filename"`, if given.
    pub(super) output: Option<std::path::PathBuf>,
    /// The colour space in effect at the `Film` statement, when not sRGB.
    pub(super) film_color_space: Option<&'static crate::spectrum::ColorSpace>,
    /// The reflection applied to the whole world when pbrt's camera mirrors the image (see
    /// [`Builder::begin_world`]); identity otherwise.
    pub(super) mirror: DMat4,
    pub(super) warnings: Vec<String>,
    pub(super) warned: HashSet<String>,
    pub(super) source: PathBuf,
    /// Every file read besides the scene file: includes, meshes, textures, maps.
    pub(super) inputs: Vec<PathBuf>,
    /// `inputs`, to record each file once.
    pub(super) input_set: HashSet<PathBuf>,
    /// The files named that are not there, each an error naming its statement: reading
    /// goes on past them so that a scene missing several reports every one.
    pub(super) missing: Vec<crate::error::Error>,
    /// The memory the reading may take (see `limits.rs`).
    pub(super) budget: MemoryBudget,
    /// What the reading holds against it, shared with the parser that holds the text.
    pub(super) held: Held,
    /// The geometry kept: the world's shapes and the object definitions.
    pub(super) geometry: Cost,
    /// `TransformTimes` and the camera's shutter.
    pub(super) timing: Timing,
}

impl Builder {
    /// A builder for the scene file `source`, holding its geometry to `budget` beside what
    /// the parser holds.
    pub(super) fn new(source: &Path, budget: MemoryBudget, held: Held) -> Builder {
        Builder {
            state: GraphicsState::default(),
            stack: Vec::new(),
            world: false,
            coordinate_systems: HashMap::new(),
            named_materials: HashMap::new(),
            textures: HashMap::new(),
            float_textures: HashMap::new(),
            objects: HashMap::new(),
            object: None,
            prototypes: Vec::new(),
            instances: Vec::new(),
            materials: Vec::new(),
            default_material: None,
            emissive: HashMap::new(),
            area_textures: HashMap::new(),
            shapes: Vec::new(),
            lights: Vec::new(),
            media: Vec::new(),
            medium_names: HashMap::new(),
            camera_medium: String::new(),
            background: Rgb::ZERO,
            environment: None,
            camera: None,
            camera_value: None,
            resolution: (1280, 720),
            settings: RenderSettings::default(),
            setting_sources: Vec::new(),
            output: None,
            film_color_space: None,
            mirror: DMat4::IDENTITY,
            warnings: Vec::new(),
            warned: HashSet::new(),
            missing: Vec::new(),
            source: source.to_path_buf(),
            inputs: Vec::new(),
            input_set: HashSet::new(),
            budget,
            held,
            geometry: Cost::default(),
            timing: Timing::default(),
        }
    }

    /// Records a warning once per distinct message.
    pub(super) fn warn(&mut self, loc: &Loc, msg: impl Into<String>) {
        let msg = msg.into();
        if self.warned.insert(msg.clone()) {
            self.warnings
                .push(format!("{}:{}: {msg}", loc.file.display(), loc.line));
        }
    }

    /// Records a file the scene reads (once, however often it is read).
    pub(super) fn add_input(&mut self, path: &Path) {
        if self.input_set.insert(path.to_path_buf()) {
            self.inputs.push(path.to_path_buf());
        }
    }

    /// Records `path` (named `file` by statement `st`) as an input, and whether it is there:
    /// one that is not is noted (see [`Builder::missing`]) for the caller to go on without.
    pub(super) fn find_input(&mut self, path: &Path, st: &str, file: &str, loc: &Loc) -> bool {
        self.add_input(path);
        let there = path.symlink_metadata().is_ok();
        if !there {
            self.missing
                .push(loc.error(format!("{st}: {file}: no such file")));
        }
        there
    }

    /// The reading's error: the missing files noted before `error`, then `error`.
    pub(super) fn failed(&mut self, error: crate::error::Error) -> crate::error::Error {
        if self.missing.is_empty() {
            return error;
        }
        let mut all = std::mem::take(&mut self.missing);
        all.push(error);
        crate::error::Error::Inputs(all)
    }

    /// The scene read: the camera made at WorldBegin, the shapes and the materials they use.
    pub(super) fn finish(mut self) -> crate::error::Result<Scene> {
        if let Some(e) = crate::error::Error::joined(std::mem::take(&mut self.missing)) {
            return Err(e);
        }
        let Some(camera) = self.camera_value.take() else {
            return Err(crate::error::Error::input(
                &self.source,
                "the file has no WorldBegin (truncated file?)",
            ));
        };
        if self.shapes.is_empty() && self.instances.is_empty() {
            return Err(crate::error::Error::input(
                &self.source,
                "the scene has no shapes",
            ));
        }
        // Keep only the materials shapes use (and those their mixes choose from, first), in
        // their order.
        let mut map = vec![usize::MAX; self.materials.len()];
        let mut materials = Vec::new();
        let placed = self.prototypes.iter_mut().flat_map(|p| &mut p.shapes);
        for s in self.shapes.iter_mut().chain(placed) {
            s.material = keep_material(&self.materials, s.material, &mut map, &mut materials);
        }
        let camera_medium = match self.medium_names.get(&self.camera_medium) {
            _ if self.camera_medium.is_empty() => None,
            Some(m) => *m,
            None => {
                return Err(crate::error::Error::input(
                    &self.source,
                    format!(
                        "Camera: its MediumInterface names \"{}\", but no MakeNamedMedium made it",
                        self.camera_medium
                    ),
                ))
            }
        };
        Ok(Scene {
            media: std::mem::take(&mut self.media),
            camera_medium,
            source: self.source.clone(),
            camera,
            materials,
            shapes: self.shapes,
            prototypes: self.prototypes.into_iter().map(Arc::new).collect(),
            instances: self.instances,
            lights: self.lights,
            ambient: Rgb::ZERO,
            background: self.background,
            environment: self.environment,
            settings: self.settings,
            setting_sources: self.setting_sources,
            output: self.output,
            color_space: self.film_color_space,
            inputs: std::iter::once(self.source.clone())
                .chain(self.inputs)
                .collect(),
            warnings: self.warnings,
        })
    }
}

/// The index of `materials[i]` among the `kept` materials, adding it (after the materials
/// it mixes, so that a mix refers only to materials before it) if `map` has none yet.
fn keep_material(
    materials: &[Material],
    i: usize,
    map: &mut [usize],
    kept: &mut Vec<Material>,
) -> usize {
    if map[i] == usize::MAX {
        let mut m = materials[i].clone();
        if let crate::scene::Surface::Mix(mix) = &mut m.surface {
            // The readers build mixes of materials defined before them: no cycle.
            for j in &mut mix.materials {
                *j = keep_material(materials, *j, map, kept);
            }
        }
        map[i] = kept.len();
        kept.push(m);
    }
    map[i]
}
