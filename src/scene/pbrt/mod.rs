//! The pbrt-v4 scene format (<https://pbrt.org/fileformat-v4>), read into a [`Scene`].
//!
//! `lexer` splits a file into tokens with positions, `params` checks parameter lists,
//! and `Loader` runs the statements against pbrt's graphics state (CTM, material, area
//! light, orientation, the attribute stack), baking every shape into world space. Object
//! instances are flattened into world-space copies.
//!
//! Syntax errors and invalid values are errors naming the file, line and column. What pbrt
//! has and raylink does not (other shape, material, light or texture types, parameters
//! raylink ignores) is reported once as a warning in [`Scene::warnings`] and replaced by the
//! closest substitute; docs/scene-format.md lists the mapping.
//!
//! Files: `statements.rs` runs each statement (and reads included files in place),
//! `limits.rs` bounds the text read and the memory taken (object instances are counted
//! before they are copied), `cursor.rs` reads a statement's arguments and parameter lists,
//! `state.rs` holds the graphics state and its stack, `options.rs` the rendering options and
//! the camera. The world block: `materials.rs`, `textures.rs`, `lights.rs` and
//! `shape_statement.rs` (the geometry itself from `shapes.rs`), their spectrum and texture
//! parameters from `param_values.rs`.

mod alpha;
mod cursor;
mod instances;
mod lexer;
mod lights;
mod limits;
mod materials;
mod motion;
mod options;
mod param_values;
mod params;
mod shape_statement;
mod shapes;
mod spectrum;
mod state;
mod statements;
mod textures;

use super::environment::Environment;
use super::{Camera, Instance, Light, Material, Prototype, Scene, Shape, Texture};
use crate::control::{CancelToken, Control, MemoryBudget};
use crate::error::Error;
use crate::math::Rgb;
use crate::scene::RenderSettings;
use glam::DMat4;
use options::CameraDef;
use params::ParamError;
use state::{Block, GraphicsState};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub(crate) use limits::Cost as GeometryCost;
pub use limits::{MAX_INCLUDES, MAX_INCLUDE_DEPTH, MAX_SCENE_TEXT};
pub(crate) use shapes::instance as placed_copies;

/// Reads a pbrt-v4 scene file (and the files it includes).
pub fn read(path: &Path, control: &Control) -> crate::error::Result<Scene> {
    let mut loader = Loader::new(path, control);
    let text = loader.read_text(path, None)?;
    loader.run_file(path, &text, None)?;
    loader.finish()
}

/// Reads pbrt-v4 scene text; `path` names it in messages and anchors relative paths.
pub fn from_str(text: &str, path: &Path) -> crate::error::Result<Scene> {
    from_str_with(text, path, &Control::default())
}

/// [`from_str`] under a job's controls: stopped between statements once the control's token
/// is cancelled, and refused (before the memory is taken) once the text being read and the
/// geometry read so far would need more than its memory budget.
pub fn from_str_with(text: &str, path: &Path, control: &Control) -> crate::error::Result<Scene> {
    let mut loader = Loader::new(path, control);
    loader.run_file(path, text, None)?;
    loader.finish()
}

/// Where a statement is: its file, line and column.
#[derive(Clone, Debug)]
struct Loc {
    file: Arc<PathBuf>,
    line: u32,
    col: u32,
}

impl Loc {
    fn error(&self, msg: impl std::fmt::Display) -> Error {
        Error::input(
            self.file.as_path(),
            format!("line {}, column {}: {msg}", self.line, self.col),
        )
    }

    fn at(&self, line: u32, col: u32) -> Loc {
        Loc {
            file: self.file.clone(),
            line,
            col,
        }
    }

    fn param_error(&self, e: ParamError) -> Error {
        self.at(e.line, e.col).error(e.msg)
    }

    fn dir(&self) -> PathBuf {
        self.file
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default()
    }
}

/// Float textures: constants, textures raylink evaluates where a parameter takes one
/// (their value in the first channel), and classes it cannot evaluate.
#[derive(Clone, Debug)]
enum FloatTexture {
    Constant(f64),
    Varying(Texture),
    Unsupported,
}

struct Loader {
    /// Files being read, outermost first (for include cycles).
    include_stack: Vec<PathBuf>,
    state: GraphicsState,
    stack: Vec<(Block, GraphicsState, Loc)>,
    world: bool,
    coordinate_systems: HashMap<String, DMat4>,
    named_materials: HashMap<String, usize>,
    textures: HashMap<String, Texture>,
    float_textures: HashMap<String, FloatTexture>,
    objects: HashMap<String, limits::Object>,
    /// The object being defined: its name and shapes (in the definition's world space).
    object: Option<(String, Vec<Shape>)>,
    /// The objects placed so far, each once, and their placements.
    prototypes: Vec<Prototype>,
    instances: Vec<Instance>,
    materials: Vec<Material>,
    default_material: Option<usize>,
    emissive: HashMap<(usize, [u32; 3], bool), usize>,
    /// Area lights' textures (`None`: a plain light), by their (radiance, two-sided) in
    /// the graphics state, which tells them apart.
    area_textures: HashMap<([u32; 3], bool), Option<Texture>>,
    shapes: Vec<Shape>,
    lights: Vec<Light>,
    background: Rgb,
    environment: Option<Arc<Environment>>,
    camera: Option<CameraDef>,
    /// raylink's camera, made at WorldBegin.
    camera_value: Option<Camera>,
    resolution: (u32, u32),
    settings: RenderSettings,
    /// The reflection applied to the whole world when pbrt's camera mirrors the image (see
    /// [`Loader::camera`]); identity otherwise.
    mirror: DMat4,
    warnings: Vec<String>,
    warned: HashSet<String>,
    source: PathBuf,
    /// Stops the reading between statements.
    cancel: CancelToken,
    /// Every file read besides the scene file: includes, meshes, textures, maps.
    inputs: Vec<PathBuf>,
    /// `inputs`, to record each file once.
    input_set: HashSet<PathBuf>,
    /// The memory the reading may take (see `limits.rs`).
    budget: MemoryBudget,
    /// What the reading has taken so far against its limits.
    usage: limits::Usage,
    /// `TransformTimes` and the camera's shutter.
    timing: motion::Timing,
}

impl Loader {
    fn new(path: &Path, control: &Control) -> Loader {
        Loader {
            include_stack: Vec::new(),
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
            background: Rgb::ZERO,
            environment: None,
            camera: None,
            camera_value: None,
            resolution: (1280, 720),
            settings: RenderSettings::default(),
            mirror: DMat4::IDENTITY,
            warnings: Vec::new(),
            warned: HashSet::new(),
            source: path.to_path_buf(),
            cancel: control.cancel.clone(),
            inputs: Vec::new(),
            input_set: HashSet::new(),
            budget: control.budget,
            usage: limits::Usage::default(),
            timing: motion::Timing::default(),
        }
    }

    /// Records a warning once per distinct message.
    fn warn(&mut self, loc: &Loc, msg: impl Into<String>) {
        let msg = msg.into();
        if self.warned.insert(msg.clone()) {
            self.warnings
                .push(format!("{}:{}: {msg}", loc.file.display(), loc.line));
        }
    }

    /// The scene read: the camera made at WorldBegin, the shapes and the materials they use.
    fn finish(mut self) -> crate::error::Result<Scene> {
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
        Ok(Scene {
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
            setting_sources: Vec::new(),
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
