//! The scene file's objects (shapes defined once, in their own space) and the instances that
//! place them.

use super::schema::{OneOrMany, ShapeDesc, TransformOp};
use serde::{Deserialize, Serialize};
use toml::Spanned;

/// `[[objects]]`: `name`, and its shapes as `[[objects.shapes]]` tables (the keys of
/// `[[shapes]]`).
#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ObjectDesc {
    pub(crate) name: String,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub(crate) shapes: Vec<Spanned<ShapeDesc>>,
}

/// `[[instances]]`: `object` (a name) placed by `transform`.
#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct InstanceDesc {
    pub(crate) object: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) transform: Option<OneOrMany<TransformOp>>,
}
