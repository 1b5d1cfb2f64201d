//! `[media.NAME]`: a participating medium, and a shape's `media = { inside = "NAME" }`.

use super::schema::{OneOrMany, Splat3, TransformOp, V3};
use super::schema_values::{opt_f32, Idx3};
use serde::{Deserialize, Serialize};

/// A medium: `type = "homogeneous"`, `"uniformgrid"`, `"rgbgrid"` or `"nanovdb"`, its
/// coefficients and, for a grid, its samples (or file).
#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct MediumDesc {
    #[serde(rename = "type")]
    pub(crate) kind: String,
    /// Absorption per unit length (at density 1 for a grid).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) sigma_a: Option<Splat3>,
    /// Scattering per unit length (at density 1 for a grid).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) sigma_s: Option<Splat3>,
    /// Scales `sigma_a` and `sigma_s`.
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) scale: Option<f32>,
    /// Emitted radiance (the medium emits sigma_a times it per unit length).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) emission: Option<Splat3>,
    /// Henyey–Greenstein asymmetry.
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) g: Option<f32>,
    /// A grid's samples along x, y, z.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) resolution: Option<Idx3>,
    /// A grid's densities, x fastest.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) density: Option<Vec<f32>>,
    /// A grid's emission scale per sample, x fastest (default 1).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) emission_scale: Option<Vec<f32>>,
    /// An rgbgrid's absorption per sample: three numbers a sample, x fastest (default 1).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) sigma_a_grid: Option<Vec<f32>>,
    /// An rgbgrid's scattering per sample, the same layout (default 1).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) sigma_s_grid: Option<Vec<f32>>,
    /// An rgbgrid's emitted radiance per sample, the same layout (default 0).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) emission_grid: Option<Vec<f32>>,
    /// A nanovdb medium's NanoVDB file, relative to the scene file.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) file: Option<String>,
    /// The float grid of the file to read (default "density").
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) grid: Option<String>,
    /// The box a grid spans in its own space: two corners (default [0, 0, 0] to [1, 1, 1]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) bounds: Option<[V3; 2]>,
    /// Places a grid's own space in the world (default: they are the same).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) transform: Option<OneOrMany<TransformOp>>,
}

/// A shape's `media`: the media inside and outside its surface (absent: vacuum).
#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ShapeMediaDesc {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) inside: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) outside: Option<String>,
}
