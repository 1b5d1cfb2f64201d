//! The scene file's values for metals: `conductor` (a named metal or its complex index) and
//! `roughness` (one α, or α along the tangent and the bitangent).

use super::schema::Splat3;
use super::schema_texture::{DiffuseDesc, TextureTable};
use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};
use serde::ser::{SerializeSeq, Serializer};
use serde::{Deserialize, Serialize};
use std::fmt;

/// `conductor = "Cu"`, `conductor = { eta = [r, g, b], k = [r, g, b] }` or `conductor =
/// { reflectance = colour or texture }` (the normal-incidence reflectance, pbrt's).
pub(crate) enum ConductorDesc {
    Named(String),
    Index(ConductorIndex),
    Reflectance(DiffuseDesc),
}

/// The table form, before it is told apart.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ConductorTable {
    eta: Option<Splat3>,
    k: Option<Splat3>,
    reflectance: Option<DiffuseDesc>,
}

#[derive(Serialize)]
struct ReflectanceTable<'a> {
    reflectance: &'a DiffuseDesc,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ConductorIndex {
    pub(crate) eta: Splat3,
    pub(crate) k: Splat3,
}

impl<'de> Deserialize<'de> for ConductorDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Vis;
        impl<'de> Visitor<'de> for Vis {
            type Value = ConductorDesc;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a metal's name (\"Cu\", \"Au\", \"Ag\", \"Al\", ..) or a table { eta = [r, g, b], k = [r, g, b] }")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<ConductorDesc, E> {
                Ok(ConductorDesc::Named(v.to_string()))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<ConductorDesc, A::Error> {
                let t = ConductorTable::deserialize(de::value::MapAccessDeserializer::new(map))?;
                match (t.eta, t.k, t.reflectance) {
                    (Some(eta), Some(k), None) => {
                        Ok(ConductorDesc::Index(ConductorIndex { eta, k }))
                    }
                    (None, None, Some(r)) => Ok(ConductorDesc::Reflectance(r)),
                    _ => Err(de::Error::custom(
                        "a conductor table takes `eta` and `k`, or `reflectance` alone",
                    )),
                }
            }
        }
        d.deserialize_any(Vis)
    }
}

impl Serialize for ConductorDesc {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            ConductorDesc::Named(n) => s.serialize_str(n),
            ConductorDesc::Index(i) => i.serialize(s),
            ConductorDesc::Reflectance(r) => ReflectanceTable { reflectance: r }.serialize(s),
        }
    }
}

/// `roughness = 0.2`, `roughness = [0.1, 0.4]` (anisotropic: α_x, α_y) or a texture table
/// of α.
pub(crate) enum RoughnessDesc {
    Isotropic(f32),
    Anisotropic(f32, f32),
    Texture(Box<TextureTable>),
}

impl<'de> Deserialize<'de> for RoughnessDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Vis;
        impl<'de> Visitor<'de> for Vis {
            type Value = RoughnessDesc;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number, an array of 2 numbers [u, v] or a texture table")
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<RoughnessDesc, E> {
                Ok(RoughnessDesc::Isotropic(v as f32))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<RoughnessDesc, E> {
                Ok(RoughnessDesc::Isotropic(v as f32))
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<RoughnessDesc, E> {
                Ok(RoughnessDesc::Isotropic(v as f32))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<RoughnessDesc, A::Error> {
                let mut values = Vec::with_capacity(2);
                while let Some(x) = seq.next_element::<f32>()? {
                    values.push(x);
                }
                match *values {
                    [u, v] => Ok(RoughnessDesc::Anisotropic(u, v)),
                    _ => Err(de::Error::invalid_length(values.len(), &self)),
                }
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<RoughnessDesc, A::Error> {
                TextureTable::deserialize(de::value::MapAccessDeserializer::new(map))
                    .map(|t| RoughnessDesc::Texture(Box::new(t)))
            }
        }
        d.deserialize_any(Vis)
    }
}

impl Serialize for RoughnessDesc {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            RoughnessDesc::Isotropic(a) => super::schema::Exact(*a).serialize(s),
            RoughnessDesc::Texture(t) => t.serialize(s),
            &RoughnessDesc::Anisotropic(u, v) => {
                let mut seq = s.serialize_seq(Some(2))?;
                seq.serialize_element(&super::schema::Exact(u))?;
                seq.serialize_element(&super::schema::Exact(v))?;
                seq.end()
            }
        }
    }
}
