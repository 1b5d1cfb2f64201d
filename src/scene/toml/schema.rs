//! The file as serde sees it: structures that mirror the scene file table for table. The
//! reader deserialises them (syntax, unknown keys and wrong types are caught here, with
//! toml's line and column) and `raylink convert` serialises them, so the two share one
//! description of the format. Values are checked later, by the builder.

pub(crate) use super::schema_alpha::AlphaDesc;
pub(crate) use super::schema_coating::CoatingDesc;
pub(crate) use super::schema_instance::{InstanceDesc, ObjectDesc};
pub(crate) use super::schema_medium::{MediumDesc, ShapeMediaDesc};
pub(crate) use super::schema_metal::{ConductorDesc, ConductorIndex, RoughnessDesc};
pub(crate) use super::schema_texture::{
    CheckerDesc, DiffuseDesc, DirectionMixDesc, ImageDesc, ScaleDesc, TextureMixDesc, TextureTable,
    UvCheckerDesc,
};
use super::schema_values::{exact_f32, opt_f32, opt_rows};
pub(crate) use super::schema_values::{Exact, Idx3, OneOrMany, Ordered, Splat3, V2, V3};
use serde::ser::Serializer;
use serde::{Deserialize, Serialize};
use toml::Spanned;

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileDesc {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) camera: Option<Spanned<CameraDesc>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) world: Option<Spanned<WorldDesc>>,
    #[serde(default, skip_serializing_if = "Ordered::is_empty")]
    pub(crate) media: Ordered<Spanned<MediumDesc>>,
    #[serde(default, skip_serializing_if = "Ordered::is_empty")]
    pub(crate) materials: Ordered<Spanned<MaterialDesc>>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub(crate) shapes: Vec<Spanned<ShapeDesc>>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub(crate) objects: Vec<Spanned<ObjectDesc>>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub(crate) instances: Vec<Spanned<InstanceDesc>>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub(crate) lights: Vec<Spanned<LightDesc>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) render: Option<Spanned<RenderDesc>>,
}

/// `[render]`: the render settings the scene file carries (command-line options override
/// them). The keys are the settings' names; each technique's own are in a table of its own.
#[derive(Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RenderDesc {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) integrator: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) spp: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) max_depth: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) time_limit: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) adaptive_threshold: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) adaptive_min_samples: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) guiding: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) spectral: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) max_component_value: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) filter: Option<FilterDesc>,
    /// Whitted's and the network's anti-aliasing: "adaptive" or "uniform".
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) aa: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) aa_threshold: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) aa_depth: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) whitted: Option<Spanned<WhittedDesc>>,
    #[serde(rename = "irradiance-cache", skip_serializing_if = "Option::is_none")]
    pub(crate) irradiance_cache: Option<Spanned<CacheDesc>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) network: Option<Spanned<NetworkDesc>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) sppm: Option<Spanned<SppmDesc>>,
    /// The image `raylink render` writes when no `-o` is given (pbrt's `Film "filename"`),
    /// relative to the current directory.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) output: Option<Spanned<String>>,
    /// The colour space of the linear outputs (`srgb`, `rec2020`, `dci-p3`, `aces2065-1`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) color_space: Option<Spanned<String>>,
}

/// `[render.whitted]`.
#[derive(Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct WhittedDesc {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) area_samples: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) fresnel: Option<bool>,
}

/// `[render.irradiance-cache]`.
#[derive(Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct CacheDesc {
    /// Diffuse bounces (Radiance's -ab).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) ab: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) accuracy: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) samples: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) gradients: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) ar: Option<f32>,
    /// Relative to the scene file.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) cache_file: Option<String>,
}

/// `[render.sppm]`.
#[derive(Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SppmDesc {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) photons_per_iteration: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) radius: Option<f32>,
}

/// `[render.network]`.
#[derive(Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct NetworkDesc {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) slopes: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) intercept_step: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) patch_size: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) jitter: Option<f32>,
    /// "scan" or "embree".
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) builder: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) tolerance: Option<f32>,
    /// "cg", "sweeps" or "shoot".
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) order: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) hybrid: Option<bool>,
    /// Relative to the scene file.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) file: Option<String>,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FilterDesc {
    #[serde(rename = "type")]
    pub(crate) kind: String,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) radius: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) sigma: Option<f32>,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct EnvironmentDesc {
    pub(crate) file: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) scale: Option<Splat3>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) transform: Option<OneOrMany<TransformOp>>,
    /// The window through which the map lights an interior: four corners in world space.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) portal: Option<[V3; 4]>,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct CameraDesc {
    pub(crate) position: V3,
    pub(crate) look_at: V3,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) up: Option<V3>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) fov: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) width: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) height: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) projection: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) size: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) lens_radius: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) focal_distance: Option<f32>,
    /// The medium the camera sits in (a name from `[media]`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) medium: Option<String>,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct WorldDesc {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) ambient: Option<Splat3>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) background: Option<Splat3>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) environment: Option<EnvironmentDesc>,
}

#[derive(Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct MaterialDesc {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) diffuse: Option<DiffuseDesc>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) ambient: Option<Splat3>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) specular: Option<DiffuseDesc>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) transmission: Option<Splat3>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) diffuse_transmission: Option<DiffuseDesc>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) ior: Option<f32>,
    /// A named glass: its index at 587.6 nm, and by wavelength in spectral renders.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) glass: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) phong_exponent: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) roughness: Option<RoughnessDesc>,
    /// A textured roughness gives pbrt's roughness r, and α = √r.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) remap_roughness: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) fresnel: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) thin: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) conductor: Option<ConductorDesc>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) emission: Option<DiffuseDesc>,
    /// Emission of a blackbody at this temperature (K): `emission` is then its luminance.
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) emission_temperature: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) two_sided_emission: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) mix: Option<MixDesc>,
    /// A tangent-space normal map (an image file).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) normal_map: Option<String>,
    /// A bump map: displacement along the normal in scene units (a float texture).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) bump: Option<DiffuseDesc>,
    /// Only the boundary of a medium: no other key.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) interface: Option<bool>,
    /// A tabulated BRDF file, in place of the lobes.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) brdf: Option<String>,
    /// A dielectric coat over the diffuse or conductor base.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) coating: Option<CoatingDesc>,
}

/// `mix = { materials = ["a", "b"], amount = 0.3 }`.
#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct MixDesc {
    pub(crate) materials: Vec<String>,
    /// A number or a float texture.
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_amount")]
    pub(crate) amount: Option<DiffuseDesc>,
}

/// A mix's amount: one number when constant, else its texture table.
fn opt_amount<S: Serializer>(v: &Option<DiffuseDesc>, s: S) -> Result<S::Ok, S::Error> {
    match v {
        Some(DiffuseDesc::Colour(c)) => opt_f32(&Some(c.x), s),
        Some(t) => t.serialize(s),
        None => s.serialize_none(),
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize)]
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

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ShapeDesc {
    #[serde(rename = "type")]
    pub(crate) kind: ShapeKind,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) material: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) transform: Option<OneOrMany<TransformOp>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) center: Option<V3>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) radius: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) vertices: Option<Vec<V3>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) positions: Option<Vec<V3>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) indices: Option<Vec<Idx3>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) normals: Option<Vec<V3>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) uvs: Option<Vec<V2>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) file: Option<String>,
    /// Where the surface is present (see `schema_alpha.rs`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) alpha: Option<AlphaDesc>,
    /// Steps that move the shape, after `transform`, by shutter close (motion blur).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) motion: Option<OneOrMany<TransformOp>>,
    /// The media inside and outside the surface.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) media: Option<ShapeMediaDesc>,
}

impl ShapeDesc {
    /// A shape of `kind` without a material or parameters (for writing).
    pub(crate) fn new(kind: ShapeKind) -> ShapeDesc {
        ShapeDesc {
            kind,
            material: None,
            transform: None,
            center: None,
            radius: None,
            vertices: None,
            positions: None,
            indices: None,
            normals: None,
            uvs: None,
            file: None,
            alpha: None,
            motion: None,
            media: None,
        }
    }

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

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct TransformOp {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) translate: Option<V3>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) rotate: Option<RotateDesc>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) scale: Option<Splat3>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_rows")]
    pub(crate) matrix: Option<Vec<Vec<f32>>>,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RotateDesc {
    pub(crate) axis: V3,
    #[serde(serialize_with = "exact_f32")]
    pub(crate) degrees: f32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub(crate) enum LightKind {
    Point,
    Directional,
    Spot,
    Goniometric,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct LightDesc {
    #[serde(rename = "type")]
    pub(crate) kind: LightKind,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) position: Option<V3>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) intensity: Option<Splat3>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) direction: Option<V3>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) irradiance: Option<Splat3>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) cone_angle: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) cone_delta: Option<f32>,
    /// A blackbody's temperature (K): `intensity` or `irradiance` is then its luminance.
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_f32")]
    pub(crate) temperature: Option<f32>,
    /// A goniometric light's image (square, equal-area).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) image: Option<String>,
    /// A goniometric light's frame (its rotation; translations are ignored).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) transform: Option<OneOrMany<TransformOp>>,
}
