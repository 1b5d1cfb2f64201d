//! `raylink convert`: writes a [`Scene`] (from any reader) as a native TOML scene. Meshes are
//! referenced, not inlined: each triangle or quad mesh is written, in world space, to a
//! binary PLY file in a `NAME.meshes/` folder beside the output. Image textures and
//! environment maps are referenced by path (relative to the output when possible).
//!
//! The scene is turned into the reader's own schema (`toml/schema.rs`) and written by
//! the `toml` crate, so what is written is what the reader reads: floats are written as the
//! shortest decimals that read back to the same `f32`, strings and keys are quoted where
//! TOML needs it.
//!
//! Everything is written through temporary files renamed into place, the TOML last, so a
//! failed conversion never leaves a half-written scene behind.

use super::toml::schema::{
    AlphaDesc, CacheDesc, CameraDesc, CheckerDesc, CoatingDesc, ConductorDesc, ConductorIndex,
    DiffuseDesc, DirectionMixDesc, EnvironmentDesc, FileDesc, FilterDesc, ImageDesc, InstanceDesc,
    LightDesc, LightKind, MaterialDesc, MixDesc, NetworkDesc, ObjectDesc, OneOrMany, Ordered,
    RenderDesc, RoughnessDesc, ScaleDesc, ShapeDesc, ShapeKind, Splat3, SppmDesc, TextureMixDesc,
    TextureTable, TransformOp, UvCheckerDesc, WhittedDesc, WorldDesc, V3,
};
use super::{
    Alpha, Camera, Classic, Coating, Geometry, Light, Material, NormalDetail, Projection,
    RenderSettings, Scene, Sphere, Surface, Texture,
};
use crate::error::Error;
use crate::image::filter::Filter;
use crate::settings::AntiAliasing;
use crate::spectrum::ColorSpace;
use std::path::{Path, PathBuf};
use toml::Spanned;

mod media;
mod mesh_dir;

use mesh_dir::MeshDir;

/// Reads `input` (.pbrt or .toml) and writes it to `output` as a native TOML scene.
/// Returns the scene read (with its warnings).
pub fn convert(input: &Path, output: &Path) -> crate::error::Result<Scene> {
    let scene = Scene::load(input)?;
    write_toml(&scene, output)?;
    Ok(scene)
}

/// A path written into the TOML: the referenced file as seen from `out_dir`.
fn reference(scene: &Scene, file: &Path, out_dir: &Path) -> String {
    let source_dir = scene.source.parent().unwrap_or(Path::new(""));
    let target = if file.is_absolute() {
        file.to_path_buf()
    } else {
        source_dir.join(file)
    };
    let abs = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    let (target, out_dir) = (abs(&target), abs(out_dir));
    relative(&target, &out_dir)
        .unwrap_or(target)
        .to_string_lossy()
        .into_owned()
}

/// `target` relative to `base` (both absolute), through `..` where needed.
fn relative(target: &Path, base: &Path) -> Option<PathBuf> {
    let t: Vec<_> = target.components().collect();
    let b: Vec<_> = base.components().collect();
    let common = t.iter().zip(&b).take_while(|(x, y)| x == y).count();
    if common == 0 {
        return None;
    }
    let mut out = PathBuf::new();
    for _ in common..b.len() {
        out.push("..");
    }
    for c in &t[common..] {
        out.push(c);
    }
    Some(out)
}

/// The `[camera]` table of a scene file for `camera`, as text to paste into one: what the
/// scene reader reads back as the same camera (floats as their shortest exact decimals).
pub fn camera_toml(camera: &Camera) -> String {
    #[derive(serde::Serialize)]
    struct Table {
        camera: CameraDesc,
    }
    toml::to_string(&Table {
        camera: self::camera(camera),
    })
    .unwrap_or_default()
}

/// Writes `scene` as TOML to `output`, its meshes as PLY files beside it.
pub fn write_toml(scene: &Scene, output: &Path) -> crate::error::Result<()> {
    write_toml_with(scene, output, &crate::control::CancelToken::new())
}

/// [`write_toml`], stopped between meshes by `cancel` ([`Error::Cancelled`]; nothing is
/// written then).
pub fn write_toml_with(
    scene: &Scene,
    output: &Path,
    cancel: &crate::control::CancelToken,
) -> crate::error::Result<()> {
    let out_dir = output
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
        .to_path_buf();
    if !out_dir.is_dir() {
        return Err(Error::Invalid(format!(
            "{}: the output's directory does not exist",
            output.display()
        )));
    }
    let stem = output
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    let refs = Refs {
        scene,
        out_dir: &out_dir,
    };
    // Material names as TOML keys: the scene's own where unique, else m<index>.
    let mut keys: Vec<String> = Vec::new();
    for (i, m) in scene.materials.iter().enumerate() {
        let key = if m.name.is_empty() || keys.contains(&m.name) {
            format!("m{i}")
        } else {
            m.name.clone()
        };
        keys.push(key);
    }
    let medium_keys = media::keys(&scene.media);
    let mut camera_desc = camera(&scene.camera);
    camera_desc.medium = media::name(scene.camera_medium, &medium_keys);
    let mut file = FileDesc {
        camera: Some(spanned(camera_desc)),
        media: Ordered(
            media::tables(&scene.media, &medium_keys)
                .into_iter()
                .map(|(key, desc)| (key, spanned(desc)))
                .collect(),
        ),
        world: Some(spanned(world(scene, refs))),
        materials: Ordered(
            scene
                .materials
                .iter()
                .zip(&keys)
                .map(|(m, key)| (key.clone(), spanned(material(m, &keys, refs))))
                .collect(),
        ),
        shapes: Vec::new(),
        objects: Vec::new(),
        instances: Vec::new(),
        lights: scene
            .lights
            .iter()
            .map(|l| light(l, refs).map(spanned))
            .collect::<crate::error::Result<_>>()?,
        render: render(&scene.settings, scene.output.as_deref(), scene.color_space).map(spanned),
    };
    let mut meshes = MeshDir::new(scene, output, &out_dir, format!("{stem}.meshes"))?;
    meshes.cancel = Some(cancel.clone());
    for (i, shape) in scene.shapes.iter().enumerate() {
        let mut desc = shape_desc(shape, &mut meshes, i, &keys, refs)?;
        desc.media = media::shape(&shape.media, &medium_keys);
        desc.motion = match &shape.motion {
            None => None,
            Some(end) => Some(OneOrMany::One(TransformOp {
                translate: Some(V3(translation(&shape.geometry, end).ok_or_else(|| {
                    Error::input(
                        &scene.source,
                        format!(
                            "shape {i} moves by more than a translation over the shutter; the \
                             TOML `motion` written by convert holds translations only"
                        ),
                    )
                })?)),
                rotate: None,
                scale: None,
                matrix: None,
            })),
        };
        file.shapes.push(spanned(desc));
    }
    // Objects' meshes are numbered after the scene's own.
    let mut next = scene.shapes.len();
    let mut names: Vec<String> = Vec::new();
    for (i, prototype) in scene.prototypes.iter().enumerate() {
        let name = if prototype.name.is_empty() || names.contains(&prototype.name) {
            format!("object{i}")
        } else {
            prototype.name.clone()
        };
        let mut shapes = Vec::new();
        for shape in &prototype.shapes {
            let mut desc = shape_desc(shape, &mut meshes, next, &keys, refs)?;
            desc.media = media::shape(&shape.media, &medium_keys);
            shapes.push(spanned(desc));
            next += 1;
        }
        file.objects.push(spanned(ObjectDesc {
            name: name.clone(),
            shapes,
        }));
        names.push(name);
    }
    for instance in &scene.instances {
        file.instances.push(spanned(InstanceDesc {
            object: names[instance.prototype as usize].clone(),
            transform: Some(OneOrMany::One(affine_step(&instance.matrix))),
        }));
    }
    let body = toml::to_string(&file).map_err(|e| {
        Error::Invalid(format!(
            "{}: the scene cannot be written as TOML: {e}",
            output.display()
        ))
    })?;
    let text = format!(
        "# Written by raylink {} from {}.\n\n{body}",
        env!("CARGO_PKG_VERSION"),
        scene.source.display()
    );
    cancel.check("writing the converted scene")?;
    meshes.install()?;
    crate::atomic_file::write(output, text.as_bytes())
}

/// What resolves the paths of referenced files (textures, environment maps).
#[derive(Clone, Copy)]
struct Refs<'a> {
    scene: &'a Scene,
    out_dir: &'a Path,
}

impl Refs<'_> {
    fn to(&self, file: &Path) -> String {
        reference(self.scene, file, self.out_dir)
    }
}

/// The schema's tables carry their place in a file; a written one has none.
fn spanned<T>(value: T) -> Spanned<T> {
    Spanned::new(0..0, value)
}

fn camera(c: &Camera) -> CameraDesc {
    CameraDesc {
        position: V3(c.position),
        look_at: V3(c.look_at),
        up: Some(V3(c.up)),
        fov: Some(c.fov_deg),
        width: Some(c.width),
        height: Some(c.height),
        projection: matches!(c.projection, Projection::Orthographic { .. })
            .then(|| "orthographic".to_string()),
        size: match c.projection {
            Projection::Orthographic { size } => Some(size),
            _ => None,
        },
        lens_radius: match c.projection {
            Projection::ThinLens { radius, .. } => Some(radius),
            _ => None,
        },
        focal_distance: match c.projection {
            Projection::ThinLens { focal_distance, .. } => Some(focal_distance),
            _ => None,
        },
        medium: None,
    }
}

fn world(scene: &Scene, refs: Refs) -> WorldDesc {
    let environment = scene.environment.as_ref().map(|env| EnvironmentDesc {
        file: refs.to(&env.file),
        scale: Some(Splat3(env.scale)),
        transform: Some(OneOrMany::One(matrix_step(env.transform))),
        portal: env.portal.as_ref().map(|p| p.corners.map(V3)),
    });
    WorldDesc {
        ambient: Some(Splat3(scene.ambient)),
        background: Some(Splat3(scene.background)),
        environment,
    }
}

/// The `[render]` table; none for the default settings and no output. Files are written as
/// given.
fn render(
    s: &RenderSettings,
    output: Option<&std::path::Path>,
    color_space: Option<&ColorSpace>,
) -> Option<RenderDesc> {
    if s == &RenderSettings::default() && output.is_none() && color_space.is_none() {
        return None;
    }
    let filter = s.filter.map(|f| {
        let (kind, radius, sigma) = match f {
            Filter::Box { radius } => ("box", radius, None),
            Filter::Triangle { radius } => ("triangle", radius, None),
            Filter::Gaussian { radius, sigma } => ("gaussian", radius, Some(sigma)),
        };
        FilterDesc {
            kind: kind.into(),
            radius: Some(radius),
            sigma,
        }
    });
    let path = |p: &Option<PathBuf>| p.as_ref().map(|p| p.display().to_string());
    let whitted = WhittedDesc {
        area_samples: s.area_samples,
        fresnel: s.fresnel,
    };
    let cache = CacheDesc {
        ab: s.ab,
        accuracy: s.ic_accuracy,
        samples: s.ic_samples,
        gradients: s.ic_gradients,
        ar: s.ar,
        cache_file: path(&s.cache_file),
    };
    let network = NetworkDesc {
        slopes: s.slopes,
        intercept_step: s.intercept_step,
        patch_size: s.patch_size,
        jitter: s.network_jitter,
        builder: s.network_builder.map(|b| b.name().into()),
        tolerance: s.tolerance,
        order: s.network_order.map(|o| o.name().into()),
        hybrid: s.network_hybrid,
        file: path(&s.network_file),
    };
    let sppm = SppmDesc {
        photons_per_iteration: s.photons_per_iteration,
        radius: s.sppm_radius,
    };
    Some(RenderDesc {
        integrator: s.integrator.map(|k| k.name().to_string()),
        spp: s.spp,
        max_depth: s.max_depth,
        time_limit: s.time_limit,
        adaptive_threshold: s.adaptive_threshold,
        adaptive_min_samples: s.adaptive_min_samples,
        guiding: s.guiding,
        spectral: s.spectral,
        max_component_value: s.max_component_value,
        filter,
        aa: s.aa.map(|a| {
            match a {
                AntiAliasing::Adaptive => "adaptive",
                AntiAliasing::Uniform => "uniform",
            }
            .into()
        }),
        aa_threshold: s.aa_threshold,
        aa_depth: s.aa_depth,
        whitted: (whitted != WhittedDesc::default()).then(|| spanned(whitted)),
        irradiance_cache: (cache != CacheDesc::default()).then(|| spanned(cache)),
        network: (network != NetworkDesc::default()).then(|| spanned(network)),
        sppm: (sppm != SppmDesc::default()).then(|| spanned(sppm)),
        output: output.map(|p| spanned(p.display().to_string())),
        color_space: color_space.map(|c| spanned(c.name.to_string())),
    })
}

fn material(m: &Material, keys: &[String], refs: Refs) -> MaterialDesc {
    if let Some(mix) = m.mix() {
        // Its other fields follow from its two materials.
        let amount = match &mix.amount_map {
            Some(t) => diffuse(t, refs),
            None => DiffuseDesc::Colour(crate::math::Vec3::splat(mix.amount)),
        };
        return MaterialDesc {
            mix: Some(MixDesc {
                materials: mix.materials.iter().map(|&i| keys[i].clone()).collect(),
                amount: Some(amount),
            }),
            ..MaterialDesc::default()
        };
    }
    if let Some(table) = m.model().table() {
        return MaterialDesc {
            brdf: Some(refs.to(&table.file)),
            emission: Some(emission(m, refs)),
            emission_temperature: temperature(m),
            two_sided_emission: m.two_sided_emission.then_some(true),
            ..MaterialDesc::default()
        };
    }
    if m.is_interface() {
        return MaterialDesc {
            interface: Some(true),
            ..MaterialDesc::default()
        };
    }
    // Every other kind is written as its classic terms, which read back as the same lobes.
    let c = m.approximation();
    match &m.surface {
        Surface::CoatedDiffuse(s) => return coated(m, c, s.coating(), refs),
        Surface::CoatedConductor(s) => return coated(m, c, s.coating(), refs),
        _ => {}
    }
    MaterialDesc {
        diffuse: Some(diffuse(&c.diffuse, refs)),
        ambient: c.ambient.map(Splat3),
        specular: Some(varying(&c.specular_map, c.specular, refs)),
        transmission: Some(Splat3(c.transmission)),
        diffuse_transmission: (c.diffuse_transmission
            != Texture::Constant(crate::math::Vec3::ZERO))
        .then(|| diffuse(&c.diffuse_transmission, refs)),
        // A named glass writes its name, which gives the index and its dispersion.
        ior: c.spectral.glass_name().is_none().then_some(c.ior),
        glass: c.spectral.glass_name().map(str::to_owned),
        phong_exponent: Some(c.phong_exponent),
        roughness: Some(match (&c.roughness_map, c.roughness_v) {
            (Some(map), _) => match diffuse(&map.u, refs) {
                DiffuseDesc::Texture(t) => RoughnessDesc::Texture(Box::new(t)),
                DiffuseDesc::Colour(c) => RoughnessDesc::Isotropic(c.x),
            },
            (None, Some(v)) => RoughnessDesc::Anisotropic(c.roughness, v),
            (None, None) => RoughnessDesc::Isotropic(c.roughness),
        }),
        remap_roughness: c
            .roughness_map
            .as_ref()
            .and_then(|r| r.remap.then_some(true)),
        fresnel: Some(c.fresnel),
        thin: c.thin.then_some(true),
        conductor: conductor(c, refs),
        emission: Some(emission(m, refs)),
        emission_temperature: temperature(m),
        two_sided_emission: m.two_sided_emission.then_some(true),
        mix: None,
        brdf: None,
        normal_map: normal_map(m, refs),
        bump: bump(m, refs),
        coating: None,
        interface: None,
    }
}

/// A material's emission as written: a blackbody's by its luminance (with
/// [`temperature`]), else its colour or map.
fn emission(m: &Material, refs: Refs) -> DiffuseDesc {
    match m.emission_spectrum {
        Some(_) => {
            let y = ColorSpace::srgb().luminance(m.emission);
            DiffuseDesc::Colour(crate::math::Vec3::splat(y))
        }
        None => varying(&m.emission_map, m.emission, refs),
    }
}

/// A blackbody emission's temperature.
fn temperature(m: &Material) -> Option<f32> {
    m.emission_spectrum.map(|b| b.kelvin() as f32)
}

/// A coated material: the base and the coat; the keys that follow from the coat (ior,
/// fresnel, a diffuse base's roughness) are left out.
fn coated(m: &Material, base: &Classic, c: &Coating, refs: Refs) -> MaterialDesc {
    let roughness = |a: f32, v: Option<f32>| match v {
        Some(v) => RoughnessDesc::Anisotropic(a, v),
        None => RoughnessDesc::Isotropic(a),
    };
    MaterialDesc {
        diffuse: Some(diffuse(&base.diffuse, refs)),
        ambient: base.ambient.map(Splat3),
        specular: Some(varying(&base.specular_map, base.specular, refs)),
        phong_exponent: Some(base.phong_exponent),
        roughness: base
            .conductor
            .map(|_| roughness(base.roughness, base.roughness_v)),
        conductor: conductor(base, refs),
        emission: Some(emission(m, refs)),
        emission_temperature: temperature(m),
        two_sided_emission: m.two_sided_emission.then_some(true),
        normal_map: normal_map(m, refs),
        bump: bump(m, refs),
        coating: Some(CoatingDesc {
            ior: Some(c.ior),
            roughness: Some(roughness(c.roughness, c.roughness_v)),
            thickness: Some(c.thickness),
            albedo: Some(Splat3(c.albedo)),
            g: Some(c.g),
            max_depth: Some(c.max_depth),
            samples: Some(c.samples),
        }),
        ..MaterialDesc::default()
    }
}

/// A material's normal map, as the file it was read from.
fn normal_map(m: &Material, refs: Refs) -> Option<String> {
    match &m.normal_detail {
        Some(NormalDetail::Map(image)) => Some(refs.to(&image.file)),
        _ => None,
    }
}

/// A material's bump map.
fn bump(m: &Material, refs: Refs) -> Option<DiffuseDesc> {
    match &m.normal_detail {
        Some(NormalDetail::Bump(t)) => Some(diffuse(t, refs)),
        _ => None,
    }
}

/// A metal's index, or its varying reflectance.
fn conductor(m: &Classic, refs: Refs) -> Option<ConductorDesc> {
    if let Some(r) = &m.reflectance_map {
        return Some(ConductorDesc::Reflectance(diffuse(r, refs)));
    }
    // A named metal writes its name, which gives its measured index in spectral renders.
    let name = m.spectral.metal.and_then(|(eta, _)| {
        let name = eta.name.strip_prefix("metal-")?.strip_suffix("-eta")?;
        (crate::bsdf::Conductor::named(name) == m.conductor).then_some(name)
    });
    if let Some(name) = name {
        return Some(ConductorDesc::Named(name.to_owned()));
    }
    m.conductor.map(|c| {
        ConductorDesc::Index(ConductorIndex {
            eta: Splat3(c.eta),
            k: Splat3(c.k),
        })
    })
}

/// A colour that a texture may replace.
fn varying(map: &Option<Texture>, c: crate::math::Vec3, refs: Refs) -> DiffuseDesc {
    map.as_ref()
        .map_or(DiffuseDesc::Colour(c), |t| diffuse(t, refs))
}

fn diffuse(t: &Texture, refs: Refs) -> DiffuseDesc {
    let table = match t {
        Texture::Constant(c) => return DiffuseDesc::Colour(*c),
        Texture::Checker { even, odd, size } => TextureTable {
            checker: Some(CheckerDesc {
                even: Splat3(*even),
                odd: Splat3(*odd),
                size: Some(*size),
            }),
            ..TextureTable::default()
        },
        Texture::UvChecker { even, odd, mapping } => TextureTable {
            uv_checker: Some(UvCheckerDesc {
                even: Splat3(*even),
                odd: Splat3(*odd),
                uscale: Some(mapping.scale.x),
                vscale: Some(mapping.scale.y),
                udelta: Some(mapping.offset.x),
                vdelta: Some(mapping.offset.y),
            }),
            ..TextureTable::default()
        },
        Texture::Image(img) => TextureTable {
            image: Some(ImageDesc {
                file: refs.to(&img.file),
                encoding: Some(img.encoding.name()),
                scale: Some(img.scale),
                invert: Some(img.invert),
                uscale: Some(img.mapping.scale.x),
                vscale: Some(img.mapping.scale.y),
                udelta: Some(img.mapping.offset.x),
                vdelta: Some(img.mapping.offset.y),
            }),
            ..TextureTable::default()
        },
        Texture::Scale(t) => TextureTable {
            scale: Some(Box::new(ScaleDesc {
                texture: diffuse(&t[0], refs),
                by: diffuse(&t[1], refs),
            })),
            ..TextureTable::default()
        },
        Texture::Mix(m) => TextureTable {
            mix: Some(Box::new(TextureMixDesc {
                textures: [diffuse(&m.textures[0], refs), diffuse(&m.textures[1], refs)],
                amount: diffuse(&m.amount, refs),
            })),
            ..TextureTable::default()
        },
        Texture::DirectionMix(t, dir) => TextureTable {
            direction_mix: Some(Box::new(DirectionMixDesc {
                textures: [diffuse(&t[0], refs), diffuse(&t[1], refs)],
                direction: V3(*dir),
            })),
            ..TextureTable::default()
        },
    };
    DiffuseDesc::Texture(table)
}

/// A light as a `[[lights]]` table; an error for a kind the native format cannot name.
fn light(l: &Light, refs: Refs) -> crate::error::Result<LightDesc> {
    let mut d = LightDesc {
        kind: LightKind::Point,
        position: None,
        intensity: None,
        direction: None,
        irradiance: None,
        cone_angle: None,
        cone_delta: None,
        image: None,
        transform: None,
        temperature: l.model().spectrum().map(|b| b.kelvin() as f32),
    };
    // A blackbody's colour is written as its luminance (with its temperature).
    let colour = |rgb: crate::math::Rgb| match l.model().spectrum() {
        Some(_) => Splat3(crate::math::Rgb::splat(ColorSpace::srgb().luminance(rgb))),
        None => Splat3(rgb),
    };
    match l {
        Light::Point(l) => {
            d.position = Some(V3(l.position));
            d.intensity = Some(colour(l.intensity));
        }
        Light::Directional(l) => {
            d.kind = LightKind::Directional;
            d.direction = Some(V3(l.direction));
            d.irradiance = Some(colour(l.irradiance));
        }
        Light::Spot(l) => {
            d.kind = LightKind::Spot;
            d.position = Some(V3(l.position));
            d.direction = Some(V3(l.direction));
            d.intensity = Some(colour(l.intensity));
            d.cone_angle = Some(l.cone_angle);
            d.cone_delta = Some(l.cone_delta);
        }
        Light::Goniometric(l) => {
            d.kind = LightKind::Goniometric;
            d.position = Some(V3(l.position));
            d.intensity = Some(Splat3(l.intensity));
            d.image = Some(refs.to(&l.map.file));
            d.transform = Some(OneOrMany::One(matrix_step(l.map.transform)));
        }
        Light::Projection(l) => {
            return Err(Error::Invalid(format!(
                "the projection light of \"{}\" has no form in the native format; render \
                 the pbrt scene as it is",
                l.file.display()
            )))
        }
    }
    Ok(d)
}

/// One shape as a `[[shapes]]` table; a mesh goes to the mesh folder as file `i`.
fn shape_desc(
    shape: &crate::scene::Shape,
    meshes: &mut MeshDir,
    i: usize,
    keys: &[String],
    refs: Refs,
) -> crate::error::Result<ShapeDesc> {
    let mut desc = match &shape.geometry {
        Geometry::Sphere(Sphere { center, radius }) => {
            let mut d = ShapeDesc::new(ShapeKind::Sphere);
            d.center = Some(V3(*center));
            d.radius = Some(*radius);
            d
        }
        g => {
            let mut d = ShapeDesc::new(ShapeKind::Ply);
            d.file = Some(meshes.write(i, g)?);
            d
        }
    };
    desc.material = Some(keys[shape.material].clone());
    desc.alpha = shape.alpha.as_ref().map(|a| match a {
        Alpha::Constant(a) => AlphaDesc::Constant(*a as f64),
        Alpha::Image(image) => match diffuse(&Texture::Image(image.clone()), refs) {
            DiffuseDesc::Texture(t) => AlphaDesc::Texture(t),
            DiffuseDesc::Colour(_) => unreachable!("an image gives a texture table"),
        },
    });
    Ok(desc)
}

/// A transform step of the affine matrix `m` (its rows; the last is [0, 0, 0, 1]).
fn affine_step(m: &glam::DMat4) -> TransformOp {
    let rows = (0..4)
        .map(|r| m.row(r).to_array().map(|x| x as f32).to_vec())
        .collect();
    TransformOp {
        translate: None,
        rotate: None,
        scale: None,
        matrix: Some(rows),
    }
}

/// The one offset that moves every vertex of `start` onto `end` (a moving shape's
/// geometry at shutter open and close), if there is one.
fn translation(start: &Geometry, end: &Geometry) -> Option<crate::math::Vec3> {
    let (a, b): (Vec<crate::math::Vec3>, Vec<crate::math::Vec3>) = match (start, end) {
        (
            Geometry::Sphere(Sphere { center, radius }),
            Geometry::Sphere(Sphere {
                center: c,
                radius: r,
            }),
        ) => (radius == r).then(|| (vec![*center], vec![*c]))?,
        (Geometry::Triangles(m), Geometry::Triangles(n)) => {
            (m.positions.clone(), n.positions.clone())
        }
        (Geometry::Quads(m), Geometry::Quads(n)) => (m.positions.clone(), n.positions.clone()),
        _ => return None,
    };
    let d = *b.first()? - *a.first()?;
    let same = a.iter().zip(&b).all(|(p, q)| {
        let tolerance = 1e-5 * (1.0 + p.abs().max_element());
        ((*q - *p) - d).abs().max_element() <= tolerance
    });
    same.then_some(d)
}

/// A transform step of the 3×3 matrix `m` (rows, in 4×4 form).
fn matrix_step(m: crate::math::Mat3) -> TransformOp {
    let mut rows: Vec<Vec<f32>> = (0..3)
        .map(|r| {
            let row = m.row(r);
            vec![row.x, row.y, row.z, 0.0]
        })
        .collect();
    rows.push(vec![0.0, 0.0, 0.0, 1.0]);
    TransformOp {
        translate: None,
        rotate: None,
        scale: None,
        matrix: Some(rows),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;

    /// The snippet, pasted as a scene's `[camera]`, reads back as the same camera to the
    /// bit, for coordinates that are not short decimals (the reader normalises `up`).
    #[test]
    fn camera_toml_reads_back_as_the_same_camera() {
        let camera = Camera {
            position: Vec3::new(1.0 / 3.0, -2.5e-7, 4.6),
            look_at: Vec3::new(2.0, 1.3, -0.1),
            up: Vec3::new(0.1, 0.9, 0.0).normalize(),
            fov_deg: 55.5,
            width: 64,
            height: 48,
            projection: crate::scene::camera::Projection::ThinLens {
                radius: 0.0625,
                focal_distance: 4.25,
            },
        };
        let snippet = camera_toml(&camera);
        assert!(snippet.starts_with("[camera]\n"), "{snippet}");
        let text = format!(
            "{snippet}\n[materials.m]\n\n[[shapes]]\ntype = \"sphere\"\nmaterial = \"m\"\n\
             center = [0, 0, 0]\nradius = 1\n"
        );
        let scene = crate::scene::toml::from_str(&text, Path::new("pasted.toml")).unwrap();
        assert_eq!(scene.camera, camera);
    }
}
