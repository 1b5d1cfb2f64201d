//! Keyframed animation in native TOML scenes: an `[animation]` table (frame range and rate)
//! and `keyframes` arrays on shapes, materials, lights and the camera (docs/animation.md).
//!
//! A frame's scene is made by rewriting the file's TOML table with the interpolated values
//! and handing it to the ordinary reader, so every frame goes through exactly the same checks
//! and transform baking as a static scene, and "render frame N from scratch" and "update to
//! frame N" see the same `Scene`.

use super::toml::Document;
use super::Scene;
use crate::control::Control;
use crate::error::{Error, Result};
use std::path::{Path, PathBuf};
use toml::de::{DeTable, DeValue};
use toml::{Table, Value};

/// Reads a native TOML scene; an animated one gives its first frame (so `raylink render`
/// renders the first frame of an animation).
pub fn read_first_frame(path: &Path, control: &Control) -> Result<Scene> {
    read_with_animation(path, control).map(|(scene, _)| scene)
}

/// Reads a native TOML scene once: the scene (an animated one's first frame) and, if the
/// file has keyframes or an `[animation]` table, its [`Animation`].
pub(crate) fn read_with_animation(
    path: &Path,
    control: &Control,
) -> Result<(Scene, Option<Animation>)> {
    let allowance = crate::input_file::Allowance::new(control.budget, 0);
    let text =
        crate::input_file::read_to_string(path, &crate::input_file::TOML_SCENE, Some(&allowance))?;
    control.cancel.check("reading the scene")?;
    // Parsing holds the text and toml's tree of it at once: far more than the text.
    allowance.check(
        &format!("reading {}", path.display()),
        (text.len() as u64).saturating_add(super::toml::parse_tree_bytes(&text)),
    )?;
    let doc = Document::parse_with(&text, path, Some(control))?;
    // Static files go straight to the reader, so its messages keep their line numbers.
    if !is_animation(doc.root()) {
        return Ok((doc.build()?, None));
    }
    let anim = Animation::from_document(doc)?;
    Ok((anim.placed_scene_at(anim.start)?, Some(anim)))
}

/// Whether a parsed scene file is an animation: it has a top-level `animation` key (the
/// `[animation]` table), or `keyframes` on a shape, light, material or the camera (where
/// [`Animation`] takes them from; a missing `[animation]` table means one frame).
fn is_animation(root: &DeTable) -> bool {
    let keyed = |v: &DeValue| v.as_table().is_some_and(|t| t.contains_key("keyframes"));
    root.iter().any(
        |(key, value)| match (key.get_ref().as_ref(), value.get_ref()) {
            ("animation", _) => true,
            ("shapes" | "lights", DeValue::Array(items)) => {
                items.iter().any(|item| keyed(item.get_ref()))
            }
            ("materials", DeValue::Table(materials)) => {
                materials.values().any(|m| keyed(m.get_ref()))
            }
            ("camera", camera) => keyed(camera),
            _ => false,
        },
    )
}

/// How a keyframe's values move on to the next keyframe's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Interpolation {
    Linear,
    /// Eases out of this key and into the next (smoothstep): zero velocity at keyframes, so
    /// objects come to rest.
    Smooth,
    /// Holds this key's values until the next key.
    Step,
}

#[derive(Clone, Debug)]
struct Key {
    frame: f64,
    interpolation: Interpolation,
    values: Table,
}

#[derive(Clone, Debug, PartialEq)]
enum Target {
    Shape(usize),
    Light(usize),
    Material(String),
    Camera,
}

#[derive(Clone, Debug)]
struct Track {
    target: Target,
    /// Sorted by frame.
    keys: Vec<Key>,
}

/// Keys of a shape's keyframe that drive its animated transform (applied after the shape's
/// own `transform`: scale, then rotate, then translate) and its presence.
const TRANSFORM_KEYS: [&str; 4] = ["translate", "rotate", "scale", "visible"];

/// An animated scene: the static file plus the keyframe tracks.
#[derive(Clone, Debug)]
pub struct Animation {
    path: PathBuf,
    base: Table,
    /// First frame number.
    pub start: i64,
    /// Number of frames.
    pub frames: u32,
    pub fps: f64,
    tracks: Vec<Track>,
}

impl Animation {
    pub fn read(path: &Path) -> Result<Animation> {
        let text = crate::input_file::read_to_string(path, &crate::input_file::TOML_SCENE, None)?;
        Animation::from_str(&text, path)
    }

    pub fn from_str(text: &str, path: &Path) -> Result<Animation> {
        Animation::from_document(Document::parse(text, path)?)
    }

    /// The animation of a parsed scene file (a static one has a single frame).
    fn from_document(doc: Document) -> Result<Animation> {
        let path = doc.path();
        let fail = |msg: String| Error::input(path, msg);
        let mut base = doc.into_table()?;
        let mut anim = Animation {
            path: path.to_path_buf(),
            base: Table::new(),
            start: 0,
            frames: 1,
            fps: 24.0,
            tracks: Vec::new(),
        };
        if let Some(a) = base.remove("animation") {
            let Value::Table(a) = a else {
                return Err(fail("[animation] must be a table".into()));
            };
            for (k, v) in &a {
                match (k.as_str(), v) {
                    ("start", Value::Integer(s)) if s.abs() <= 1_000_000_000 => anim.start = *s,
                    ("frames", Value::Integer(n)) if (1..=1_000_000).contains(n) => {
                        anim.frames = *n as u32
                    }
                    ("fps", _) if number(v).is_some_and(|f| f > 0.0 && f.is_finite()) => {
                        anim.fps = number(v).unwrap_or(24.0)
                    }
                    ("start" | "frames" | "fps", _) => {
                        return Err(fail(format!(
                            "animation.{k}: expected {}, got {v}",
                            match k.as_str() {
                                "start" => "an integer frame number (at most 10^9 in size)",
                                "frames" => "a frame count from 1 to 1000000",
                                _ => "a positive number of frames per second",
                            }
                        )))
                    }
                    _ => {
                        return Err(fail(format!(
                            "animation.{k}: unknown key (expected start, frames or fps)"
                        )))
                    }
                }
            }
        }
        // Collect and strip the keyframes, so that the reader sees a static scene.
        if let Some(Value::Array(shapes)) = base.get_mut("shapes") {
            for (i, s) in shapes.iter_mut().enumerate() {
                if let Some(t) = take_track(s, Target::Shape(i), &format!("shapes[{i}]"), path)? {
                    anim.tracks.push(t);
                }
            }
        }
        if let Some(Value::Array(lights)) = base.get_mut("lights") {
            for (i, l) in lights.iter_mut().enumerate() {
                if let Some(t) = take_track(l, Target::Light(i), &format!("lights[{i}]"), path)? {
                    anim.tracks.push(t);
                }
            }
        }
        if let Some(Value::Table(materials)) = base.get_mut("materials") {
            for (name, m) in materials.iter_mut() {
                let target = Target::Material(name.clone());
                if let Some(t) = take_track(m, target, &format!("materials.{name}"), path)? {
                    anim.tracks.push(t);
                }
            }
        }
        if let Some(c) = base.get_mut("camera") {
            if let Some(t) = take_track(c, Target::Camera, "camera", path)? {
                anim.tracks.push(t);
            }
        }
        for t in &anim.tracks {
            if !matches!(t.target, Target::Shape(_)) {
                for k in &t.keys {
                    if let Some(key) = TRANSFORM_KEYS.iter().find(|k2| k.values.contains_key(**k2))
                    {
                        return Err(fail(format!(
                            "{}: `{key}` keyframes apply to shapes only",
                            t.describe()
                        )));
                    }
                }
            }
        }
        anim.base = base;
        // Frame `start` must read: most mistakes show up here, with the reader's message.
        anim.placed_scene_at(anim.start)?;
        Ok(anim)
    }

    /// Whether the file has any keyframes.
    pub fn is_animated(&self) -> bool {
        !self.tracks.is_empty()
    }

    /// The frame numbers, in order.
    pub fn frame_numbers(&self) -> std::ops::Range<i64> {
        self.start..self.start + self.frames as i64
    }

    /// The scene at frame `frame` (keyframes before the first / after the last hold), its
    /// instances placed as world-space copies: the animation renderer follows world-space
    /// shapes from frame to frame.
    pub fn scene_at(&self, frame: i64) -> Result<Scene> {
        let mut scene = self.placed_scene_at(frame)?;
        scene.flatten_instances();
        Ok(scene)
    }

    /// The scene at frame `frame`, its instances kept.
    fn placed_scene_at(&self, frame: i64) -> Result<Scene> {
        let text = to_text(&self.table_at(frame as f64)?);
        super::toml::from_str(&text, &self.path).map_err(|e| match e {
            Error::Input { path, detail } if self.is_animated() => Error::Input {
                path,
                detail: format!("frame {frame}: {detail}"),
            },
            e => e,
        })
    }

    /// The file's table with every track's values at `frame`.
    fn table_at(&self, frame: f64) -> Result<Table> {
        let mut table = self.base.clone();
        let mut hidden = Vec::new();
        for track in &self.tracks {
            let values = track.values_at(frame);
            let entry = match &track.target {
                Target::Shape(i) => table
                    .get_mut("shapes")
                    .and_then(|v| v.as_array_mut())
                    .and_then(|a| a.get_mut(*i)),
                Target::Light(i) => table
                    .get_mut("lights")
                    .and_then(|v| v.as_array_mut())
                    .and_then(|a| a.get_mut(*i)),
                Target::Material(name) => table
                    .get_mut("materials")
                    .and_then(|v| v.as_table_mut())
                    .and_then(|m| m.get_mut(name)),
                Target::Camera => table.get_mut("camera"),
            };
            let Some(Value::Table(entry)) = entry else {
                return Err(Error::input(
                    &self.path,
                    format!(
                        "{}: keyframes on something that is not a table",
                        track.describe()
                    ),
                ));
            };
            let mut steps = Vec::new();
            for (k, v) in values {
                match k.as_str() {
                    "visible" => match v {
                        Value::Boolean(false) => {
                            if let Target::Shape(i) = track.target {
                                hidden.push(i)
                            }
                        }
                        Value::Boolean(true) => {}
                        _ => {
                            return Err(Error::input(
                                &self.path,
                                format!("{}: visible must be true or false", track.describe()),
                            ))
                        }
                    },
                    "scale" | "rotate" | "translate" => steps.push((k, v)),
                    _ => {
                        entry.insert(k, v);
                    }
                }
            }
            if !steps.is_empty() {
                // Scale, rotate, translate: the usual order of an object's own motion.
                steps.sort_by_key(|(k, _)| match k.as_str() {
                    "scale" => 0,
                    "rotate" => 1,
                    _ => 2,
                });
                let mut ops = match entry.remove("transform") {
                    None => Vec::new(),
                    Some(Value::Array(a)) => a,
                    Some(one) => vec![one],
                };
                for (k, v) in steps {
                    let mut step = Table::new();
                    step.insert(k, v);
                    ops.push(Value::Table(step));
                }
                entry.insert("transform".into(), Value::Array(ops));
            }
        }
        if !hidden.is_empty() {
            if let Some(Value::Array(shapes)) = table.get_mut("shapes") {
                let mut i = 0;
                shapes.retain(|_| {
                    i += 1;
                    !hidden.contains(&(i - 1))
                });
            }
        }
        Ok(table)
    }
}

impl Track {
    fn describe(&self) -> String {
        match &self.target {
            Target::Shape(i) => format!("shapes[{i}].keyframes"),
            Target::Light(i) => format!("lights[{i}].keyframes"),
            Target::Material(n) => format!("materials.{n}.keyframes"),
            Target::Camera => "camera.keyframes".into(),
        }
    }

    /// Every animated key's value at `frame`; each key is interpolated between the keyframes
    /// that give it.
    fn values_at(&self, frame: f64) -> Vec<(String, Value)> {
        let mut names: Vec<&String> = self.keys.iter().flat_map(|k| k.values.keys()).collect();
        names.sort();
        names.dedup();
        names
            .into_iter()
            .map(|name| {
                let keys: Vec<&Key> = self
                    .keys
                    .iter()
                    .filter(|k| k.values.contains_key(name))
                    .collect();
                (name.clone(), interpolate(&keys, name, frame))
            })
            .collect()
    }
}

fn interpolate(keys: &[&Key], name: &str, frame: f64) -> Value {
    // The last key at or before `frame` (or the first key when `frame` precedes them all).
    let i = keys.iter().rposition(|k| k.frame <= frame).unwrap_or(0);
    let a = keys[i];
    let Some(b) = keys.get(i + 1).filter(|_| frame > a.frame) else {
        return a.values[name].clone();
    };
    let t = (frame - a.frame) / (b.frame - a.frame);
    let t = match a.interpolation {
        Interpolation::Linear => t,
        Interpolation::Smooth => t * t * (3.0 - 2.0 * t),
        Interpolation::Step => return a.values[name].clone(),
    };
    mix(&a.values[name], &b.values[name], t).unwrap_or_else(|| a.values[name].clone())
}

/// Blends two values: numbers and arrays of numbers componentwise, rotations by their angle
/// (same axis) or by quaternion slerp; `None` for anything else (which then steps).
fn mix(a: &Value, b: &Value, t: f64) -> Option<Value> {
    match (a, b) {
        (Value::Integer(_), Value::Integer(_)) => None,
        (Value::Array(x), Value::Array(y)) if x.len() == y.len() => x
            .iter()
            .zip(y)
            .map(|(p, q)| mix_number(p, q, t))
            .collect::<Option<Vec<_>>>()
            .map(Value::Array),
        (Value::Table(x), Value::Table(y)) => {
            // A rotation: { axis, degrees }.
            let axis_a = vec3(x.get("axis")?)?;
            let axis_b = vec3(y.get("axis")?)?;
            let (da, db) = (number(x.get("degrees")?)?, number(y.get("degrees")?)?);
            let (axis, degrees) = if axis_a == axis_b {
                (axis_a, da + (db - da) * t)
            } else {
                let qa = glam::DQuat::from_axis_angle(axis_a.normalize(), da.to_radians());
                let qb = glam::DQuat::from_axis_angle(axis_b.normalize(), db.to_radians());
                let (axis, angle) = qa.slerp(qb, t).to_axis_angle();
                (axis, angle.to_degrees())
            };
            let mut r = Table::new();
            r.insert(
                "axis".into(),
                Value::Array(axis.to_array().map(Value::Float).to_vec()),
            );
            r.insert("degrees".into(), Value::Float(degrees));
            Some(Value::Table(r))
        }
        _ => mix_number(a, b, t),
    }
}

fn mix_number(a: &Value, b: &Value, t: f64) -> Option<Value> {
    let (x, y) = (number(a)?, number(b)?);
    Some(Value::Float(x + (y - x) * t))
}

fn number(v: &Value) -> Option<f64> {
    match v {
        Value::Integer(i) => Some(*i as f64),
        Value::Float(f) => Some(*f),
        _ => None,
    }
}

fn vec3(v: &Value) -> Option<glam::DVec3> {
    let a = v.as_array()?;
    (a.len() == 3).then_some(())?;
    Some(glam::DVec3::new(
        number(&a[0])?,
        number(&a[1])?,
        number(&a[2])?,
    ))
}

/// Removes `keyframes` from a shape, light, material or camera table and checks it.
fn take_track(entry: &mut Value, target: Target, what: &str, path: &Path) -> Result<Option<Track>> {
    let Value::Table(t) = entry else {
        return Ok(None);
    };
    let Some(k) = t.remove("keyframes") else {
        return Ok(None);
    };
    let fail = |msg: String| Error::input(path, format!("{what}.keyframes{msg}"));
    let Value::Array(items) = k else {
        return Err(fail(
            ": must be an array of tables ([[...keyframes]])".into(),
        ));
    };
    let mut keys = Vec::new();
    for (i, item) in items.into_iter().enumerate() {
        let Value::Table(mut values) = item else {
            return Err(fail(format!("[{i}]: must be a table")));
        };
        let frame = match values.remove("frame") {
            Some(v) if number(&v).is_some_and(f64::is_finite) => number(&v).unwrap_or(0.0),
            Some(v) => return Err(fail(format!("[{i}].frame: expected a number, got {v}"))),
            None => return Err(fail(format!("[{i}]: needs a frame number (frame = N)"))),
        };
        let interpolation = match values.remove("interpolation") {
            None => Interpolation::Linear,
            Some(Value::String(s)) if s == "linear" => Interpolation::Linear,
            Some(Value::String(s)) if s == "smooth" => Interpolation::Smooth,
            Some(Value::String(s)) if s == "step" => Interpolation::Step,
            Some(v) => {
                return Err(fail(format!(
                    "[{i}].interpolation: expected \"linear\", \"smooth\" or \"step\", got {v}"
                )))
            }
        };
        if let Some(prev) = keys.last().map(|k: &Key| k.frame) {
            if frame <= prev {
                return Err(fail(format!(
                    "[{i}].frame: keyframes must be in increasing frame order ({frame} after {prev})"
                )));
            }
        }
        keys.push(Key {
            frame,
            interpolation,
            values,
        });
    }
    if keys.is_empty() {
        return Ok(None);
    }
    Ok(Some(Track { target, keys }))
}

/// The table as TOML text with every table below the top level written inline, as scene
/// files write them (the reader borrows keys from the text).
fn to_text(table: &Table) -> String {
    fn key(k: &str) -> String {
        if !k.is_empty()
            && k.chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        {
            k.to_string()
        } else {
            Value::String(k.to_string()).to_string()
        }
    }
    fn entries(t: &Table, out: &mut String) {
        for (k, v) in t {
            out.push_str(&format!("{} = {v}\n", key(k)));
        }
    }
    let mut out = String::new();
    let mut sections = String::new();
    for (k, v) in table {
        match v {
            Value::Table(t) => {
                sections.push_str(&format!("[{}]\n", key(k)));
                entries(t, &mut sections);
            }
            Value::Array(a) if !a.is_empty() && a.iter().all(Value::is_table) => {
                for item in a {
                    sections.push_str(&format!("[[{}]]\n", key(k)));
                    if let Value::Table(t) = item {
                        entries(t, &mut sections);
                    }
                }
            }
            _ => out.push_str(&format!("{} = {v}\n", key(k))),
        }
    }
    out + &sections
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;

    const SCENE: &str = r#"
[animation]
frames = 5

[camera]
position = [0, 0, 5]
look_at = [0, 0, 0]
width = 8
height = 8

[materials.red]
diffuse = [0.8, 0.1, 0.1]

[[materials.red.keyframes]]
frame = 0
diffuse = [0.8, 0.1, 0.1]
[[materials.red.keyframes]]
frame = 4
diffuse = [0.0, 0.5, 0.1]

[[shapes]]
type = "sphere"
material = "red"
center = [0, 0, 0]
radius = 1

[[shapes.keyframes]]
frame = 0
translate = [0, 0, 0]
visible = true
interpolation = "smooth"
[[shapes.keyframes]]
frame = 4
translate = [2, 0, 0]
[[shapes.keyframes]]
frame = 5
visible = false

[[shapes]]
type = "sphere"
material = "red"
center = [0, 3, 0]
radius = 1
"#;

    fn center(scene: &Scene) -> Vec3 {
        match scene.shapes[0].geometry {
            super::super::Geometry::Sphere(super::super::Sphere { center, .. }) => center,
            _ => panic!("a sphere"),
        }
    }

    #[test]
    fn keys_out_of_order_are_an_error() {
        let text = SCENE.replace("frame = 5", "frame = 3");
        let e = Animation::from_str(&text, Path::new("a.toml")).unwrap_err();
        assert!(e.to_string().contains("increasing frame order"), "{e}");
    }

    #[test]
    fn smooth_and_linear_interpolation() {
        let a = Animation::from_str(SCENE, Path::new("a.toml")).unwrap();
        assert!(a.is_animated());
        assert_eq!(a.frames, 5);
        // Smooth: smoothstep(1/4) = 0.15625 of the way at frame 1, halfway at frame 2.
        let c1 = center(&a.scene_at(1).unwrap());
        assert!((c1.x - 2.0 * 0.15625).abs() < 1e-6, "{c1}");
        let c2 = center(&a.scene_at(2).unwrap());
        assert!((c2.x - 1.0).abs() < 1e-6, "{c2}");
        // Holds after the last key.
        assert!((center(&a.scene_at(4).unwrap()).x - 2.0).abs() < 1e-6);
        // Linear material: a quarter of the way at frame 1.
        let s = a.scene_at(1).unwrap();
        let m = &s.materials[s.shapes[0].material];
        let kd = m
            .approximation()
            .diffuse
            .eval(Vec3::ZERO, crate::math::Vec2::ZERO, Vec3::ZERO);
        assert!(
            (kd.x - 0.6).abs() < 1e-6 && (kd.y - 0.2).abs() < 1e-6,
            "{kd}"
        );
        // Hidden from frame 5 (step: visible is not a number).
        assert_eq!(a.scene_at(4).unwrap().shapes.len(), 2);
        assert_eq!(a.scene_at(5).unwrap().shapes.len(), 1);
    }
}
