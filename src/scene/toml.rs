//! The native scene format (documented in docs/scene-format.md).
//!
//! Reading happens in two steps: serde + toml turn the text into the `*Desc` structures below
//! (syntax, unknown keys and wrong types are caught there, with toml's line and column), then
//! `Builder` checks the values and bakes transforms into world-space geometry. Every
//! problem becomes an [`Error::input`](crate::Error::input) whose detail is one line that
//! starts with the line number and names the field, e.g.
//! `line 12: shapes[2].radius: must be positive, got -1`.

use super::environment::Environment;
use super::obj;
use super::texture::{Encoding, ImageTexture, UvMapping};
use super::{
    Camera, Geometry, Light, Material, QuadMesh, RenderSettings, Scene, Shape, Texture,
    TriangleMesh, MAX_RESOLUTION,
};
use crate::image::filter::Filter;
use crate::math::{Mat3, Mat4, Rgb, Vec2, Vec3};
use crate::Error;
use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};
use serde::Deserialize;
use std::collections::HashMap;
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};
use toml::Spanned;

/// Reads a native TOML scene.
pub fn read(path: &Path) -> crate::Result<Scene> {
    let text = std::fs::read_to_string(path).map_err(|e| crate::Error::io(path, e))?;
    from_str(&text, path)
}

/// Parses a native TOML scene; `path` names the file in messages and resolves relative paths.
pub fn from_str(text: &str, path: &Path) -> crate::Result<Scene> {
    let ctx = Ctx { path, text };
    let file: FileDesc = toml::from_str(text).map_err(|e| ctx.toml_error(&e))?;
    Builder::new(ctx).build(file)
}

// ------------------------------------------------------------------------------------------
// The file as serde sees it.

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileDesc {
    camera: Option<Spanned<CameraDesc>>,
    world: Option<Spanned<WorldDesc>>,
    #[serde(default)]
    materials: Ordered<Spanned<MaterialDesc>>,
    #[serde(default)]
    shapes: Vec<Spanned<ShapeDesc>>,
    #[serde(default)]
    lights: Vec<Spanned<LightDesc>>,
    render: Option<Spanned<RenderDesc>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RenderDesc {
    integrator: Option<String>,
    spp: Option<u32>,
    max_depth: Option<u32>,
    filter: Option<FilterDesc>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FilterDesc {
    #[serde(rename = "type")]
    kind: String,
    radius: Option<f32>,
    sigma: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct EnvironmentDesc {
    file: String,
    scale: Option<Splat3>,
    transform: Option<OneOrMany<TransformOp>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraDesc {
    position: V3,
    look_at: V3,
    up: Option<V3>,
    fov: Option<f32>,
    width: Option<u32>,
    height: Option<u32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct WorldDesc {
    ambient: Option<Splat3>,
    background: Option<Splat3>,
    environment: Option<EnvironmentDesc>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialDesc {
    diffuse: Option<DiffuseDesc>,
    ambient: Option<Splat3>,
    specular: Option<Splat3>,
    transmission: Option<Splat3>,
    ior: Option<f32>,
    phong_exponent: Option<f32>,
    roughness: Option<f32>,
    fresnel: Option<bool>,
    emission: Option<Splat3>,
}

enum DiffuseDesc {
    Colour(Vec3),
    Texture(TextureTable),
}

/// `{ checker = {..} }`, `{ uv_checker = {..} }` or `{ image = {..} }`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TextureTable {
    checker: Option<CheckerDesc>,
    uv_checker: Option<UvCheckerDesc>,
    image: Option<ImageDesc>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct UvCheckerDesc {
    even: Splat3,
    odd: Splat3,
    uscale: Option<f32>,
    vscale: Option<f32>,
    udelta: Option<f32>,
    vdelta: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ImageDesc {
    file: String,
    encoding: Option<String>,
    scale: Option<f32>,
    invert: Option<bool>,
    uscale: Option<f32>,
    vscale: Option<f32>,
    udelta: Option<f32>,
    vdelta: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CheckerDesc {
    even: Splat3,
    odd: Splat3,
    size: Option<f32>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
enum ShapeKind {
    Sphere,
    Quad,
    Polygon,
    Mesh,
    Obj,
    Ply,
}

impl ShapeKind {
    fn name(self) -> &'static str {
        match self {
            ShapeKind::Sphere => "sphere",
            ShapeKind::Quad => "quad",
            ShapeKind::Polygon => "polygon",
            ShapeKind::Mesh => "mesh",
            ShapeKind::Obj => "obj",
            ShapeKind::Ply => "ply",
        }
    }

    /// The parameters the kind takes besides `type`, `material` and `transform`.
    fn params(self) -> &'static [&'static str] {
        match self {
            ShapeKind::Sphere => &["center", "radius"],
            ShapeKind::Quad | ShapeKind::Polygon => &["vertices"],
            ShapeKind::Mesh => &["positions", "indices", "normals", "uvs"],
            ShapeKind::Obj | ShapeKind::Ply => &["file"],
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ShapeDesc {
    #[serde(rename = "type")]
    kind: ShapeKind,
    material: Option<String>,
    transform: Option<OneOrMany<TransformOp>>,
    center: Option<V3>,
    radius: Option<f32>,
    vertices: Option<Vec<V3>>,
    positions: Option<Vec<V3>>,
    indices: Option<Vec<Idx3>>,
    normals: Option<Vec<V3>>,
    uvs: Option<Vec<V2>>,
    file: Option<String>,
}

impl ShapeDesc {
    /// The kind-specific parameters that are present.
    fn present(&self) -> Vec<&'static str> {
        [
            ("center", self.center.is_some()),
            ("radius", self.radius.is_some()),
            ("vertices", self.vertices.is_some()),
            ("positions", self.positions.is_some()),
            ("indices", self.indices.is_some()),
            ("normals", self.normals.is_some()),
            ("uvs", self.uvs.is_some()),
            ("file", self.file.is_some()),
        ]
        .into_iter()
        .filter_map(|(name, present)| present.then_some(name))
        .collect()
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TransformOp {
    translate: Option<V3>,
    rotate: Option<RotateDesc>,
    scale: Option<Splat3>,
    matrix: Option<Vec<Vec<f32>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RotateDesc {
    axis: V3,
    degrees: f32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
enum LightKind {
    Point,
    Directional,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LightDesc {
    #[serde(rename = "type")]
    kind: LightKind,
    position: Option<V3>,
    intensity: Option<Splat3>,
    direction: Option<V3>,
    irradiance: Option<Splat3>,
}

// ------------------------------------------------------------------------------------------
// Value types with their own deserializers (for clear messages).

/// Exactly three numbers `[x, y, z]`.
#[derive(Clone, Copy, Debug)]
struct V3(Vec3);

/// Exactly two numbers `[u, v]`.
#[derive(Clone, Copy, Debug)]
struct V2(Vec2);

/// Exactly three vertex indices.
#[derive(Clone, Copy, Debug)]
struct Idx3([u32; 3]);

/// Three numbers, or one number standing for three equal ones (a grey, a uniform scale).
#[derive(Clone, Copy, Debug)]
struct Splat3(Vec3);

fn read_numbers<'de, A: SeqAccess<'de>>(seq: &mut A) -> Result<Vec<f32>, A::Error> {
    let mut values = Vec::with_capacity(3);
    while let Some(x) = seq.next_element::<f32>()? {
        values.push(x);
    }
    Ok(values)
}

fn triple<E: de::Error>(values: &[f32], exp: &dyn de::Expected) -> Result<Vec3, E> {
    match *values {
        [x, y, z] => Ok(Vec3::new(x, y, z)),
        _ => Err(E::invalid_length(values.len(), exp)),
    }
}

impl<'de> Deserialize<'de> for V3 {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Vis;
        impl<'de> Visitor<'de> for Vis {
            type Value = V3;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an array of 3 numbers [x, y, z]")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<V3, A::Error> {
                triple(&read_numbers(&mut seq)?, &self).map(V3)
            }
        }
        d.deserialize_seq(Vis)
    }
}

impl<'de> Deserialize<'de> for V2 {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Vis;
        impl<'de> Visitor<'de> for Vis {
            type Value = V2;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an array of 2 numbers [u, v]")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<V2, A::Error> {
                match read_numbers(&mut seq)?[..] {
                    [u, v] => Ok(V2(Vec2::new(u, v))),
                    ref other => Err(de::Error::invalid_length(other.len(), &self)),
                }
            }
        }
        d.deserialize_seq(Vis)
    }
}

impl<'de> Deserialize<'de> for Idx3 {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Vis;
        impl<'de> Visitor<'de> for Vis {
            type Value = Idx3;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an array of 3 vertex indices [i, j, k]")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Idx3, A::Error> {
                let mut values = Vec::with_capacity(3);
                while let Some(i) = seq.next_element::<u32>()? {
                    values.push(i);
                }
                match values[..] {
                    [a, b, c] => Ok(Idx3([a, b, c])),
                    _ => Err(de::Error::invalid_length(values.len(), &self)),
                }
            }
        }
        d.deserialize_seq(Vis)
    }
}

/// Accepts a number (splatted) or three numbers.
struct Splat3Visitor;

impl<'de> Visitor<'de> for Splat3Visitor {
    type Value = Vec3;
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a number or an array of 3 numbers")
    }
    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Vec3, E> {
        Ok(Vec3::splat(v as f32))
    }
    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Vec3, E> {
        Ok(Vec3::splat(v as f32))
    }
    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Vec3, E> {
        Ok(Vec3::splat(v as f32))
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Vec3, A::Error> {
        triple(&read_numbers(&mut seq)?, &self)
    }
}

impl<'de> Deserialize<'de> for Splat3 {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(Splat3Visitor).map(Splat3)
    }
}

impl<'de> Deserialize<'de> for DiffuseDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Vis;
        impl<'de> Visitor<'de> for Vis {
            type Value = DiffuseDesc;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str(
                    "a number, an array of 3 numbers or a table { checker = { .. } }, \
                     { uv_checker = { .. } } or { image = { .. } }",
                )
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<DiffuseDesc, E> {
                Splat3Visitor.visit_i64(v).map(DiffuseDesc::Colour)
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<DiffuseDesc, E> {
                Splat3Visitor.visit_u64(v).map(DiffuseDesc::Colour)
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<DiffuseDesc, E> {
                Splat3Visitor.visit_f64(v).map(DiffuseDesc::Colour)
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<DiffuseDesc, A::Error> {
                Splat3Visitor.visit_seq(seq).map(DiffuseDesc::Colour)
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<DiffuseDesc, A::Error> {
                TextureTable::deserialize(de::value::MapAccessDeserializer::new(map))
                    .map(DiffuseDesc::Texture)
            }
        }
        d.deserialize_any(Vis)
    }
}

/// A single table or an array of them.
enum OneOrMany<T> {
    One(T),
    Many(Vec<T>),
}

impl<'de, T: Deserialize<'de>> Deserialize<'de> for OneOrMany<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Vis<T>(std::marker::PhantomData<T>);
        impl<'de, T: Deserialize<'de>> Visitor<'de> for Vis<T> {
            type Value = OneOrMany<T>;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a table or an array of tables")
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<OneOrMany<T>, A::Error> {
                T::deserialize(de::value::MapAccessDeserializer::new(map)).map(OneOrMany::One)
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<OneOrMany<T>, A::Error> {
                Vec::<T>::deserialize(de::value::SeqAccessDeserializer::new(seq))
                    .map(OneOrMany::Many)
            }
        }
        d.deserialize_any(Vis(std::marker::PhantomData))
    }
}

/// A table whose entries keep the order of the file.
struct Ordered<T>(Vec<(String, T)>);

impl<T> Default for Ordered<T> {
    fn default() -> Self {
        Ordered(Vec::new())
    }
}

impl<'de, T: Deserialize<'de>> Deserialize<'de> for Ordered<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Vis<T>(std::marker::PhantomData<T>);
        impl<'de, T: Deserialize<'de>> Visitor<'de> for Vis<T> {
            type Value = Ordered<T>;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a table")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Ordered<T>, A::Error> {
                let mut entries = Vec::new();
                while let Some((k, v)) = map.next_entry::<String, T>()? {
                    entries.push((k, v));
                }
                Ok(Ordered(entries))
            }
        }
        d.deserialize_map(Vis(std::marker::PhantomData))
    }
}

// ------------------------------------------------------------------------------------------
// Messages.

#[derive(Clone, Copy)]
struct Ctx<'a> {
    path: &'a Path,
    text: &'a str,
}

/// A table of the file, for messages: its name (`shapes[2]`) and where it is.
struct Site {
    name: String,
    span: Range<usize>,
}

impl Ctx<'_> {
    fn line_at(&self, offset: usize) -> usize {
        let end = offset.min(self.text.len());
        1 + self.text.as_bytes()[..end]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
    }

    fn column_at(&self, offset: usize) -> usize {
        let end = offset.min(self.text.len());
        let bytes = &self.text.as_bytes()[..end];
        let start = bytes.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
        // Count characters, not bytes.
        1 + self
            .text
            .get(start..end)
            .map_or(end - start, |s| s.chars().count())
    }

    /// toml's errors span several lines (a snippet with a caret); keep the position and the
    /// message on one line.
    fn toml_error(&self, e: &toml::de::Error) -> Error {
        let message = one_line(&e.message());
        let detail = match e.span() {
            Some(span) => format!(
                "line {}, column {}: {message}{}",
                self.line_at(span.start),
                self.column_at(span.start),
                self.snippet(span.start)
            ),
            None => message,
        };
        Error::input(self.path, detail)
    }

    /// ` (in `...`)` quoting the line around `offset`, shortened; empty for a blank line.
    fn snippet(&self, offset: usize) -> String {
        let bytes = self.text.as_bytes();
        let at = offset.min(bytes.len());
        let start = bytes[..at]
            .iter()
            .rposition(|&b| b == b'\n')
            .map_or(0, |i| i + 1);
        let end = bytes[at..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(bytes.len(), |i| at + i);
        let line = self.text.get(start..end).unwrap_or("").trim();
        if line.is_empty() {
            return String::new();
        }
        const MAX: usize = 60;
        let short: String = if line.chars().count() > MAX {
            line.chars().take(MAX - 3).chain("...".chars()).collect()
        } else {
            line.to_string()
        };
        format!(" (in `{short}`)")
    }

    /// The line on which `key` is set inside the table at `span`; the table's first line
    /// when it cannot be found.
    fn key_line(&self, span: &Range<usize>, key: &str) -> usize {
        let span = &self.table_extent(span);
        let body = self.text.get(span.clone()).unwrap_or("");
        if !key.is_empty() {
            let bytes = body.as_bytes();
            let mut from = 0;
            while let Some(i) = body.get(from..).and_then(|s| s.find(key)) {
                let at = from + i;
                let before_ok =
                    at == 0 || matches!(bytes[at - 1], b' ' | b'\t' | b'\n' | b'\r' | b'{' | b',');
                let after = body.get(at + key.len()..).unwrap_or("");
                if before_ok && after.trim_start_matches([' ', '\t']).starts_with('=') {
                    return self.line_at(span.start + at);
                }
                from = at + key.len();
            }
        }
        self.line_at(span.start)
    }

    /// A `[table]` or `[[table]]` header's span (what toml gives for a table opened by a
    /// header) extended over the table's body, up to the next header line; any other span as
    /// it is.
    fn table_extent(&self, span: &Range<usize>) -> Range<usize> {
        let Some(head) = self.text.get(span.clone()) else {
            return span.clone();
        };
        if !head.trim_start().starts_with('[') || head.contains('=') {
            return span.clone();
        }
        let is_header = |line: &str| {
            let l = line.trim_start();
            let name = l.trim_start_matches('[').trim_start();
            l.starts_with('[')
                && name
                    .chars()
                    .next()
                    .is_some_and(|c| c.is_alphabetic() || c == '_' || c == '"' || c == '\'')
        };
        let mut end = self.text.len();
        let mut offset = span.end;
        for line in self.text[span.end..].split_inclusive('\n') {
            if offset > span.end && is_header(line) {
                end = offset;
                break;
            }
            offset += line.len();
        }
        span.start..end
    }

    /// An error about `field` (a path inside the table, may be empty) of the table `site`.
    fn fail(&self, site: &Site, field: &str, msg: impl fmt::Display) -> Error {
        let key = field.split(['.', '[']).next().unwrap_or("");
        let line = self.key_line(&site.span, key);
        let name = match (site.name.is_empty(), field.is_empty()) {
            (_, true) => site.name.clone(),
            (true, false) => field.to_string(),
            (false, false) => format!("{}.{field}", site.name),
        };
        Error::input(
            self.path,
            format!("line {line}: {name}: {}", one_line(&msg)),
        )
    }
}

fn one_line(msg: &dyn fmt::Display) -> String {
    let text = msg.to_string();
    text.split(['\n', '\r'])
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join("; ")
}

// ------------------------------------------------------------------------------------------
// Value checks: each returns the message for `Ctx::fail`.

fn finite(v: f32) -> Result<f32, String> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("must be a finite number, got {v}"))
    }
}

fn positive(v: f32) -> Result<f32, String> {
    finite(v)?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err(format!("must be positive, got {v}"))
    }
}

fn non_negative(v: f32) -> Result<f32, String> {
    finite(v)?;
    if v >= 0.0 {
        Ok(v)
    } else {
        Err(format!("must not be negative, got {v}"))
    }
}

fn finite3(v: Vec3) -> Result<Vec3, String> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("must be finite, got {v}"))
    }
}

fn colour(v: Vec3) -> Result<Rgb, String> {
    finite3(v)?;
    if v.min_element() >= 0.0 {
        Ok(v)
    } else {
        Err(format!("must not be negative, got {v}"))
    }
}

fn direction(v: Vec3) -> Result<Vec3, String> {
    finite3(v)?;
    let n = v.normalize_or_zero();
    if n == Vec3::ZERO {
        Err(format!("must be a non-zero vector, got {v}"))
    } else {
        Ok(n)
    }
}

/// Largest image side accepted.
fn resolution(v: u32) -> Result<u32, String> {
    if (1..=MAX_RESOLUTION).contains(&v) {
        Ok(v)
    } else {
        Err(format!("must be between 1 and {MAX_RESOLUTION}, got {v}"))
    }
}

// ------------------------------------------------------------------------------------------
// Geometry helpers.

/// An affine transform with the matrix for normals.
struct Xform {
    m: Mat4,
    normal: Mat3,
    /// True when the transform mirrors (negative determinant): triangle winding is reversed
    /// to keep faces oriented as before.
    flips: bool,
}

impl Xform {
    fn new(m: Mat4) -> Result<Xform, String> {
        let linear = Mat3::from_mat4(m);
        let det = linear.determinant();
        if !det.is_finite() || det.abs() < 1e-30 {
            return Err(format!("is singular (determinant {det})"));
        }
        Ok(Xform {
            m,
            normal: linear.inverse().transpose(),
            flips: det < 0.0,
        })
    }

    fn point(&self, p: Vec3) -> Vec3 {
        self.m.transform_point3(p)
    }

    fn normal(&self, n: Vec3) -> Vec3 {
        (self.normal * n).normalize_or_zero()
    }

    /// Moves a mesh's positions and (unit) normals; the caller reverses the winding when
    /// `flips`.
    fn place(&self, positions: &mut [Vec3], normals: &mut Option<Vec<Vec3>>) {
        for p in positions {
            *p = self.point(*p);
        }
        for n in normals.iter_mut().flatten() {
            *n = self.normal(*n);
        }
    }

    /// Some(s) when the linear part is a rotation (or mirror) times the uniform scale s.
    fn uniform_scale(&self) -> Option<f32> {
        let l = Mat3::from_mat4(self.m);
        let cols = [l.x_axis, l.y_axis, l.z_axis];
        let len = cols.map(Vec3::length);
        let mean = (len[0] + len[1] + len[2]) / 3.0;
        let tol = 1e-4 * mean;
        let equal = len.iter().all(|&x| (x - mean).abs() <= tol);
        let orthogonal = (cols[0].dot(cols[1]).abs() <= tol * mean)
            && (cols[0].dot(cols[2]).abs() <= tol * mean)
            && (cols[1].dot(cols[2]).abs() <= tol * mean);
        (equal && orthogonal).then_some(mean)
    }
}

fn triangle_area(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    0.5 * (b - a).cross(c - a).length()
}

/// Newell's normal of a polygon: its length is twice the polygon's area.
fn newell(vs: &[Vec3]) -> Vec3 {
    // Relative to the centroid, for precision away from the origin.
    let c = vs.iter().copied().sum::<Vec3>() / vs.len().max(1) as f32;
    let mut n = Vec3::ZERO;
    for (i, &a) in vs.iter().enumerate() {
        let b = vs[(i + 1) % vs.len()];
        n += (a - c).cross(b - c);
    }
    n
}

/// Checks that the vertices form a planar, convex polygon with area; returns its unit normal
/// (following the vertex order).
fn planar_convex(vs: &[Vec3], what: &str) -> Result<Vec3, String> {
    let n = newell(vs);
    // The bounding box's diagonal stands for the size.
    let lo = vs.iter().copied().fold(Vec3::splat(f32::MAX), Vec3::min);
    let hi = vs.iter().copied().fold(Vec3::splat(f32::MIN), Vec3::max);
    let size = (hi - lo).length();
    if !size.is_finite() {
        return Err("the vertices must be finite after the transform".into());
    }
    if size == 0.0 || n.length() <= 1e-10 * size * size {
        return Err(format!("the {what} has zero area"));
    }
    let n = n.normalize();
    let centre = vs.iter().copied().sum::<Vec3>() / vs.len() as f32;
    for (i, v) in vs.iter().enumerate() {
        let off = (*v - centre).dot(n).abs();
        if off > 1e-4 * size {
            return Err(format!(
                "the {what} is not planar: vertex {i} is {off} away from its mean plane"
            ));
        }
    }
    for i in 0..vs.len() {
        let (a, b, c) = (vs[i], vs[(i + 1) % vs.len()], vs[(i + 2) % vs.len()]);
        if (b - a).cross(c - b).dot(n) < -1e-6 * size * size {
            return Err(format!(
                "the {what} is not convex (at vertex {})",
                (i + 1) % vs.len()
            ));
        }
    }
    Ok(n)
}

// ------------------------------------------------------------------------------------------
// Building the scene.

struct Builder<'a> {
    ctx: Ctx<'a>,
    /// Directory that relative mesh paths start from.
    dir: PathBuf,
    materials: Vec<Material>,
    names: HashMap<String, usize>,
    /// Scene material index of each MTL material already loaded, by OBJ file.
    obj_materials: HashMap<PathBuf, Vec<usize>>,
}

impl<'a> Builder<'a> {
    fn new(ctx: Ctx<'a>) -> Self {
        let dir = ctx.path.parent().map(Path::to_path_buf).unwrap_or_default();
        Builder {
            ctx,
            dir,
            materials: Vec::new(),
            names: HashMap::new(),
            obj_materials: HashMap::new(),
        }
    }

    fn site(&self, name: String, span: Range<usize>) -> Site {
        Site { name, span }
    }

    fn build(mut self, file: FileDesc) -> crate::Result<Scene> {
        let ctx = self.ctx;
        let Some(camera) = file.camera else {
            return Err(Error::input(
                ctx.path,
                "missing [camera] table: the scene needs a camera (position, look_at, fov)",
            ));
        };
        let camera = self.camera(camera)?;

        let settings = match file.render {
            Some(r) => self.render(r)?,
            None => RenderSettings::default(),
        };
        let mut environment = None;
        let (ambient, background) = match file.world {
            Some(world) => {
                let site = self.site("world".into(), world.span());
                let mut world = world.into_inner();
                if let Some(env) = world.environment.take() {
                    environment = Some(std::sync::Arc::new(self.environment(&site, env)?));
                }
                let get = |v: Option<Splat3>, key: &str| -> crate::Result<Rgb> {
                    v.map_or(Ok(Rgb::ZERO), |c| {
                        colour(c.0).map_err(|m| ctx.fail(&site, key, m))
                    })
                };
                (
                    get(world.ambient, "ambient")?,
                    get(world.background, "background")?,
                )
            }
            None => (Rgb::ZERO, Rgb::ZERO),
        };

        for (name, desc) in file.materials.0 {
            let site = self.site(format!("materials.{name}"), desc.span());
            let material = self.material(&site, name.clone(), desc.into_inner())?;
            self.names.insert(name, self.materials.len());
            self.materials.push(material);
        }

        if file.shapes.is_empty() {
            return Err(Error::input(
                ctx.path,
                "the scene has no shapes: add at least one [[shapes]] table",
            ));
        }
        let mut shapes = Vec::new();
        for (i, desc) in file.shapes.into_iter().enumerate() {
            let site = self.site(format!("shapes[{i}]"), desc.span());
            shapes.extend(self.shape(&site, desc.into_inner())?);
        }

        let mut lights = Vec::new();
        for (i, desc) in file.lights.into_iter().enumerate() {
            let site = self.site(format!("lights[{i}]"), desc.span());
            lights.push(self.light(&site, desc.into_inner())?);
        }

        Ok(Scene {
            source: ctx.path.to_path_buf(),
            camera,
            materials: self.materials,
            shapes,
            lights,
            ambient,
            background,
            environment,
            settings,
            warnings: Vec::new(),
        })
    }

    fn camera(&self, desc: Spanned<CameraDesc>) -> crate::Result<Camera> {
        let ctx = self.ctx;
        let site = self.site("camera".into(), desc.span());
        let desc = desc.into_inner();
        let at = |key: &str, r: Result<Vec3, String>| r.map_err(|m| ctx.fail(&site, key, m));
        let position = at("position", finite3(desc.position.0))?;
        let look_at = at("look_at", finite3(desc.look_at.0))?;
        let up = at("up", direction(desc.up.map_or(Vec3::Y, |v| v.0)))?;
        let forward = look_at - position;
        if forward.length() <= 1e-6 * (1.0 + position.abs().max_element()) {
            return Err(ctx.fail(
                &site,
                "look_at",
                format!("must differ from the camera position {position}"),
            ));
        }
        if forward.normalize().cross(up).length() < 1e-4 {
            return Err(ctx.fail(
                &site,
                "up",
                format!("must not be parallel to the viewing direction, got {up}"),
            ));
        }
        let fov = desc.fov.unwrap_or(45.0);
        if !(fov > 0.0 && fov < 180.0) {
            return Err(ctx.fail(
                &site,
                "fov",
                format!("must be in (0, 180) degrees, got {fov}"),
            ));
        }
        let width =
            resolution(desc.width.unwrap_or(640)).map_err(|m| ctx.fail(&site, "width", m))?;
        let height =
            resolution(desc.height.unwrap_or(480)).map_err(|m| ctx.fail(&site, "height", m))?;
        Ok(Camera {
            position,
            look_at,
            up,
            fov_deg: fov,
            width,
            height,
        })
    }

    fn material(&self, site: &Site, name: String, desc: MaterialDesc) -> crate::Result<Material> {
        let ctx = self.ctx;
        let fail = |key: &'static str| move |m: String| ctx.fail(site, key, m);
        let d = Material::default();
        let col = |v: Option<Splat3>, key: &'static str, default: Rgb| -> crate::Result<Rgb> {
            v.map_or(Ok(default), |c| colour(c.0).map_err(fail(key)))
        };
        let diffuse = match desc.diffuse {
            None => d.diffuse,
            Some(DiffuseDesc::Colour(c)) => Texture::Constant(colour(c).map_err(fail("diffuse"))?),
            Some(DiffuseDesc::Texture(t)) => self.texture(site, t)?,
        };
        let ambient = match desc.ambient {
            None => None,
            Some(c) => Some(colour(c.0).map_err(fail("ambient"))?),
        };
        Ok(Material {
            name,
            diffuse,
            ambient,
            specular: col(desc.specular, "specular", d.specular)?,
            transmission: col(desc.transmission, "transmission", d.transmission)?,
            ior: positive(desc.ior.unwrap_or(d.ior)).map_err(fail("ior"))?,
            phong_exponent: non_negative(desc.phong_exponent.unwrap_or(d.phong_exponent))
                .map_err(fail("phong_exponent"))?,
            roughness: non_negative(desc.roughness.unwrap_or(d.roughness))
                .map_err(fail("roughness"))?,
            fresnel: desc.fresnel.unwrap_or(d.fresnel),
            emission: col(desc.emission, "emission", d.emission)?,
        })
    }

    fn texture(&self, site: &Site, t: TextureTable) -> crate::Result<Texture> {
        let ctx = self.ctx;
        let fail = |key: &'static str| move |m: String| ctx.fail(site, key, m);
        let count = [
            t.checker.is_some(),
            t.uv_checker.is_some(),
            t.image.is_some(),
        ]
        .iter()
        .filter(|&&b| b)
        .count();
        if count != 1 {
            return Err(ctx.fail(
                site,
                "diffuse",
                "a texture table takes exactly one of checker, uv_checker or image",
            ));
        }
        let mapping = |us: Option<f32>, vs: Option<f32>, ud: Option<f32>, vd: Option<f32>| {
            let f = |v: Option<f32>, d: f32| finite(v.unwrap_or(d));
            Ok::<_, String>(UvMapping {
                scale: Vec2::new(f(us, 1.0)?, f(vs, 1.0)?),
                offset: Vec2::new(f(ud, 0.0)?, f(vd, 0.0)?),
            })
        };
        if let Some(c) = t.checker {
            return Ok(Texture::Checker {
                even: colour(c.even.0).map_err(fail("diffuse.checker.even"))?,
                odd: colour(c.odd.0).map_err(fail("diffuse.checker.odd"))?,
                size: positive(c.size.unwrap_or(1.0)).map_err(fail("diffuse.checker.size"))?,
            });
        }
        if let Some(c) = t.uv_checker {
            return Ok(Texture::UvChecker {
                even: colour(c.even.0).map_err(fail("diffuse.uv_checker.even"))?,
                odd: colour(c.odd.0).map_err(fail("diffuse.uv_checker.odd"))?,
                mapping: mapping(c.uscale, c.vscale, c.udelta, c.vdelta)
                    .map_err(fail("diffuse.uv_checker"))?,
            });
        }
        let i = t.image.expect("counted above");
        let path = self.dir.join(&i.file);
        let encoding = match i.encoding {
            None => Encoding::default_for(&path),
            Some(e) => Encoding::parse(&e).ok_or_else(|| {
                ctx.fail(
                    site,
                    "diffuse.image.encoding",
                    format!("must be \"linear\", \"sRGB\" or \"gamma G\", got \"{e}\""),
                )
            })?,
        };
        let scale = non_negative(i.scale.unwrap_or(1.0)).map_err(fail("diffuse.image.scale"))?;
        let mapping =
            mapping(i.uscale, i.vscale, i.udelta, i.vdelta).map_err(fail("diffuse.image"))?;
        let image = ImageTexture::load(
            &path,
            i.file.into(),
            encoding,
            scale,
            i.invert.unwrap_or(false),
            mapping,
        )
        .map_err(|e| ctx.fail(site, "diffuse.image.file", e))?;
        Ok(Texture::Image(std::sync::Arc::new(image)))
    }

    fn environment(&self, site: &Site, desc: EnvironmentDesc) -> crate::Result<Environment> {
        let ctx = self.ctx;
        let xf = self.transform(site, desc.transform)?;
        let scale = colour(desc.scale.map_or(Vec3::ONE, |s| s.0))
            .map_err(|m| ctx.fail(site, "environment.scale", m))?;
        let path = self.dir.join(&desc.file);
        Environment::load(&path, desc.file.into(), Mat3::from_mat4(xf.m), scale)
            .map_err(|e| ctx.fail(site, "environment.file", e))
    }

    fn render(&self, desc: Spanned<RenderDesc>) -> crate::Result<RenderSettings> {
        let ctx = self.ctx;
        let site = self.site("render".into(), desc.span());
        let desc = desc.into_inner();
        if desc.spp == Some(0) {
            return Err(ctx.fail(&site, "spp", "must be at least 1"));
        }
        let filter = match desc.filter {
            None => None,
            Some(f) => {
                let radius = f.radius;
                let filter = match f.kind.as_str() {
                    "box" => Filter::Box {
                        radius: radius.unwrap_or(0.5),
                    },
                    "triangle" => Filter::Triangle {
                        radius: radius.unwrap_or(2.0),
                    },
                    "gaussian" => Filter::Gaussian {
                        radius: radius.unwrap_or(1.5),
                        sigma: f.sigma.unwrap_or(0.5),
                    },
                    other => {
                        return Err(ctx.fail(
                            &site,
                            "filter.type",
                            format!(
                                "must be \"box\", \"triangle\" or \"gaussian\", got \"{other}\""
                            ),
                        ))
                    }
                };
                if f.sigma.is_some() && !matches!(filter, Filter::Gaussian { .. }) {
                    return Err(ctx.fail(
                        &site,
                        "filter.sigma",
                        "only a gaussian filter takes sigma",
                    ));
                }
                filter
                    .validate()
                    .map_err(|m| ctx.fail(&site, "filter", m))?;
                Some(filter)
            }
        };
        Ok(RenderSettings {
            integrator: desc.integrator,
            spp: desc.spp,
            max_depth: desc.max_depth,
            filter,
        })
    }

    fn ply(
        &self,
        site: &Site,
        file: &str,
        material: usize,
        xf: &Xform,
    ) -> crate::Result<Vec<Shape>> {
        let ctx = self.ctx;
        let path = self.dir.join(file);
        let mut mesh = super::ply::read(&path).map_err(|e| ctx.fail(site, "file", e))?;
        xf.place(&mut mesh.positions, &mut mesh.normals);
        if xf.flips {
            for t in &mut mesh.triangles {
                t.swap(1, 2);
            }
            for q in &mut mesh.quads {
                q.swap(1, 3);
            }
        }
        let shapes: Vec<Shape> = mesh
            .into_geometry()
            .into_iter()
            .map(|geometry| Shape { geometry, material })
            .collect();
        if shapes.iter().any(|s| !geometry_is_finite(&s.geometry)) {
            return Err(ctx.fail(
                site,
                "transform",
                "moves the shape out of the range of finite numbers",
            ));
        }
        if shapes.iter().all(|s| s.geometry.area() <= 0.0) {
            return Err(ctx.fail(
                site,
                "file",
                format!("{}: the mesh has no faces with area", path.display()),
            ));
        }
        Ok(shapes)
    }

    fn material_index(&self, site: &Site, name: &str) -> crate::Result<usize> {
        self.names.get(name).copied().ok_or_else(|| {
            let mut known: Vec<&str> = self.materials.iter().map(|m| m.name.as_str()).collect();
            known.truncate(12);
            let known = if known.is_empty() {
                "no [materials.NAME] tables are defined".to_string()
            } else {
                format!("defined: {}", known.join(", "))
            };
            self.ctx.fail(
                site,
                "material",
                format!("unknown material `{name}` ({known})"),
            )
        })
    }

    fn transform(&self, site: &Site, desc: Option<OneOrMany<TransformOp>>) -> crate::Result<Xform> {
        let ctx = self.ctx;
        let (ops, single) = match desc {
            None => (Vec::new(), true),
            Some(OneOrMany::One(op)) => (vec![op], true),
            Some(OneOrMany::Many(ops)) => (ops, false),
        };
        let mut m = Mat4::IDENTITY;
        for (i, op) in ops.into_iter().enumerate() {
            let field = if single {
                "transform".to_string()
            } else {
                format!("transform[{i}]")
            };
            let fail = |key: &str, msg: String| {
                let f = if key.is_empty() {
                    field.clone()
                } else {
                    format!("{field}.{key}")
                };
                ctx.fail(site, &f, msg)
            };
            let count = [
                op.translate.is_some(),
                op.rotate.is_some(),
                op.scale.is_some(),
                op.matrix.is_some(),
            ]
            .iter()
            .filter(|&&b| b)
            .count();
            if count != 1 {
                return Err(fail(
                    "",
                    format!(
                        "each step takes exactly one of translate, rotate, scale or matrix \
                         (found {count}); use an array of steps to combine them"
                    ),
                ));
            }
            let step = if let Some(t) = op.translate {
                Mat4::from_translation(finite3(t.0).map_err(|e| fail("translate", e))?)
            } else if let Some(r) = op.rotate {
                let axis = direction(r.axis.0).map_err(|e| fail("rotate.axis", e))?;
                let deg = finite(r.degrees).map_err(|e| fail("rotate.degrees", e))?;
                Mat4::from_axis_angle(axis, deg.to_radians())
            } else if let Some(s) = op.scale {
                let s = finite3(s.0).map_err(|e| fail("scale", e))?;
                if s.abs().min_element() == 0.0 {
                    return Err(fail("scale", format!("must not be zero, got {s}")));
                }
                Mat4::from_scale(s)
            } else if let Some(rows) = op.matrix {
                matrix(&rows).map_err(|e| fail("matrix", e))?
            } else {
                Mat4::IDENTITY
            };
            // Steps apply in order: the later one acts on the result of the earlier.
            m = step * m;
        }
        Xform::new(m).map_err(|e| ctx.fail(site, "transform", e))
    }

    fn shape(&mut self, site: &Site, mut desc: ShapeDesc) -> crate::Result<Vec<Shape>> {
        let ctx = self.ctx;
        let kind = desc.kind;
        for p in desc.present() {
            if !kind.params().contains(&p) {
                return Err(ctx.fail(
                    site,
                    p,
                    format!(
                        "a {} does not take `{p}` (it takes {})",
                        kind.name(),
                        kind.params().join(", ")
                    ),
                ));
            }
        }
        let material = match (&desc.material, kind) {
            (Some(name), _) => Some(self.material_index(site, name)?),
            (None, ShapeKind::Obj) => None,
            (None, _) => {
                return Err(ctx.fail(
                    site,
                    "",
                    format!("a {} needs `material = \"NAME\"`", kind.name()),
                ))
            }
        };
        let required = |v: bool, key: &str| {
            if v {
                Ok(())
            } else {
                Err(ctx.fail(site, "", format!("a {} needs `{key}`", kind.name())))
            }
        };
        let xf = self.transform(site, desc.transform.take())?;
        let fail = |key: &'static str| move |m: String| ctx.fail(site, key, m);

        let geometry = match kind {
            ShapeKind::Sphere => {
                let center =
                    finite3(desc.center.map_or(Vec3::ZERO, |c| c.0)).map_err(fail("center"))?;
                let radius = positive(desc.radius.unwrap_or(1.0)).map_err(fail("radius"))?;
                let scale = xf.uniform_scale().ok_or_else(|| {
                    ctx.fail(
                        site,
                        "transform",
                        "a sphere cannot take a non-uniform scale or shear (it would be an \
                         ellipsoid)",
                    )
                })?;
                Geometry::Sphere {
                    center: xf.point(center),
                    radius: radius * scale,
                }
            }
            ShapeKind::Quad => {
                required(desc.vertices.is_some(), "vertices")?;
                let vs = self.vertices(site, desc.vertices.unwrap_or_default(), &xf)?;
                if vs.len() != 4 {
                    return Err(ctx.fail(
                        site,
                        "vertices",
                        format!("a quad has exactly 4 vertices, got {}", vs.len()),
                    ));
                }
                planar_convex(&vs, "quad").map_err(fail("vertices"))?;
                Geometry::Quads(QuadMesh {
                    positions: vs,
                    indices: vec![[0, 1, 2, 3]],
                })
            }
            ShapeKind::Polygon => {
                required(desc.vertices.is_some(), "vertices")?;
                let vs = self.vertices(site, desc.vertices.unwrap_or_default(), &xf)?;
                if vs.len() < 3 {
                    return Err(ctx.fail(
                        site,
                        "vertices",
                        format!("a polygon has at least 3 vertices, got {}", vs.len()),
                    ));
                }
                planar_convex(&vs, "polygon").map_err(fail("vertices"))?;
                let indices = (1..vs.len() as u32 - 1).map(|i| [0, i, i + 1]).collect();
                Geometry::Triangles(TriangleMesh {
                    positions: vs,
                    normals: None,
                    uvs: None,
                    indices,
                })
            }
            ShapeKind::Mesh => {
                required(desc.positions.is_some(), "positions")?;
                required(desc.indices.is_some(), "indices")?;
                let mesh = self.mesh(site, desc, &xf)?;
                Geometry::Triangles(mesh)
            }
            ShapeKind::Obj => {
                required(desc.file.is_some(), "file")?;
                let file = desc.file.unwrap_or_default();
                return self.obj(site, &file, material, &xf);
            }
            ShapeKind::Ply => {
                required(desc.file.is_some(), "file")?;
                let file = desc.file.unwrap_or_default();
                return self.ply(site, &file, material.unwrap_or_default(), &xf);
            }
        };
        if !geometry_is_finite(&geometry) {
            return Err(ctx.fail(
                site,
                "transform",
                "moves the shape out of the range of finite numbers",
            ));
        }
        Ok(vec![Shape {
            geometry,
            material: material.unwrap_or_default(),
        }])
    }

    /// Checks and transforms a vertex list; keeps the order unless the transform mirrors.
    fn vertices(&self, site: &Site, vs: Vec<V3>, xf: &Xform) -> crate::Result<Vec<Vec3>> {
        let mut out = Vec::with_capacity(vs.len());
        for (i, v) in vs.into_iter().enumerate() {
            let v = finite3(v.0).map_err(|m| self.ctx.fail(site, &format!("vertices[{i}]"), m))?;
            out.push(xf.point(v));
        }
        if xf.flips && out.len() > 1 {
            // A mirror reverses the winding; reverse it back so faces keep their side.
            out[1..].reverse();
        }
        Ok(out)
    }

    fn mesh(&self, site: &Site, desc: ShapeDesc, xf: &Xform) -> crate::Result<TriangleMesh> {
        let ctx = self.ctx;
        let field = |name: &str, i: usize| format!("{name}[{i}]");
        let positions = desc.positions.unwrap_or_default();
        let indices = desc.indices.unwrap_or_default();
        let n = positions.len();
        let mut mesh = TriangleMesh::default();
        for (i, p) in positions.into_iter().enumerate() {
            let p = finite3(p.0).map_err(|m| ctx.fail(site, &field("positions", i), m))?;
            let p = xf.point(p);
            if !p.is_finite() {
                return Err(ctx.fail(
                    site,
                    "transform",
                    "moves the shape out of the range of finite numbers",
                ));
            }
            mesh.positions.push(p);
        }
        if indices.is_empty() {
            return Err(ctx.fail(site, "indices", "the mesh has no triangles"));
        }
        for (i, Idx3(tri)) in indices.into_iter().enumerate() {
            if let Some(&k) = tri.iter().find(|&&k| k as usize >= n) {
                return Err(ctx.fail(
                    site,
                    &field("indices", i),
                    format!("vertex index {k} out of range (the mesh has {n} positions)"),
                ));
            }
            let [a, b, c] = tri;
            mesh.indices
                .push(if xf.flips { [a, c, b] } else { [a, b, c] });
        }
        if let Some(normals) = desc.normals {
            if normals.len() != n {
                return Err(ctx.fail(
                    site,
                    "normals",
                    format!("needs one normal per position ({n}), got {}", normals.len()),
                ));
            }
            let mut out = Vec::with_capacity(n);
            for (i, v) in normals.into_iter().enumerate() {
                let v = direction(v.0).map_err(|m| ctx.fail(site, &field("normals", i), m))?;
                out.push(xf.normal(v));
            }
            mesh.normals = Some(out);
        }
        if let Some(uvs) = desc.uvs {
            if uvs.len() != n {
                return Err(ctx.fail(
                    site,
                    "uvs",
                    format!("needs one uv per position ({n}), got {}", uvs.len()),
                ));
            }
            let mut out = Vec::with_capacity(n);
            for (i, V2(uv)) in uvs.into_iter().enumerate() {
                if !uv.is_finite() {
                    return Err(ctx.fail(
                        site,
                        &field("uvs", i),
                        format!("must be finite, got {uv}"),
                    ));
                }
                out.push(uv);
            }
            mesh.uvs = Some(out);
        }
        check_area(&mesh).map_err(|m| ctx.fail(site, "positions", m))?;
        Ok(mesh)
    }

    fn obj(
        &mut self,
        site: &Site,
        file: &str,
        material: Option<usize>,
        xf: &Xform,
    ) -> crate::Result<Vec<Shape>> {
        let ctx = self.ctx;
        let path = self.dir.join(file);
        let data = obj::load(&path, material.is_none()).map_err(|e| ctx.fail(site, "file", e))?;
        let mapping = match material {
            Some(_) => Vec::new(),
            None => match self.obj_materials.get(&path) {
                Some(m) => m.clone(),
                None => {
                    let mut m = Vec::new();
                    for mat in data.materials {
                        m.push(self.materials.len());
                        self.materials.push(mat);
                    }
                    self.obj_materials.insert(path.clone(), m.clone());
                    m
                }
            },
        };
        let mut shapes = Vec::new();
        for group in data.groups {
            let index = match material {
                Some(i) => i,
                None => group
                    .material
                    .and_then(|k| mapping.get(k).copied())
                    .ok_or_else(|| {
                        ctx.fail(
                            site,
                            "file",
                            format!(
                                "{}: object `{}` has faces without a material; give the shape \
                                 a `material`",
                                path.display(),
                                group.name
                            ),
                        )
                    })?,
            };
            let mut mesh = group.mesh;
            xf.place(&mut mesh.positions, &mut mesh.normals);
            if xf.flips {
                for t in &mut mesh.indices {
                    t.swap(1, 2);
                }
            }
            let geometry = Geometry::Triangles(mesh);
            if !geometry_is_finite(&geometry) {
                return Err(ctx.fail(
                    site,
                    "transform",
                    "moves the shape out of the range of finite numbers",
                ));
            }
            shapes.push(Shape {
                geometry,
                material: index,
            });
        }
        if shapes.iter().all(|s| s.geometry.area() <= 0.0) {
            return Err(ctx.fail(
                site,
                "file",
                format!("{}: the mesh has no triangles with area", path.display()),
            ));
        }
        Ok(shapes)
    }

    fn light(&self, site: &Site, desc: LightDesc) -> crate::Result<Light> {
        let ctx = self.ctx;
        let (name, takes, allowed): (&str, &str, [&str; 2]) = match desc.kind {
            LightKind::Point => ("point", "position, intensity", ["position", "intensity"]),
            LightKind::Directional => (
                "directional",
                "direction, irradiance",
                ["direction", "irradiance"],
            ),
        };
        let present = [
            ("position", desc.position.is_some()),
            ("intensity", desc.intensity.is_some()),
            ("direction", desc.direction.is_some()),
            ("irradiance", desc.irradiance.is_some()),
        ];
        for (key, is) in present {
            if is && !allowed.contains(&key) {
                return Err(ctx.fail(
                    site,
                    key,
                    format!("a {name} light does not take `{key}` (it takes {takes})"),
                ));
            }
        }
        let need = |key: &str| ctx.fail(site, "", format!("a {name} light needs `{key}`"));
        let fail = |key: &'static str| move |m: String| ctx.fail(site, key, m);
        Ok(match desc.kind {
            LightKind::Point => Light::Point {
                position: finite3(desc.position.ok_or_else(|| need("position"))?.0)
                    .map_err(fail("position"))?,
                intensity: colour(desc.intensity.ok_or_else(|| need("intensity"))?.0)
                    .map_err(fail("intensity"))?,
            },
            LightKind::Directional => Light::Directional {
                direction: direction(desc.direction.ok_or_else(|| need("direction"))?.0)
                    .map_err(fail("direction"))?,
                irradiance: colour(desc.irradiance.ok_or_else(|| need("irradiance"))?.0)
                    .map_err(fail("irradiance"))?,
            },
        })
    }
}

/// A 4x4 affine matrix written as rows.
fn matrix(rows: &[Vec<f32>]) -> Result<Mat4, String> {
    if rows.len() != 4 || rows.iter().any(|r| r.len() != 4) {
        return Err("must be 4 rows of 4 numbers".into());
    }
    let mut a = [[0.0f32; 4]; 4];
    for (i, row) in rows.iter().enumerate() {
        for (j, &x) in row.iter().enumerate() {
            a[i][j] = finite(x)?;
        }
    }
    if a[3] != [0.0, 0.0, 0.0, 1.0] {
        return Err(format!(
            "must be affine: the last row must be [0, 0, 0, 1], got {:?}",
            a[3]
        ));
    }
    // glam takes columns; the file gives rows.
    Ok(Mat4::from_cols_array_2d(&a).transpose())
}

fn geometry_is_finite(g: &Geometry) -> bool {
    match g {
        Geometry::Sphere { center, radius } => center.is_finite() && radius.is_finite(),
        Geometry::Triangles(m) => m.positions.iter().all(|p| p.is_finite()),
        Geometry::Quads(q) => q.positions.iter().all(|p| p.is_finite()),
    }
}

/// A mesh must have at least one triangle with area.
pub(crate) fn check_area(mesh: &TriangleMesh) -> Result<(), String> {
    let any = mesh.indices.iter().any(|t| {
        let [a, b, c] = t.map(|k| {
            mesh.positions
                .get(k as usize)
                .copied()
                .unwrap_or(Vec3::ZERO)
        });
        triangle_area(a, b, c) > 0.0
    });
    if any {
        Ok(())
    } else {
        Err(format!(
            "all {} triangles are degenerate (zero area)",
            mesh.indices.len()
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> crate::Result<Scene> {
        from_str(text, Path::new("test.toml"))
    }

    const CAMERA: &str = "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n";

    #[test]
    fn minimal_scene() {
        let s = parse(&format!(
            "{CAMERA}[materials.white]\ndiffuse = 0.8\n[[shapes]]\ntype = \"sphere\"\n\
             material = \"white\"\nradius = 2\n"
        ))
        .unwrap();
        assert_eq!(s.camera.width, 640);
        assert_eq!(s.camera.height, 480);
        assert_eq!(s.materials[0].diffuse, Texture::Constant(Vec3::splat(0.8)));
        assert_eq!(
            s.shapes[0].geometry,
            Geometry::Sphere {
                center: Vec3::ZERO,
                radius: 2.0
            }
        );
    }

    #[test]
    fn semantic_errors_name_the_line_of_the_key() {
        let text = format!(
            "{CAMERA}[materials.white]\n\n[[shapes]]\ntype = \"sphere\"\nmaterial = \"white\"\n\
             radius = -1\n"
        );
        let e = parse(&text).unwrap_err().to_string();
        assert_eq!(
            e,
            "test.toml: line 9: shapes[0].radius: must be positive, got -1"
        );
    }

    #[test]
    fn toml_errors_are_one_line() {
        let e = parse(&format!("{CAMERA}fov = \"wide\"\n"))
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("test.toml: line 4, column 7: invalid type"),
            "{e}"
        );
        assert!(!e.contains('\n'));
        let e = parse(&format!(
            "{CAMERA}[[shapes]]\ntype = \"sphere\"\nradiu = 1\n"
        ))
        .unwrap_err()
        .to_string();
        assert!(e.contains("line 6, column 1: unknown field `radiu`"), "{e}");
    }

    #[test]
    fn inline_tables_and_transform_steps() {
        let s = parse(&format!(
            "{CAMERA}[materials.m]\n[[shapes]]\ntype = \"quad\"\nmaterial = \"m\"\n\
             vertices = [[0,0,0],[1,0,0],[1,1,0],[0,1,0]]\n\
             transform = [{{ scale = 2 }}, {{ rotate = {{ axis = [0,1,0], degrees = 90 }} }}, \
             {{ translate = [0, 0, 1] }}]\n"
        ))
        .unwrap();
        let Geometry::Quads(q) = &s.shapes[0].geometry else {
            panic!("not a quad")
        };
        // (1,0,0) scaled to (2,0,0), rotated 90 degrees about +y to (0,0,-2), moved to z=-1.
        assert!((q.positions[1] - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-5);
    }
}
