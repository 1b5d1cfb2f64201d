//! A shape's `alpha`: a number in [0, 1], or `{ image = { file = "leaf.png", .. } }` whose
//! first channel is the alpha (the same image table as a colour texture's).

use super::schema::TextureTable;
use serde::de::{self, Deserializer, MapAccess, Visitor};
use serde::ser::Serializer;
use serde::{Deserialize, Serialize};
use std::fmt;

pub(crate) enum AlphaDesc {
    Constant(f64),
    Texture(TextureTable),
}

impl<'de> Deserialize<'de> for AlphaDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Vis;
        impl<'de> Visitor<'de> for Vis {
            type Value = AlphaDesc;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number in [0, 1] or a table { image = { file = \"..\" } }")
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<AlphaDesc, E> {
                Ok(AlphaDesc::Constant(v as f64))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<AlphaDesc, E> {
                Ok(AlphaDesc::Constant(v as f64))
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<AlphaDesc, E> {
                Ok(AlphaDesc::Constant(v))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<AlphaDesc, A::Error> {
                TextureTable::deserialize(de::value::MapAccessDeserializer::new(map))
                    .map(AlphaDesc::Texture)
            }
        }
        d.deserialize_any(Vis)
    }
}

impl Serialize for AlphaDesc {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            AlphaDesc::Constant(a) => s.serialize_f64(*a),
            AlphaDesc::Texture(t) => t.serialize(s),
        }
    }
}
