//! Building the scene: the builder checks the values of the deserialised file (see
//! [`schema`](super::schema)), bakes transforms into world-space geometry, and resolves
//! material names, meshes, textures and environment maps relative to the file.

mod coating;
mod emitters;
mod instances;
mod media;
mod motion;
mod render;
mod shapes;
mod textures;

use super::checks::{
    colour, direction, finite, finite3, matrix, non_negative, positive, resolution, Xform,
};
use super::diagnostics::{Ctx, Site};
use super::schema::{
    CameraDesc, ConductorDesc, DiffuseDesc, EnvironmentDesc, FileDesc, LightDesc, LightKind,
    MaterialDesc, MixDesc, OneOrMany, RoughnessDesc, Splat3, TransformOp,
};
use crate::bsdf::{SpectralParts, TabulatedBrdf};
use crate::error::Error;
use crate::input_file::Allowance;
use crate::math::{Mat3, Mat4, Rgb, Vec3};
use crate::scene::environment::Environment;
use crate::scene::lights::{
    check_cone_width, DirectionalLight, GoniometricLight, GoniometricMap, PointLight, SpotLight,
};
use crate::scene::materials::{Classic, Measured, Surface};
use crate::scene::Portal;
use crate::scene::{
    Camera, Conductor, Light, Material, Projection, RenderSettings, RoughnessMap, Scene, Texture,
};
use std::collections::HashMap;
use std::ops::Range;
use std::path::{Path, PathBuf};
use toml::Spanned;

pub(super) struct Builder<'a> {
    ctx: Ctx<'a>,
    /// Directory that relative mesh paths start from.
    dir: PathBuf,
    materials: Vec<Material>,
    names: HashMap<String, usize>,
    media: Vec<crate::scene::media::Medium>,
    medium_names: HashMap<String, u32>,
    /// Scene material index of each MTL material already loaded, by OBJ file.
    obj_materials: HashMap<PathBuf, Vec<usize>>,
    /// Every file read besides the scene file (meshes, textures, environment maps).
    pub(super) inputs: std::cell::RefCell<Vec<PathBuf>>,
    /// The bytes of the images kept so far, held against the job's memory budget.
    images: std::cell::Cell<u64>,
}

impl<'a> Builder<'a> {
    pub(super) fn new(ctx: Ctx<'a>) -> Self {
        let dir = ctx.path.parent().map(Path::to_path_buf).unwrap_or_default();
        Builder {
            ctx,
            dir,
            materials: Vec::new(),
            names: HashMap::new(),
            media: Vec::new(),
            medium_names: HashMap::new(),
            obj_materials: HashMap::new(),
            inputs: Default::default(),
            images: Default::default(),
        }
    }

    /// What reading a file may take of the job's memory budget, the scene's text and the
    /// images kept so far being held (the machine's default budget without a job).
    fn allowance(&self) -> Allowance {
        match self.ctx.control {
            Some(c) => Allowance::new(
                c.budget,
                (self.ctx.text.len() as u64).saturating_add(self.images.get()),
            ),
            None => Allowance::machine(),
        }
    }

    /// Counts an image the scene keeps against the budget.
    fn hold_image(&self, image: &crate::image::Image) {
        self.hold_bytes(std::mem::size_of_val(image.pixels.as_slice()) as u64);
    }

    /// Counts `bytes` the scene keeps (images, a medium's grid) against the budget.
    fn hold_bytes(&self, bytes: u64) {
        self.images.set(self.images.get().saturating_add(bytes));
    }

    fn site(&self, name: String, span: Range<usize>) -> Site {
        Site { name, span }
    }

    pub(super) fn build(mut self, file: FileDesc) -> crate::error::Result<Scene> {
        let ctx = self.ctx;
        let Some(camera) = file.camera else {
            return Err(Error::input(
                ctx.path,
                "missing [camera] table: the scene needs a camera (position, look_at, fov)",
            ));
        };
        let camera_site = self.site("camera".into(), camera.span());
        let camera_medium = camera.get_ref().medium.clone();
        let camera = self.camera(camera)?;

        let (settings, setting_sources, output, color_space) = match file.render {
            Some(mut r) => {
                let output = self.output(r.get_mut().output.take())?;
                let color_space = self.color_space(r.get_mut().color_space.take())?;
                let (settings, sources) = self.render(r)?;
                (settings, sources, output, color_space)
            }
            None => (RenderSettings::default(), Vec::new(), None, None),
        };
        let mut environment = None;
        let (ambient, background) = match file.world {
            Some(world) => {
                let site = self.site("world".into(), world.span());
                let mut world = world.into_inner();
                if let Some(env) = world.environment.take() {
                    environment = Some(std::sync::Arc::new(self.environment(&site, env)?));
                }
                let get = |v: Option<Splat3>, key: &str| -> crate::error::Result<Rgb> {
                    v.map_or(Ok(Rgb::ZERO), |c| {
                        colour(c.0).map_err(|m| ctx.fail(&site, key, m))
                    })
                };
                (
                    get(world.ambient, "ambient")?,
                    get(world.background, "background")?,
                )
            }
            None => (Rgb::ZERO, Rgb::ZERO),
        };

        for (name, desc) in file.media.0 {
            let site = self.site(format!("media.{name}"), desc.span());
            let medium = self.medium(&site, name.clone(), desc.into_inner())?;
            self.medium_names.insert(name, self.media.len() as u32);
            self.media.push(medium);
        }
        let camera_medium = match camera_medium {
            Some(name) => self.medium_index(&camera_site, "medium", &name)?,
            None => None,
        };

        for (name, desc) in file.materials.0 {
            let site = self.site(format!("materials.{name}"), desc.span());
            let material = self.material(&site, name.clone(), desc.into_inner())?;
            self.names.insert(name, self.materials.len());
            self.materials.push(material);
        }

        let placed = self.placed(file.shapes, file.objects, file.instances)?;

        let mut lights = Vec::new();
        for (i, desc) in file.lights.into_iter().enumerate() {
            let site = self.site(format!("lights[{i}]"), desc.span());
            lights.push(self.light(&site, desc.into_inner())?);
        }

        Ok(Scene {
            media: self.media,
            camera_medium,
            source: ctx.path.to_path_buf(),
            camera,
            materials: self.materials,
            shapes: placed.shapes,
            prototypes: placed.prototypes,
            instances: placed.instances,
            lights,
            ambient,
            background,
            environment,
            settings,
            setting_sources,
            output,
            color_space,
            inputs: std::iter::once(ctx.path.to_path_buf())
                .chain(self.inputs.take())
                .collect(),
            warnings: Vec::new(),
        })
    }

    fn camera(&self, desc: Spanned<CameraDesc>) -> crate::error::Result<Camera> {
        let ctx = self.ctx;
        let site = self.site("camera".into(), desc.span());
        let desc = desc.into_inner();
        let at = |key: &str, r: Result<Vec3, String>| r.map_err(|m| ctx.fail(&site, key, m));
        let position = at("position", finite3(desc.position.0))?;
        let look_at = at("look_at", finite3(desc.look_at.0))?;
        let up = at("up", direction(desc.up.map_or(Vec3::Y, |v| v.0)))?;
        // Directions, lengths and the frame are checked with the rest, by `Camera::check`.
        let fov = desc.fov.unwrap_or(45.0);
        let width =
            resolution(desc.width.unwrap_or(640)).map_err(|m| ctx.fail(&site, "width", m))?;
        let height =
            resolution(desc.height.unwrap_or(480)).map_err(|m| ctx.fail(&site, "height", m))?;
        let projection = self.projection(&site, &desc)?;
        let camera = Camera {
            position,
            look_at,
            up,
            fov_deg: fov,
            width,
            height,
            projection,
        };
        camera
            .check()
            .map_err(|p| ctx.fail(&site, p.field, p.message))?;
        Ok(camera)
    }

    /// `projection` ("perspective", the default, or "orthographic" with `size`), and a thin
    /// lens for a perspective camera with `lens_radius` > 0 (`focal_distance` required).
    fn projection(&self, site: &Site, desc: &CameraDesc) -> crate::error::Result<Projection> {
        let ctx = self.ctx;
        let fail = |key: &'static str| move |m: String| ctx.fail(site, key, m);
        let orthographic = match desc.projection.as_deref() {
            None | Some("perspective") => false,
            Some("orthographic") => true,
            Some(other) => {
                return Err(fail("projection")(format!(
                    "must be \"perspective\" or \"orthographic\", got \"{other}\""
                )))
            }
        };
        if orthographic {
            for (key, given) in [
                ("lens_radius", desc.lens_radius.is_some()),
                ("focal_distance", desc.focal_distance.is_some()),
            ] {
                if given {
                    return Err(fail(key)(
                        "applies to the perspective projection only".into(),
                    ));
                }
            }
            let Some(size) = desc.size else {
                return Err(fail("size")(
                    "is required for the orthographic projection: the width of the view in scene units".into(),
                ));
            };
            let size = positive(size).map_err(fail("size"))?;
            return Ok(Projection::Orthographic { size });
        }
        if desc.size.is_some() {
            return Err(fail("size")(
                "applies to the orthographic projection only".into(),
            ));
        }
        let radius = non_negative(desc.lens_radius.unwrap_or(0.0)).map_err(fail("lens_radius"))?;
        if radius == 0.0 {
            return Ok(Projection::Pinhole);
        }
        let Some(focal_distance) = desc.focal_distance else {
            return Err(fail("focal_distance")(
                "is required with lens_radius: the distance of the plane in focus".into(),
            ));
        };
        let focal_distance = positive(focal_distance).map_err(fail("focal_distance"))?;
        Ok(Projection::ThinLens {
            radius,
            focal_distance,
        })
    }

    fn material(
        &self,
        site: &Site,
        name: String,
        desc: MaterialDesc,
    ) -> crate::error::Result<Material> {
        let ctx = self.ctx;
        let fail = |key: &'static str| move |m: String| ctx.fail(site, key, m);
        if let Some(interface) = desc.interface {
            // Every key the table gives, `interface` among them.
            let keys = toml::Value::try_from(&desc)
                .ok()
                .and_then(|v| v.as_table().map(|t| t.len()))
                .unwrap_or(0);
            if !interface || keys > 1 {
                return Err(fail("interface")(
                    "an interface (`interface = true`) is only the boundary of a medium: it \
                     takes no other key"
                        .into(),
                ));
            }
            return Ok(Material::new(
                name,
                Surface::Interface(crate::scene::materials::Interface::default()),
            ));
        }
        if let Some(mix) = desc.mix {
            let others = [
                desc.diffuse.is_some(),
                desc.ambient.is_some(),
                desc.specular.is_some(),
                desc.transmission.is_some(),
                desc.diffuse_transmission.is_some(),
                desc.ior.is_some(),
                desc.glass.is_some(),
                desc.phong_exponent.is_some(),
                desc.roughness.is_some(),
                desc.fresnel.is_some(),
                desc.thin.is_some(),
                desc.conductor.is_some(),
                desc.emission.is_some(),
                desc.two_sided_emission.is_some(),
                desc.brdf.is_some(),
                desc.normal_map.is_some(),
                desc.bump.is_some(),
                desc.remap_roughness.is_some(),
                desc.coating.is_some(),
            ];
            return self.mix(site, name, mix, others.contains(&true));
        }
        if let Some(file) = &desc.brdf {
            let lobes = [
                ("diffuse", desc.diffuse.is_some()),
                ("ambient", desc.ambient.is_some()),
                ("specular", desc.specular.is_some()),
                ("transmission", desc.transmission.is_some()),
                ("diffuse_transmission", desc.diffuse_transmission.is_some()),
                ("ior", desc.ior.is_some()),
                ("glass", desc.glass.is_some()),
                ("phong_exponent", desc.phong_exponent.is_some()),
                ("roughness", desc.roughness.is_some()),
                ("fresnel", desc.fresnel.is_some()),
                ("thin", desc.thin.is_some()),
                ("conductor", desc.conductor.is_some()),
                ("coating", desc.coating.is_some()),
            ];
            if let Some((key, _)) = lobes.iter().find(|k| k.1) {
                return Err(fail(key)(
                    "a material with a tabulated `brdf` takes no other lobe".into(),
                ));
            }
            let path = self.dir.join(file);
            self.inputs.borrow_mut().push(path.clone());
            let table = TabulatedBrdf::read(&path, file.into()).map_err(fail("brdf"))?;
            let (emission, emission_map, emission_spectrum) =
                self.emission(site, desc.emission, desc.emission_temperature)?;
            let measured = Measured::new(std::sync::Arc::new(table));
            return Ok(Material {
                emission,
                emission_map,
                emission_spectrum,
                two_sided_emission: desc.two_sided_emission.unwrap_or(false),
                ..Material::new(name, Surface::Measured(measured))
            });
        }
        if desc.coating.is_some() {
            self.check_coated_keys(site, &desc)?;
        }
        let d = Classic::default();
        let col =
            |v: Option<Splat3>, key: &'static str, default: Rgb| -> crate::error::Result<Rgb> {
                v.map_or(Ok(default), |c| colour(c.0).map_err(fail(key)))
            };
        let diffuse = match desc.diffuse {
            // A metal has no diffuse lobe unless one is given (pbrt-v4's conductor has
            // none): 0.5 beside a Fresnel reflectance near 1 would reflect more than it takes.
            None if desc.conductor.is_some() => Texture::Constant(Rgb::ZERO),
            None => d.diffuse,
            Some(t) => self.texture(site, "diffuse", t)?,
        };
        let diffuse_transmission = match desc.diffuse_transmission {
            None => d.diffuse_transmission.clone(),
            Some(t) => self.texture(site, "diffuse_transmission", t)?,
        };
        let ambient = match desc.ambient {
            None => None,
            Some(c) => Some(colour(c.0).map_err(fail("ambient"))?),
        };
        let mut spectral = SpectralParts {
            metal: match &desc.conductor {
                Some(ConductorDesc::Named(n)) => SpectralParts::metal_named(n),
                _ => None,
            },
            ..SpectralParts::default()
        };
        let mut reflectance_map = None;
        let conductor = match desc.conductor {
            None => None,
            Some(ConductorDesc::Named(n)) => Some(Conductor::named(&n).ok_or_else(|| {
                let names: Vec<_> = Conductor::names().collect();
                fail("conductor")(format!(
                    "unknown metal \"{n}\"; known: {}",
                    names.join(", ")
                ))
            })?),
            Some(ConductorDesc::Index(i)) => Some(Conductor {
                eta: colour(i.eta.0).map_err(fail("conductor"))?,
                k: colour(i.k.0).map_err(fail("conductor"))?,
            }),
            Some(ConductorDesc::Reflectance(r)) => {
                let r = self.texture(site, "conductor.reflectance", r)?;
                let top = r.max_value();
                if !r.is_constant() {
                    reflectance_map = Some(r);
                }
                Some(Conductor::from_reflectance(top))
            }
        };
        // A metal reflects everything its Fresnel lets it unless a tint is given.
        let specular_default = if conductor.is_some() {
            Rgb::ONE
        } else {
            d.specular
        };
        let mut roughness_map = None;
        let (roughness, roughness_v) = match desc.roughness {
            None => (d.roughness, None),
            Some(RoughnessDesc::Isotropic(a)) => (a, None),
            Some(RoughnessDesc::Anisotropic(u, v)) => (u, Some(v)),
            Some(RoughnessDesc::Texture(t)) => {
                let map = RoughnessMap {
                    u: self.texture(site, "roughness", DiffuseDesc::Texture(*t))?,
                    v: None,
                    remap: desc.remap_roughness.unwrap_or(false),
                };
                let top = map.max_alpha();
                roughness_map = Some(std::sync::Arc::new(map));
                (top, None)
            }
        };
        let roughness = non_negative(roughness).map_err(fail("roughness"))?;
        let roughness_v = match roughness_v {
            Some(v) => Some(non_negative(v).map_err(fail("roughness"))?),
            None => None,
        };
        // pbrt's remapping of its roughness r to α = √r (a textured one at each point).
        let (roughness, roughness_v) = match desc.remap_roughness {
            Some(true) if roughness_map.is_none() => (roughness.sqrt(), roughness_v.map(f32::sqrt)),
            _ => (roughness, roughness_v),
        };
        let thin = desc.thin.unwrap_or(d.thin);
        let normal_detail = self.normal_detail(site, desc.normal_map, desc.bump)?;
        if thin && (roughness > 0.0 || roughness_v.is_some_and(|v| v > 0.0)) {
            return Err(fail("roughness")(
                "a thin sheet (`thin = true`) is smooth: roughness must be 0".into(),
            ));
        }
        // A coat's mirror reflects everything its Fresnel lets it unless a tint is given.
        let specular_default = if desc.coating.is_some() {
            Rgb::ONE
        } else {
            specular_default
        };
        let (specular, specular_map) = match desc.specular {
            None => (specular_default, None),
            Some(t) => match self.texture(site, "specular", t)? {
                Texture::Constant(c) => (c, None),
                t => (t.max_value(), Some(t)),
            },
        };
        let (emission, emission_map, emission_spectrum) =
            self.emission(site, desc.emission, desc.emission_temperature)?;
        let mut ior = desc.ior.unwrap_or(d.ior);
        if let Some(name) = &desc.glass {
            if desc.ior.is_some() {
                return Err(fail("glass")(
                    "gives the index of refraction: drop `ior`".into(),
                ));
            }
            let s = SpectralParts::glass_named(name).ok_or_else(|| {
                let known: Vec<_> = crate::spectrum::named::glasses().collect();
                fail("glass")(format!(
                    "unknown glass \"{name}\"; known: {}",
                    known.join(", ")
                ))
            })?;
            // The index RGB renders use: at the helium d line, as glass catalogues give it.
            ior = s.eval(587.56);
            spectral.dispersion = Some(s);
        }
        let classic = Classic {
            diffuse,
            ambient,
            specular,
            specular_map,
            reflectance_map,
            transmission: col(desc.transmission, "transmission", d.transmission)?,
            diffuse_transmission,
            ior: positive(ior).map_err(fail("ior"))?,
            phong_exponent: non_negative(desc.phong_exponent.unwrap_or(d.phong_exponent))
                .map_err(fail("phong_exponent"))?,
            roughness,
            roughness_v,
            fresnel: desc.fresnel.unwrap_or(d.fresnel),
            thin,
            conductor,
            roughness_map,
            spectral,
        };
        let surface = match desc.coating {
            Some(c) => self.coated(site, c, classic)?,
            None => Surface::Classic(classic),
        };
        Ok(Material {
            emission,
            emission_map,
            emission_spectrum,
            two_sided_emission: desc.two_sided_emission.unwrap_or(false),
            normal_detail,
            ..Material::new(name, surface)
        })
    }

    /// A mix of two materials defined before it (by name): the second chosen with
    /// probability `amount` (default 0.5, within [0, 1]). It has no other key: its emission
    /// is its materials', which must emit alike.
    fn mix(
        &self,
        site: &Site,
        name: String,
        mix: MixDesc,
        other_keys: bool,
    ) -> crate::error::Result<Material> {
        let ctx = self.ctx;
        let fail = |m: String| ctx.fail(site, "mix", m);
        if other_keys {
            return Err(fail(
                "a mix takes no other key: set them on its two materials".into(),
            ));
        }
        let [a, b] = <[String; 2]>::try_from(mix.materials).map_err(|m| {
            fail(format!(
                "\"materials\" must name two materials, got {}",
                m.len()
            ))
        })?;
        let find = |n: &str| {
            self.names
                .get(n)
                .copied()
                .ok_or_else(|| fail(format!("\"{n}\" is not a material defined before this one")))
        };
        let (ia, ib) = (find(&a)?, find(&b)?);
        let amount = match mix.amount {
            None => Texture::Constant(Rgb::splat(0.5)),
            Some(t) => self.texture(site, "mix.amount", t)?,
        };
        let top = amount.max_value().x;
        if let Texture::Constant(c) = amount {
            if !(0.0..=1.0).contains(&c.x) {
                return Err(fail(format!("amount must be within [0, 1], got {}", c.x)));
            }
        } else if top > 1.0 {
            return Err(fail(format!(
                "amount must be within [0, 1], its texture reaches {top}"
            )));
        }
        let (ma, mb) = (&self.materials[ia], &self.materials[ib]);
        let emits = |m: &Material| (m.emission, m.two_sided_emission, m.emission_map.clone());
        if emits(ma) != emits(mb) {
            return Err(fail(format!(
                "\"{a}\" and \"{b}\" emit differently: the shapes of a mix emit alike"
            )));
        }
        Ok(Material::mix_of(name, (ia, ma), (ib, mb), amount))
    }

    /// A material's emission: a colour, or a texture (then the colour is its mean, for the
    /// techniques that take one value per surface).
    fn environment(&self, site: &Site, desc: EnvironmentDesc) -> crate::error::Result<Environment> {
        let ctx = self.ctx;
        let xf = self.transform(site, desc.transform)?;
        let scale = colour(desc.scale.map_or(Vec3::ONE, |s| s.0))
            .map_err(|m| ctx.fail(site, "environment.scale", m))?;
        let path = self.dir.join(&desc.file);
        self.inputs.borrow_mut().push(path.clone());
        let (mut env, _) = Environment::load_with_mapping(
            &path,
            desc.file.into(),
            Mat3::from_mat4(xf.m),
            scale,
            &self.allowance(),
        )
        .map_err(|e| ctx.fail(site, "environment.file", e))?;
        if let Some(corners) = desc.portal {
            env.portal = Some(
                Portal::new(corners.map(|c| c.0))
                    .map_err(|m| ctx.fail(site, "environment.portal", m))?,
            );
        }
        self.hold_image(&env.image);
        Ok(env)
    }

    fn transform(
        &self,
        site: &Site,
        desc: Option<OneOrMany<TransformOp>>,
    ) -> crate::error::Result<Xform> {
        self.transform_steps(site, desc, "transform")
    }

    /// The transform of a list of steps given under `key` (`transform`, `motion`).
    fn transform_steps(
        &self,
        site: &Site,
        desc: Option<OneOrMany<TransformOp>>,
        key: &str,
    ) -> crate::error::Result<Xform> {
        let ctx = self.ctx;
        let (ops, single) = match desc {
            None => (Vec::new(), true),
            Some(OneOrMany::One(op)) => (vec![op], true),
            Some(OneOrMany::Many(ops)) => (ops, false),
        };
        let mut m = Mat4::IDENTITY;
        for (i, op) in ops.into_iter().enumerate() {
            let field = if single {
                key.to_string()
            } else {
                format!("{key}[{i}]")
            };
            let fail = |key: &str, msg: String| {
                let f = if key.is_empty() {
                    field.clone()
                } else {
                    format!("{field}.{key}")
                };
                ctx.fail(site, &f, msg)
            };
            let count = [
                op.translate.is_some(),
                op.rotate.is_some(),
                op.scale.is_some(),
                op.matrix.is_some(),
            ]
            .iter()
            .filter(|&&b| b)
            .count();
            if count != 1 {
                return Err(fail(
                    "",
                    format!(
                        "each step takes exactly one of translate, rotate, scale or matrix \
                         (found {count}); use an array of steps to combine them"
                    ),
                ));
            }
            let step = if let Some(t) = op.translate {
                Mat4::from_translation(finite3(t.0).map_err(|e| fail("translate", e))?)
            } else if let Some(r) = op.rotate {
                let axis = direction(r.axis.0).map_err(|e| fail("rotate.axis", e))?;
                let deg = finite(r.degrees).map_err(|e| fail("rotate.degrees", e))?;
                Mat4::from_axis_angle(axis, deg.to_radians())
            } else if let Some(s) = op.scale {
                let s = finite3(s.0).map_err(|e| fail("scale", e))?;
                if s.abs().min_element() == 0.0 {
                    return Err(fail("scale", format!("must not be zero, got {s}")));
                }
                Mat4::from_scale(s)
            } else if let Some(rows) = op.matrix {
                matrix(&rows).map_err(|e| fail("matrix", e))?
            } else {
                Mat4::IDENTITY
            };
            // Steps apply in order: the later one acts on the result of the earlier.
            m = step * m;
        }
        Xform::new(m).map_err(|e| ctx.fail(site, key, e))
    }

    fn light(&self, site: &Site, mut desc: LightDesc) -> crate::error::Result<Light> {
        let temperature = desc.temperature.take();
        let light = self.light_of(site, desc)?;
        self.with_temperature(site, light, temperature)
    }

    fn light_of(&self, site: &Site, desc: LightDesc) -> crate::error::Result<Light> {
        let ctx = self.ctx;
        let (name, takes, allowed): (&str, &str, &[&str]) = match desc.kind {
            LightKind::Point => ("point", "position, intensity", &["position", "intensity"]),
            LightKind::Directional => (
                "directional",
                "direction, irradiance",
                &["direction", "irradiance"],
            ),
            LightKind::Spot => (
                "spot",
                "position, direction, intensity, cone_angle, cone_delta",
                &[
                    "position",
                    "direction",
                    "intensity",
                    "cone_angle",
                    "cone_delta",
                ],
            ),
            LightKind::Goniometric => (
                "goniometric",
                "position, intensity, image, transform",
                &["position", "intensity", "image", "transform"],
            ),
        };
        let present = [
            ("position", desc.position.is_some()),
            ("intensity", desc.intensity.is_some()),
            ("direction", desc.direction.is_some()),
            ("irradiance", desc.irradiance.is_some()),
            ("cone_angle", desc.cone_angle.is_some()),
            ("cone_delta", desc.cone_delta.is_some()),
            ("image", desc.image.is_some()),
            ("transform", desc.transform.is_some()),
        ];
        for (key, is) in present {
            if is && !allowed.contains(&key) {
                return Err(ctx.fail(
                    site,
                    key,
                    format!("a {name} light does not take `{key}` (it takes {takes})"),
                ));
            }
        }
        let need = |key: &str| ctx.fail(site, "", format!("a {name} light needs `{key}`"));
        let fail = |key: &'static str| move |m: String| ctx.fail(site, key, m);
        Ok(match desc.kind {
            LightKind::Point => Light::Point(PointLight {
                position: finite3(desc.position.ok_or_else(|| need("position"))?.0)
                    .map_err(fail("position"))?,
                intensity: colour(desc.intensity.ok_or_else(|| need("intensity"))?.0)
                    .map_err(fail("intensity"))?,
                spectrum: None,
            }),
            LightKind::Directional => Light::Directional(DirectionalLight::new(
                direction(desc.direction.ok_or_else(|| need("direction"))?.0)
                    .map_err(fail("direction"))?,
                colour(desc.irradiance.ok_or_else(|| need("irradiance"))?.0)
                    .map_err(fail("irradiance"))?,
            )),
            LightKind::Spot => {
                // pbrt-v4's defaults: a 30° cone, the last 5° of it falling off.
                let cone_angle = desc.cone_angle.unwrap_or(30.0);
                if !(cone_angle > 0.0 && cone_angle <= 180.0) {
                    return Err(fail("cone_angle")(format!(
                        "must be in (0, 180] degrees, got {cone_angle}"
                    )));
                }
                check_cone_width(cone_angle).map_err(fail("cone_angle"))?;
                let cone_delta = desc.cone_delta.unwrap_or(5.0);
                if !(0.0..=cone_angle).contains(&cone_delta) {
                    return Err(fail("cone_delta")(format!(
                        "must be in [0, cone_angle = {cone_angle}] degrees, got {cone_delta}"
                    )));
                }
                Light::Spot(SpotLight::new(
                    finite3(desc.position.ok_or_else(|| need("position"))?.0)
                        .map_err(fail("position"))?,
                    direction(desc.direction.ok_or_else(|| need("direction"))?.0)
                        .map_err(fail("direction"))?,
                    colour(desc.intensity.ok_or_else(|| need("intensity"))?.0)
                        .map_err(fail("intensity"))?,
                    cone_angle,
                    cone_delta,
                ))
            }
            LightKind::Goniometric => {
                let file = desc.image.ok_or_else(|| need("image"))?;
                let frame = Mat3::from_mat4(self.transform(site, desc.transform)?.m);
                let path = self.dir.join(&file);
                self.inputs.borrow_mut().push(path.clone());
                let (image, _) = crate::image::output::read_image_within(&path, &self.allowance())
                    .map_err(|e| ctx.fail(site, "image", e))?;
                self.hold_image(&image);
                let map = GoniometricMap::new(file.into(), &image, frame)
                    .map_err(|e| ctx.fail(site, "image", e))?;
                Light::Goniometric(GoniometricLight {
                    position: finite3(desc.position.ok_or_else(|| need("position"))?.0)
                        .map_err(fail("position"))?,
                    intensity: colour(desc.intensity.ok_or_else(|| need("intensity"))?.0)
                        .map_err(fail("intensity"))?,
                    map: std::sync::Arc::new(map),
                })
            }
        })
    }
}
