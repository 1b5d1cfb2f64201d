//! The scene file's `coating` of a material: a dielectric coat over its diffuse or conductor
//! base (pbrt-v4's coated materials).

use super::schema::{RoughnessDesc, Splat3};
use super::schema_values::opt_f32;
use serde::{Deserialize, Serialize};

/// `coating = { ior = 1.5, roughness = 0.0, thickness = 0.01 }` (and `albedo`, `g`,
/// `max_depth`, `samples`): every key optional, pbrt-v4's defaults.
#[derive(Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct CoatingDesc {
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) ior: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) roughness: Option<RoughnessDesc>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) thickness: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) albedo: Option<Splat3>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) g: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) max_depth: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) samples: Option<u32>,
}
