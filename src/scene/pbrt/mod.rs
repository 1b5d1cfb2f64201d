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

mod lexer;
mod params;
mod shapes;
mod spectrum;
mod world;

use super::environment::Environment;
use super::{Camera, Light, Material, Scene, Shape, Texture, MAX_RESOLUTION};
use crate::image::filter::Filter;
use crate::math::Rgb;
use crate::scene::RenderSettings;
use crate::Error;
use glam::{DMat3, DMat4, DVec3};
use lexer::{Tok, Token};
use params::{ParamError, Params, Values};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Reads a pbrt-v4 scene file (and the files it includes).
pub fn read(path: &Path) -> crate::Result<Scene> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    from_str(&text, path)
}

/// Reads pbrt-v4 scene text; `path` names it in messages and anchors relative paths.
pub fn from_str(text: &str, path: &Path) -> crate::Result<Scene> {
    let mut loader = Loader::new(path);
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

/// An area light attached to the shapes that follow (`AreaLightSource`).
#[derive(Clone, Copy, Debug)]
struct AreaEmission {
    radiance: Rgb,
}

#[derive(Clone, Debug)]
struct GraphicsState {
    ctm: DMat4,
    reverse_orientation: bool,
    /// Index into `Loader::materials`; `None` is pbrt's default (diffuse, reflectance 0.5).
    material: Option<usize>,
    area: Option<AreaEmission>,
    /// `ActiveTransform EndTime`: transform statements only change the end transform,
    /// which raylink (no motion blur) ignores.
    end_time_only: bool,
}

impl Default for GraphicsState {
    fn default() -> Self {
        GraphicsState {
            ctm: DMat4::IDENTITY,
            reverse_orientation: false,
            material: None,
            area: None,
            end_time_only: false,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Block {
    Attribute,
    Transform,
    Object,
}

impl Block {
    fn begin(self) -> &'static str {
        match self {
            Block::Attribute => "AttributeBegin",
            Block::Transform => "TransformBegin",
            Block::Object => "ObjectBegin",
        }
    }
}

/// Float textures: only constants have a value raylink can use.
#[derive(Clone, Copy, Debug)]
enum FloatTexture {
    Constant(f64),
    Unsupported,
}

struct CameraDef {
    camera_to_world: DMat4,
    fov: f64,
    loc: Loc,
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
    objects: HashMap<String, Vec<Shape>>,
    /// The object being defined: its name and shapes (in the definition's world space).
    object: Option<(String, Vec<Shape>)>,
    materials: Vec<Material>,
    default_material: Option<usize>,
    emissive: HashMap<(usize, [u32; 3]), usize>,
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
}

impl Loader {
    fn new(path: &Path) -> Loader {
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
            materials: Vec::new(),
            default_material: None,
            emissive: HashMap::new(),
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

    fn run_file(&mut self, path: &Path, text: &str, from: Option<&Loc>) -> crate::Result<()> {
        let key = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
        if let Some(i) = self.include_stack.iter().position(|p| *p == key) {
            let chain: Vec<String> = self.include_stack[i..]
                .iter()
                .chain([&key])
                .map(|p| {
                    p.file_name()
                        .map_or(p.display().to_string(), |n| n.to_string_lossy().into())
                })
                .collect();
            let msg = format!("include cycle: {}", chain.join(" includes "));
            return Err(match from {
                Some(loc) => loc.error(msg),
                None => Error::input(path, msg),
            });
        }
        let file = Arc::new(path.to_path_buf());
        let tokens = lexer::tokenize(text).map_err(|e| {
            Error::input(
                path,
                format!("line {}, column {}: {}", e.line, e.col, e.msg),
            )
        })?;
        self.include_stack.push(key);
        let depth = self.stack.len();
        let mut cursor = Cursor {
            file,
            tokens: &tokens,
            i: 0,
        };
        while cursor.i < tokens.len() {
            self.statement(&mut cursor)?;
        }
        self.include_stack.pop();
        if from.is_none() && self.stack.len() > depth {
            let (block, _, loc) = self.stack.last().expect("non-empty");
            return Err(loc.error(format!(
                "{} is never closed: the file ends before its {}End (truncated file?)",
                block.begin(),
                &block.begin()[..block.begin().len() - 5]
            )));
        }
        Ok(())
    }

    fn statement(&mut self, c: &mut Cursor) -> crate::Result<()> {
        let t = &c.tokens[c.i];
        let loc = c.loc(t);
        let Tok::Word(keyword) = &t.tok else {
            return Err(loc.error(format!(
                "expected a statement keyword (such as Shape or WorldBegin), got {}",
                t.tok.describe()
            )));
        };
        let keyword = keyword.clone();
        c.i += 1;
        let kw = keyword.as_str();
        match kw {
            "AttributeBegin" => self.push(Block::Attribute, &loc),
            "AttributeEnd" => self.pop(Block::Attribute, &loc)?,
            "TransformBegin" => self.push(Block::Transform, &loc),
            "TransformEnd" => self.pop(Block::Transform, &loc)?,
            "ObjectBegin" => {
                let name = c.string(&loc, kw)?;
                if let Some((outer, _)) = &self.object {
                    return Err(loc.error(format!(
                        "ObjectBegin \"{name}\" inside the definition of \"{outer}\": \
                         object definitions cannot nest"
                    )));
                }
                self.require_world(&loc, kw)?;
                self.push(Block::Object, &loc);
                self.object = Some((name, Vec::new()));
            }
            "ObjectEnd" => {
                self.pop(Block::Object, &loc)?;
                if let Some((name, shapes)) = self.object.take() {
                    self.objects.insert(name, shapes);
                }
            }
            "ObjectInstance" => {
                let name = c.string(&loc, kw)?;
                self.require_world(&loc, kw)?;
                if self.object.is_some() {
                    return Err(loc.error(
                        "ObjectInstance inside an object definition (pbrt does not nest instances)",
                    ));
                }
                let Some(def) = self.objects.get(&name) else {
                    return Err(loc.error(format!("ObjectInstance: no object named \"{name}\"")));
                };
                let t = self.mirror * self.state.ctm;
                let copies: Vec<Shape> = def.iter().flat_map(|s| shapes::instance(s, &t)).collect();
                self.shapes.extend(copies);
            }
            "Identity" => self.set_ctm(&loc, |_| DMat4::IDENTITY),
            "Translate" => {
                let v = c.numbers(&loc, kw, 3)?;
                self.set_ctm(&loc, |m| {
                    m * DMat4::from_translation(DVec3::new(v[0], v[1], v[2]))
                });
            }
            "Scale" => {
                let v = c.numbers(&loc, kw, 3)?;
                self.set_ctm(&loc, |m| {
                    m * DMat4::from_scale(DVec3::new(v[0], v[1], v[2]))
                });
            }
            "Rotate" => {
                let v = c.numbers(&loc, kw, 4)?;
                let axis = DVec3::new(v[1], v[2], v[3]);
                if axis.length() == 0.0 {
                    return Err(loc.error("Rotate: the axis must not be zero"));
                }
                let r = DMat4::from_axis_angle(axis.normalize(), v[0].to_radians());
                self.set_ctm(&loc, |m| m * r);
            }
            "LookAt" => {
                let v = c.numbers(&loc, kw, 9)?;
                let look = look_at(
                    DVec3::new(v[0], v[1], v[2]),
                    DVec3::new(v[3], v[4], v[5]),
                    DVec3::new(v[6], v[7], v[8]),
                )
                .map_err(|m| loc.error(format!("LookAt: {m}")))?;
                self.set_ctm(&loc, |m| m * look);
            }
            "Transform" | "ConcatTransform" => {
                let v = c.matrix(&loc, kw)?;
                // pbrt lists the matrix column by column.
                let m = DMat4::from_cols_array(&v);
                if kw == "Transform" {
                    self.set_ctm(&loc, |_| m);
                } else {
                    self.set_ctm(&loc, |ctm| ctm * m);
                }
            }
            "CoordinateSystem" => {
                let name = c.string(&loc, kw)?;
                self.coordinate_systems.insert(name, self.state.ctm);
            }
            "CoordSysTransform" => {
                let name = c.string(&loc, kw)?;
                match self.coordinate_systems.get(&name) {
                    Some(&m) => self.state.ctm = m,
                    None => self.warn(
                        &loc,
                        format!("CoordSysTransform: unknown coordinate system \"{name}\"; ignored"),
                    ),
                }
            }
            "ActiveTransform" => {
                let Some(Tok::Word(which)) = c.peek().map(|t| t.tok.clone()) else {
                    return Err(loc.error("ActiveTransform takes StartTime, EndTime or All"));
                };
                c.i += 1;
                match which.as_str() {
                    "StartTime" | "All" => self.state.end_time_only = false,
                    "EndTime" => {
                        self.state.end_time_only = true;
                        self.warn(
                            &loc,
                            "ActiveTransform EndTime: motion blur is not supported; the end \
                             transforms are ignored",
                        );
                    }
                    other => {
                        return Err(loc.error(format!(
                            "ActiveTransform takes StartTime, EndTime or All, got `{other}`"
                        )))
                    }
                }
            }
            "TransformTimes" => {
                c.numbers(&loc, kw, 2)?;
                self.warn(
                    &loc,
                    "TransformTimes: motion blur is not supported; ignored",
                );
            }
            "ReverseOrientation" => {
                self.state.reverse_orientation = !self.state.reverse_orientation
            }
            "Camera" | "Film" | "Sampler" | "PixelFilter" | "Integrator" | "Accelerator"
            | "ColorSpace" | "Option" => {
                let ty = c.string(&loc, kw)?;
                let value = if kw == "Option" {
                    c.option_value()
                } else {
                    None
                };
                let p = c.params(&loc)?;
                if self.world {
                    return Err(loc.error(format!(
                        "{kw} must come before WorldBegin (it sets a rendering option)"
                    )));
                }
                self.option(kw, &ty, value, &p, &loc)?;
                self.report_unused(kw, &ty, &p, &loc);
            }
            "MakeNamedMedium" => {
                let name = c.string(&loc, kw)?;
                let _ = c.params(&loc)?;
                self.warn(
                    &loc,
                    format!("MakeNamedMedium \"{name}\": participating media are not supported; ignored"),
                );
            }
            "MediumInterface" => {
                c.string(&loc, kw)?;
                if matches!(c.peek().map(|t| &t.tok), Some(Tok::Str(_))) {
                    c.string(&loc, kw)?;
                }
                self.warn(
                    &loc,
                    "MediumInterface: participating media are not supported; ignored",
                );
            }
            "Attribute" => {
                let target = c.string(&loc, kw)?;
                let _ = c.params(&loc)?;
                self.warn(
                    &loc,
                    format!(
                        "Attribute \"{target}\": default parameters are not supported; ignored"
                    ),
                );
            }
            "WorldBegin" => {
                if self.world {
                    return Err(loc.error("WorldBegin appears twice"));
                }
                self.world = true;
                self.begin_world(&loc)?;
            }
            "WorldEnd" => {}
            "MakeNamedMaterial" => {
                let name = c.string(&loc, kw)?;
                let p = c.params(&loc)?;
                self.require_world(&loc, kw)?;
                let ty = p
                    .string("type")
                    .map_err(|e| loc.param_error(e))?
                    .ok_or_else(|| {
                        loc.error(format!(
                            "MakeNamedMaterial \"{name}\" needs a \"string type\" parameter"
                        ))
                    })?;
                let m = self.material(&ty, &name, &p, &loc)?;
                self.report_unused("MakeNamedMaterial", &ty, &p, &loc);
                self.named_materials.insert(name, self.materials.len());
                self.materials.push(m);
            }
            "Material" => {
                let ty = c.string(&loc, kw)?;
                let p = c.params(&loc)?;
                self.require_world(&loc, kw)?;
                let m = self.material(&ty, "", &p, &loc)?;
                self.report_unused(kw, &ty, &p, &loc);
                self.state.material = Some(self.materials.len());
                self.materials.push(m);
            }
            "NamedMaterial" => {
                let name = c.string(&loc, kw)?;
                self.require_world(&loc, kw)?;
                match self.named_materials.get(&name) {
                    Some(&i) => self.state.material = Some(i),
                    None => {
                        return Err(loc.error(format!(
                            "NamedMaterial: no material named \"{name}\" (define it with \
                             MakeNamedMaterial first)"
                        )))
                    }
                }
            }
            "Texture" => {
                let name = c.string(&loc, kw)?;
                let ty = c.string(&loc, kw)?;
                let class = c.string(&loc, kw)?;
                let p = c.params(&loc)?;
                self.require_world(&loc, kw)?;
                self.texture(&name, &ty, &class, &p, &loc)?;
                self.report_unused(kw, &class, &p, &loc);
            }
            "Shape" | "LightSource" | "AreaLightSource" => {
                let ty = c.string(&loc, kw)?;
                let p = c.params(&loc)?;
                self.require_world(&loc, kw)?;
                match kw {
                    "Shape" => self.shape(&ty, &p, &loc)?,
                    "LightSource" => self.light(&ty, &p, &loc)?,
                    _ => self.area_light(&ty, &p, &loc)?,
                }
                self.report_unused(kw, &ty, &p, &loc);
            }
            "Include" | "Import" => {
                let name = c.string(&loc, kw)?;
                let path = loc.dir().join(&name);
                if self.include_stack.len() > 64 {
                    return Err(loc.error(format!("{kw}: includes nest more than 64 deep")));
                }
                let text = std::fs::read_to_string(&path).map_err(|e| {
                    loc.error(format!(
                        "{kw} \"{name}\": cannot read {}: {e}",
                        path.display()
                    ))
                })?;
                self.run_file(&path, &text, Some(&loc))?;
            }
            other => {
                return Err(loc.error(format!("unknown statement `{other}`")));
            }
        }
        Ok(())
    }

    fn require_world(&self, loc: &Loc, what: &str) -> crate::Result<()> {
        if self.world {
            Ok(())
        } else {
            Err(loc.error(format!("{what} must come after WorldBegin")))
        }
    }

    fn set_ctm(&mut self, loc: &Loc, f: impl FnOnce(DMat4) -> DMat4) {
        if self.state.end_time_only {
            let _ = loc;
            return;
        }
        self.state.ctm = f(self.state.ctm);
    }

    fn push(&mut self, block: Block, loc: &Loc) {
        self.stack.push((block, self.state.clone(), loc.clone()));
    }

    fn pop(&mut self, block: Block, loc: &Loc) -> crate::Result<()> {
        let end = match block {
            Block::Attribute => "AttributeEnd",
            Block::Transform => "TransformEnd",
            Block::Object => "ObjectEnd",
        };
        match self.stack.pop() {
            None => Err(loc.error(format!("{end} without a matching {}", block.begin()))),
            Some((open, _, open_loc)) if open != block => Err(loc.error(format!(
                "{end} does not match the {} at line {}",
                open.begin(),
                open_loc.line
            ))),
            Some((_, saved_state, _)) => {
                if block == Block::Transform {
                    self.state.ctm = saved_state.ctm;
                } else {
                    self.state = saved_state;
                }
                Ok(())
            }
        }
    }

    fn report_unused(&mut self, statement: &str, ty: &str, p: &Params, loc: &Loc) {
        let unused: Vec<(String, u32)> = p.unused().map(|q| (q.name.clone(), q.line)).collect();
        for (name, line) in unused {
            self.warn(
                &loc.at(line, 1),
                format!("{statement} \"{ty}\": parameter \"{name}\" is not supported; ignored"),
            );
        }
    }

    // --------------------------------------------------------------------------------------
    // Rendering options.

    fn option(
        &mut self,
        kw: &str,
        ty: &str,
        _value: Option<String>,
        p: &Params,
        loc: &Loc,
    ) -> crate::Result<()> {
        let pe = |e| loc.param_error(e);
        match kw {
            "Camera" => {
                if ty != "perspective" {
                    self.warn(
                        loc,
                        format!("Camera \"{ty}\" is not supported; using a perspective camera"),
                    );
                }
                let fov = p.float_or("fov", 90.0).map_err(pe)?;
                if !(fov > 0.0 && fov < 180.0) {
                    return Err(loc.error(format!(
                        "Camera: fov must be in (0, 180) degrees, got {fov}"
                    )));
                }
                if p.float_or("lensradius", 0.0).map_err(pe)? > 0.0 {
                    self.warn(
                        loc,
                        "Camera: depth of field (lensradius) is not supported; using a pinhole",
                    );
                }
                p.ignore("focaldistance");
                let ctm = self.state.ctm;
                if ctm.determinant().abs() < 1e-12 || !ctm.is_finite() {
                    return Err(loc.error("Camera: the camera transform is singular"));
                }
                let camera_to_world = ctm.inverse();
                self.coordinate_systems
                    .insert("camera".into(), camera_to_world);
                self.camera = Some(CameraDef {
                    camera_to_world,
                    fov,
                    loc: loc.clone(),
                });
            }
            "Film" => {
                if !matches!(ty, "rgb" | "gbuffer" | "spectral") {
                    self.warn(
                        loc,
                        format!("Film \"{ty}\" is not supported; using an RGB film"),
                    );
                }
                let res = |name: &str, default: u32| -> crate::Result<u32> {
                    let v = p.int(name).map_err(|e| loc.param_error(e))?;
                    match v {
                        None => Ok(default),
                        Some(v) if (1..=MAX_RESOLUTION as i64).contains(&v) => Ok(v as u32),
                        Some(v) => Err(loc.error(format!(
                            "Film: {name} must be between 1 and {MAX_RESOLUTION}, got {v}"
                        ))),
                    }
                };
                self.resolution = (res("xresolution", 1280)?, res("yresolution", 720)?);
                // The output file is named on the command line.
                p.ignore("filename");
            }
            "Sampler" => {
                // raylink has its own sample patterns; the sample count carries over.
                if let Some(n) = p.int("pixelsamples").map_err(pe)? {
                    if !(1..=1 << 24).contains(&n) {
                        return Err(loc.error(format!(
                            "Sampler: pixelsamples must be between 1 and 16777216, got {n}"
                        )));
                    }
                    self.settings.spp = Some(n as u32);
                }
            }
            "PixelFilter" => {
                let x = p.float("xradius").map_err(pe)?;
                let y = p.float("yradius").map_err(pe)?;
                let r = |default: f64| x.unwrap_or(default).max(y.unwrap_or(default)) as f32;
                let filter = match ty {
                    "box" => Filter::Box { radius: r(0.5) },
                    "triangle" => Filter::Triangle { radius: r(2.0) },
                    "gaussian" => Filter::Gaussian {
                        radius: r(1.5),
                        sigma: p.float_or("sigma", 0.5).map_err(pe)? as f32,
                    },
                    _ => {
                        for name in ["B", "C", "tau"] {
                            p.ignore(name);
                        }
                        self.warn(
                            loc,
                            format!(
                                "PixelFilter \"{ty}\" is not supported; using the default \
                                 Gaussian (radius 1.5, sigma 0.5)"
                            ),
                        );
                        Filter::default()
                    }
                };
                filter
                    .validate()
                    .map_err(|m| loc.error(format!("PixelFilter: {m}")))?;
                self.settings.filter = Some(filter);
            }
            "Integrator" => {
                let name = match ty {
                    "volpath" | "path" | "simplepath" => "path",
                    "bdpt" => "bdpt",
                    "lighttracer" => "light",
                    _ => {
                        self.warn(
                            loc,
                            format!("Integrator \"{ty}\" is not supported; using the path tracer"),
                        );
                        "path"
                    }
                };
                self.settings.integrator = Some(name.into());
                if let Some(d) = p.int("maxdepth").map_err(pe)? {
                    if d < 0 {
                        return Err(loc.error(format!(
                            "Integrator: maxdepth must not be negative, got {d}"
                        )));
                    }
                    self.settings.max_depth = Some(d.min(u32::MAX as i64) as u32);
                } else {
                    self.settings.max_depth = Some(5);
                }
            }
            "Accelerator" => {
                for q in &p.list {
                    p.ignore(&q.name);
                }
            }
            "ColorSpace" if !ty.eq_ignore_ascii_case("srgb") => {
                self.warn(
                    loc,
                    format!("ColorSpace \"{ty}\" is not supported; colours are read as sRGB"),
                );
            }
            "Option" => {
                self.warn(loc, format!("Option \"{ty}\" is not supported; ignored"));
            }
            _ => {}
        }
        Ok(())
    }

    /// raylink's camera from pbrt's camera transform. pbrt's camera space is left-handed
    /// (x right, y up, z forward); raylink's image right is forward × up. When pbrt's right
    /// is the opposite (a camera-to-world without a reflection, as a plain `LookAt` gives),
    /// no rotation of raylink's camera shows the same image, so the whole world is mirrored
    /// across the plane through the eye spanned by forward and up instead: the camera then
    /// sees exactly pbrt's image.
    fn begin_world(&mut self, loc: &Loc) -> crate::Result<()> {
        self.state.ctm = DMat4::IDENTITY;
        self.coordinate_systems
            .insert("world".into(), DMat4::IDENTITY);
        let (c2w, fov, cam_loc) = match &self.camera {
            Some(c) => (c.camera_to_world, c.fov, c.loc.clone()),
            None => (DMat4::IDENTITY, 90.0, loc.clone()),
        };
        let pos = c2w.transform_point3(DVec3::ZERO);
        let forward = c2w.transform_vector3(DVec3::Z).normalize_or_zero();
        let up = c2w.transform_vector3(DVec3::Y);
        let up = (up - forward * up.dot(forward)).normalize_or_zero();
        let right = c2w.transform_vector3(DVec3::X);
        if forward == DVec3::ZERO || up == DVec3::ZERO || !pos.is_finite() {
            return Err(cam_loc.error("Camera: the camera transform is degenerate"));
        }
        let raylink_right = forward.cross(up);
        if right.dot(raylink_right) < 0.0 {
            let n = raylink_right.normalize();
            let reflect = DMat4::from_mat3(DMat3::IDENTITY - 2.0 * outer(n, n));
            self.mirror = DMat4::from_translation(pos) * reflect * DMat4::from_translation(-pos);
        }
        self.camera_value = Some(Camera {
            position: pos.as_vec3(),
            look_at: (pos + forward).as_vec3(),
            up: up.as_vec3(),
            fov_deg: fov as f32,
            width: self.resolution.0,
            height: self.resolution.1,
        });
        Ok(())
    }
}

fn outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}

/// pbrt's `LookAt`: the world-to-camera transform of an eye at `eye` looking at `target`.
pub(crate) fn look_at(eye: DVec3, target: DVec3, up: DVec3) -> Result<DMat4, String> {
    let dir = (target - eye).normalize_or_zero();
    if dir == DVec3::ZERO {
        return Err("the eye and the target are the same point".into());
    }
    let right = up.normalize_or_zero().cross(dir);
    if right.length() < 1e-9 {
        return Err("the up vector is parallel to the viewing direction".into());
    }
    let right = right.normalize();
    let new_up = dir.cross(right);
    let camera_to_world = DMat4::from_cols(
        right.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        eye.extend(1.0),
    );
    Ok(camera_to_world.inverse())
}

/// The tokens of one file and the reading position.
struct Cursor<'a> {
    file: Arc<PathBuf>,
    tokens: &'a [Token],
    i: usize,
}

impl Cursor<'_> {
    fn loc(&self, t: &Token) -> Loc {
        Loc {
            file: self.file.clone(),
            line: t.line,
            col: t.col,
        }
    }

    fn peek(&self) -> Option<&Token> {
        self.tokens.get(self.i)
    }

    /// The position just past the last token, for "the file ends here" messages.
    fn end_loc(&self, stmt: &Loc) -> Loc {
        match self.tokens.last() {
            Some(t) => self.loc(t),
            None => stmt.clone(),
        }
    }

    fn next(&mut self, stmt: &Loc, what: &str) -> crate::Result<Token> {
        let t = self.tokens.get(self.i).cloned().ok_or_else(|| {
            self.end_loc(stmt)
                .error(format!("the file ends inside {what} (truncated file?)"))
        })?;
        self.i += 1;
        Ok(t)
    }

    fn string(&mut self, stmt: &Loc, kw: &str) -> crate::Result<String> {
        let t = self.next(stmt, kw)?;
        match &t.tok {
            Tok::Str(s) => Ok(s.clone()),
            other => {
                let loc = self.loc(&t);
                Err(loc.error(format!(
                    "{kw} expects a quoted string, got {}",
                    other.describe()
                )))
            }
        }
    }

    /// `n` numbers, bare or in brackets.
    fn numbers(&mut self, stmt: &Loc, kw: &str, n: usize) -> crate::Result<Vec<f64>> {
        let bracket = matches!(self.peek().map(|t| &t.tok), Some(Tok::Open));
        if bracket {
            self.i += 1;
        }
        let mut v = Vec::with_capacity(n);
        while v.len() < n {
            let t = self.next(stmt, kw)?;
            match t.tok {
                Tok::Num(x) => v.push(x),
                ref other => {
                    let loc = self.loc(&t);
                    return Err(loc.error(format!(
                        "{kw} takes {n} numbers, got {} after {}",
                        other.describe(),
                        v.len()
                    )));
                }
            }
        }
        if bracket {
            let t = self.next(stmt, kw)?;
            if t.tok != Tok::Close {
                let loc = self.loc(&t);
                return Err(loc.error(format!(
                    "{kw} takes {n} numbers, expected `]`, got {}",
                    t.tok.describe()
                )));
            }
        }
        Ok(v)
    }

    fn matrix(&mut self, stmt: &Loc, kw: &str) -> crate::Result<[f64; 16]> {
        let v = self.numbers(stmt, kw, 16)?;
        let mut a = [0.0; 16];
        a.copy_from_slice(&v);
        let m = DMat4::from_cols_array(&a);
        if m.determinant().abs() < 1e-300 {
            return Err(stmt.error(format!("{kw}: the matrix is singular")));
        }
        Ok(a)
    }

    /// `Option "name" value`: the value token, kept as text.
    fn option_value(&mut self) -> Option<String> {
        let t = self.peek()?;
        let v = match &t.tok {
            Tok::Word(w) => w.clone(),
            Tok::Num(x) => x.to_string(),
            _ => return None,
        };
        self.i += 1;
        Some(v)
    }

    /// A parameter list: `"type name" value` or `"type name" [ values ]`, repeated.
    fn params(&mut self, stmt: &Loc) -> crate::Result<Params> {
        let mut out = Params::default();
        while let Some(t) = self.peek() {
            let Tok::Str(decl) = &t.tok else { break };
            let (decl, dloc) = (decl.clone(), self.loc(t));
            self.i += 1;
            let what = format!("the value of \"{decl}\"");
            let first = self.next(stmt, &what)?;
            let items: Vec<Token> = if first.tok == Tok::Open {
                let mut items = Vec::new();
                loop {
                    let t = self.next(stmt, &format!("the [ ] list of \"{decl}\""))?;
                    match &t.tok {
                        Tok::Close => break,
                        Tok::Open => {
                            let loc = self.loc(&t);
                            return Err(
                                loc.error(format!("unexpected `[` inside the list of \"{decl}\""))
                            );
                        }
                        Tok::Word(w) if w != "true" && w != "false" => {
                            let loc = self.loc(&t);
                            return Err(loc.error(format!(
                                "`{w}` inside the list of \"{decl}\": missing `]`?"
                            )));
                        }
                        _ => items.push(t.clone()),
                    }
                }
                items
            } else {
                vec![first]
            };
            let values = values_of(
                &items,
                &decl,
                &self.loc(&items.first().cloned().unwrap_or(Token {
                    tok: Tok::Close,
                    line: dloc.line,
                    col: dloc.col,
                })),
            )?;
            let param = params::Param::new(&decl, values, dloc.line, dloc.col)
                .map_err(|m| dloc.error(m))?;
            out.list.push(param);
        }
        Ok(out)
    }
}

fn values_of(items: &[Token], decl: &str, loc: &Loc) -> crate::Result<Values> {
    let mut nums = Vec::new();
    let mut strs = Vec::new();
    let mut bools = Vec::new();
    for t in items {
        match &t.tok {
            Tok::Num(x) => nums.push(*x),
            Tok::Str(s) => strs.push(s.clone()),
            Tok::Word(w) if w == "true" || w == "false" => bools.push(w == "true"),
            other => {
                return Err(loc.error(format!(
                    "unexpected {} as the value of \"{decl}\"",
                    other.describe()
                )))
            }
        }
    }
    let kinds = [!nums.is_empty(), !strs.is_empty(), !bools.is_empty()];
    if kinds.iter().filter(|&&k| k).count() > 1 {
        return Err(loc.error(format!(
            "the values of \"{decl}\" mix numbers, strings and booleans"
        )));
    }
    Ok(if !strs.is_empty() {
        Values::Strs(strs)
    } else if !bools.is_empty() {
        Values::Bools(bools)
    } else {
        Values::Nums(nums)
    })
}
