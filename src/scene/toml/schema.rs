//! The file as serde sees it: structures that mirror the scene file table for table. The
//! reader deserialises them (syntax, unknown keys and wrong types are caught here, with
//! toml's line and column); the builder checks the values.

use crate::math::{Vec2, Vec3};
use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};
use serde::Deserialize;
use std::fmt;
use toml::Spanned;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileDesc {
    pub(crate) camera: Option<Spanned<CameraDesc>>,
    pub(crate) world: Option<Spanned<WorldDesc>>,
    #[serde(default)]
    pub(crate) materials: Ordered<Spanned<MaterialDesc>>,
    #[serde(default)]
    pub(crate) shapes: Vec<Spanned<ShapeDesc>>,
    #[serde(default)]
    pub(crate) lights: Vec<Spanned<LightDesc>>,
    pub(crate) render: Option<Spanned<RenderDesc>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RenderDesc {
    pub(crate) integrator: Option<String>,
    pub(crate) spp: Option<u32>,
    pub(crate) max_depth: Option<u32>,
    pub(crate) filter: Option<FilterDesc>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FilterDesc {
    #[serde(rename = "type")]
    pub(crate) kind: String,
    pub(crate) radius: Option<f32>,
    pub(crate) sigma: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct EnvironmentDesc {
    pub(crate) file: String,
    pub(crate) scale: Option<Splat3>,
    pub(crate) transform: Option<OneOrMany<TransformOp>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct CameraDesc {
    pub(crate) position: V3,
    pub(crate) look_at: V3,
    pub(crate) up: Option<V3>,
    pub(crate) fov: Option<f32>,
    pub(crate) width: Option<u32>,
    pub(crate) height: Option<u32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct WorldDesc {
    pub(crate) ambient: Option<Splat3>,
    pub(crate) background: Option<Splat3>,
    pub(crate) environment: Option<EnvironmentDesc>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct MaterialDesc {
    pub(crate) diffuse: Option<DiffuseDesc>,
    pub(crate) ambient: Option<Splat3>,
    pub(crate) specular: Option<Splat3>,
    pub(crate) transmission: Option<Splat3>,
    pub(crate) ior: Option<f32>,
    pub(crate) phong_exponent: Option<f32>,
    pub(crate) roughness: Option<f32>,
    pub(crate) fresnel: Option<bool>,
    pub(crate) emission: Option<Splat3>,
}

pub(crate) enum DiffuseDesc {
    Colour(Vec3),
    Texture(TextureTable),
}

/// `{ checker = {..} }`, `{ uv_checker = {..} }` or `{ image = {..} }`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct TextureTable {
    pub(crate) checker: Option<CheckerDesc>,
    pub(crate) uv_checker: Option<UvCheckerDesc>,
    pub(crate) image: Option<ImageDesc>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct UvCheckerDesc {
    pub(crate) even: Splat3,
    pub(crate) odd: Splat3,
    pub(crate) uscale: Option<f32>,
    pub(crate) vscale: Option<f32>,
    pub(crate) udelta: Option<f32>,
    pub(crate) vdelta: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ImageDesc {
    pub(crate) file: String,
    pub(crate) encoding: Option<String>,
    pub(crate) scale: Option<f32>,
    pub(crate) invert: Option<bool>,
    pub(crate) uscale: Option<f32>,
    pub(crate) vscale: Option<f32>,
    pub(crate) udelta: Option<f32>,
    pub(crate) vdelta: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct CheckerDesc {
    pub(crate) even: Splat3,
    pub(crate) odd: Splat3,
    pub(crate) size: Option<f32>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub(crate) enum ShapeKind {
    Sphere,
    Quad,
    Polygon,
    Mesh,
    Obj,
    Ply,
}

impl ShapeKind {
    pub(crate) fn name(self) -> &'static str {
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
    pub(crate) fn params(self) -> &'static [&'static str] {
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
pub(crate) struct ShapeDesc {
    #[serde(rename = "type")]
    pub(crate) kind: ShapeKind,
    pub(crate) material: Option<String>,
    pub(crate) transform: Option<OneOrMany<TransformOp>>,
    pub(crate) center: Option<V3>,
    pub(crate) radius: Option<f32>,
    pub(crate) vertices: Option<Vec<V3>>,
    pub(crate) positions: Option<Vec<V3>>,
    pub(crate) indices: Option<Vec<Idx3>>,
    pub(crate) normals: Option<Vec<V3>>,
    pub(crate) uvs: Option<Vec<V2>>,
    pub(crate) file: Option<String>,
}

impl ShapeDesc {
    /// The kind-specific parameters that are present.
    pub(crate) fn present(&self) -> Vec<&'static str> {
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
pub(crate) struct TransformOp {
    pub(crate) translate: Option<V3>,
    pub(crate) rotate: Option<RotateDesc>,
    pub(crate) scale: Option<Splat3>,
    pub(crate) matrix: Option<Vec<Vec<f32>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RotateDesc {
    pub(crate) axis: V3,
    pub(crate) degrees: f32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub(crate) enum LightKind {
    Point,
    Directional,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct LightDesc {
    #[serde(rename = "type")]
    pub(crate) kind: LightKind,
    pub(crate) position: Option<V3>,
    pub(crate) intensity: Option<Splat3>,
    pub(crate) direction: Option<V3>,
    pub(crate) irradiance: Option<Splat3>,
}

// ------------------------------------------------------------------------------------------
// Value types with their own deserializers (for clear messages).

/// Exactly three numbers `[x, y, z]`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct V3(pub(crate) Vec3);

/// Exactly two numbers `[u, v]`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct V2(pub(crate) Vec2);

/// Exactly three vertex indices.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Idx3(pub(crate) [u32; 3]);

/// Three numbers, or one number standing for three equal ones (a grey, a uniform scale).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Splat3(pub(crate) Vec3);

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
pub(crate) enum OneOrMany<T> {
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
pub(crate) struct Ordered<T>(pub(crate) Vec<(String, T)>);

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
