//! The scene file's textures: a colour (or a number) or a texture table, wherever a material
//! takes a texture.

use super::schema_values::{numbers, opt_f32, Splat3, Splat3Visitor, V3};
use crate::math::Vec3;
use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};
use serde::ser::Serializer;
use serde::{Deserialize, Serialize};
use std::fmt;

/// A colour (three numbers, or one for grey) or a texture table.
pub(crate) enum DiffuseDesc {
    Colour(Vec3),
    Texture(TextureTable),
}

/// `{ checker = {..} }`, `{ uv_checker = {..} }`, `{ image = {..} }`, `{ scale = {..} }`,
/// `{ mix = {..} }` or `{ direction_mix = {..} }`.
#[derive(Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct TextureTable {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) checker: Option<CheckerDesc>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) uv_checker: Option<UvCheckerDesc>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) image: Option<ImageDesc>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) scale: Option<Box<ScaleDesc>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) mix: Option<Box<TextureMixDesc>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) direction_mix: Option<Box<DirectionMixDesc>>,
}

/// `scale = { texture = T, by = F }`: T times the float texture F.
#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ScaleDesc {
    pub(crate) texture: DiffuseDesc,
    pub(crate) by: DiffuseDesc,
}

/// `mix = { textures = [A, B], amount = F }`: (1 − F)·A + F·B.
#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct TextureMixDesc {
    pub(crate) textures: [DiffuseDesc; 2],
    pub(crate) amount: DiffuseDesc,
}

/// `direction_mix = { textures = [A, B], direction = [x, y, z] }`: |n·d|·A + (1 − |n·d|)·B.
#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct DirectionMixDesc {
    pub(crate) textures: [DiffuseDesc; 2],
    pub(crate) direction: V3,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct UvCheckerDesc {
    pub(crate) even: Splat3,
    pub(crate) odd: Splat3,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) uscale: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) vscale: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) udelta: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) vdelta: Option<f32>,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ImageDesc {
    pub(crate) file: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) encoding: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) scale: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) invert: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) uscale: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) vscale: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) udelta: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) vdelta: Option<f32>,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct CheckerDesc {
    pub(crate) even: Splat3,
    pub(crate) odd: Splat3,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) size: Option<f32>,
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

impl Serialize for DiffuseDesc {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            DiffuseDesc::Colour(c) => numbers(s, &c.to_array()),
            DiffuseDesc::Texture(t) => t.serialize(s),
        }
    }
}
