//! The scene file's value types, with their own deserializers (for clear messages) and
//! serializers (floats written to read back bit for bit): the numbers, vectors, colours and
//! lists every table of the schema is made of.

use crate::math::{Vec2, Vec3};
use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};
use serde::ser::{SerializeMap, SerializeSeq, Serializer};
use serde::{Deserialize, Serialize};
use std::fmt;

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
pub(crate) struct Splat3Visitor;

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

impl<T> Ordered<T> {
    pub(crate) fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

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
// Writing: each value type as the reader takes it (vectors and colours as arrays, so every
// component is written as the scene holds it), and every float so that it reads back to the
// same bits.

/// An `f32` written so that the reader gets the same bits back. The reader parses a TOML
/// float as an `f64` and narrows it to `f32`; the `f32`'s shortest decimal survives that for
/// every `f32` but one pair (checked over all of them): `±7.038531e-26` lies so close to the
/// midpoint between two `f32`s that its `f64` rounds across it. Such a value is written as
/// its `f64`'s decimal instead (up to 17 digits), which reads back exactly.
pub(crate) struct Exact(pub(crate) f32);

impl Serialize for Exact {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let x = self.0;
        let shortest_survives = x
            .to_string()
            .parse::<f64>()
            .is_ok_and(|y| (y as f32).to_bits() == x.to_bits());
        if shortest_survives {
            s.serialize_f32(x)
        } else {
            s.serialize_f64(f64::from(x))
        }
    }
}

pub(super) fn exact_f32<S: Serializer>(x: &f32, s: S) -> Result<S::Ok, S::Error> {
    Exact(*x).serialize(s)
}

pub(super) fn opt_f32<S: Serializer>(x: &Option<f32>, s: S) -> Result<S::Ok, S::Error> {
    x.map(Exact).serialize(s)
}

pub(super) fn opt_rows<S: Serializer>(
    rows: &Option<Vec<Vec<f32>>>,
    s: S,
) -> Result<S::Ok, S::Error> {
    let rows: Option<Vec<Vec<Exact>>> = rows.as_ref().map(|rows| {
        rows.iter()
            .map(|r| r.iter().copied().map(Exact).collect())
            .collect()
    });
    rows.serialize(s)
}

pub(super) fn numbers<S: Serializer>(s: S, values: &[f32]) -> Result<S::Ok, S::Error> {
    let mut seq = s.serialize_seq(Some(values.len()))?;
    for &x in values {
        seq.serialize_element(&Exact(x))?;
    }
    seq.end()
}

impl Serialize for V3 {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        numbers(s, &self.0.to_array())
    }
}

impl Serialize for V2 {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        numbers(s, &self.0.to_array())
    }
}

impl Serialize for Idx3 {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.0.serialize(s)
    }
}

impl Serialize for Splat3 {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        numbers(s, &self.0.to_array())
    }
}

impl<T: Serialize> Serialize for OneOrMany<T> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            OneOrMany::One(x) => x.serialize(s),
            OneOrMany::Many(xs) => xs.serialize(s),
        }
    }
}

impl<T: Serialize> Serialize for Ordered<T> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut map = s.serialize_map(Some(self.0.len()))?;
        for (k, v) in &self.0 {
            map.serialize_entry(k, v)?;
        }
        map.end()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Deserialize, Serialize)]
    struct Doc {
        v: V3,
        #[serde(serialize_with = "exact_f32")]
        degrees: f32,
        #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
        size: Option<f32>,
    }

    /// Floats are written as the shortest decimals that read back to the same bits, or, for
    /// the rare values whose shortest decimal does not survive the reader's f64, as the f64's.
    #[test]
    fn floats_round_trip_exactly() {
        let strided = (0..0x7f80_0000u32).step_by(7919).map(f32::from_bits);
        let special = [
            f32::MIN_POSITIVE,
            f32::MAX,
            f32::EPSILON,
            0.1,
            0.65,
            1e-38,
            3e38,
            // Its shortest decimal, 7.038531e-26, reads back through an f64 as the next f32.
            f32::from_bits(0x15ae_43fd),
        ];
        for x in strided.chain(special) {
            let v = Vec3::new(x, -x, 1.0 / x.max(1e-30));
            let doc = Doc {
                v: V3(v),
                degrees: x,
                size: Some(-x),
            };
            let text = toml::to_string(&doc).unwrap();
            let back: Doc = toml::from_str(&text).unwrap();
            let bits = |v: Vec3| v.to_array().map(f32::to_bits);
            assert_eq!(bits(back.v.0), bits(v), "{text}");
            assert_eq!(back.degrees.to_bits(), x.to_bits(), "{text}");
            assert_eq!(back.size.map(f32::to_bits), Some((-x).to_bits()), "{text}");
        }
        // Tidy where it can be: the shortest decimal.
        let doc = Doc {
            v: V3(Vec3::new(0.65, 1.0, 19.5)),
            degrees: 0.1,
            size: None,
        };
        assert_eq!(
            toml::to_string(&doc).unwrap(),
            "v = [0.65, 1.0, 19.5]\ndegrees = 0.1\n"
        );
    }
}
