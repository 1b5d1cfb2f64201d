//! The world block: materials, textures, shapes and lights, mapped to raylink's.

use super::params::Params;
use super::shapes;
use super::spectrum::{self, Kind};
use super::state::AreaEmission;
use super::{FloatTexture, Loader, Loc};
use crate::math::Vec2;
use crate::math::{Mat3, Rgb, Vec3};
use crate::scene::environment::Environment;
use crate::scene::ply::{self, PlyMesh};
use crate::scene::texture::{Encoding, ImageTexture, UvMapping};
use crate::scene::{Geometry, Light, Material, Scene, Shape, Texture};
use glam::{DMat4, DVec3};
use std::path::PathBuf;
use std::sync::Arc;

/// pbrt-v4's roughness remapping for the Trowbridge–Reitz distribution: alpha = √roughness.
fn roughness_to_alpha(r: f64) -> f64 {
    r.max(0.0).sqrt()
}

/// Normal-incidence reflectance of a conductor, per channel.
fn conductor_f0(eta: Rgb, k: Rgb) -> Rgb {
    let f = |n: f32, k: f32| ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k);
    Rgb::new(f(eta.x, k.x), f(eta.y, k.y), f(eta.z, k.z))
}

impl Loader {
    fn pe(loc: &Loc) -> impl Fn(super::params::ParamError) -> crate::Error + '_ {
        move |e| loc.param_error(e)
    }

    /// A spectrum-valued parameter (rgb, spectrum, blackbody) as RGB.
    pub(super) fn spectrum(
        &mut self,
        p: &Params,
        name: &str,
        kind: Kind,
        statement: &str,
        loc: &Loc,
    ) -> crate::Result<Option<Rgb>> {
        let Some(q) = p
            .find(name, &["rgb", "spectrum", "blackbody"])
            .map_err(Self::pe(loc))?
        else {
            return Ok(None);
        };
        let qloc = loc.at(q.line, q.col);
        let rgb = match q.ty.as_str() {
            "rgb" => {
                let v = q.nums();
                if v.len() != 3 {
                    return Err(qloc.error(format!("parameter \"{name}\" takes one rgb value")));
                }
                Rgb::new(v[0] as f32, v[1] as f32, v[2] as f32)
            }
            "blackbody" => spectrum::blackbody(q.nums()[0]),
            _ => {
                match q.strs().first() {
                    Some(named) => match spectrum::named(named) {
                        Some((rgb, approx)) => {
                            if approx {
                                self.warn(
                                &qloc,
                                format!("{statement}: spectrum \"{named}\" is approximated by white"),
                            );
                            }
                            rgb
                        }
                        None => {
                            self.warn(
                                &qloc,
                                format!(
                                    "{statement}: spectrum \"{named}\" is not known; using 1 \
                                 (spectrum files are not read)"
                                ),
                            );
                            Rgb::ONE
                        }
                    },
                    None => spectrum::sampled(q.nums(), kind),
                }
            }
        };
        if kind != Kind::Unbounded && rgb.min_element() < 0.0 {
            return Err(qloc.error(format!(
                "parameter \"{name}\" must not be negative, got {rgb}"
            )));
        }
        Ok(Some(rgb))
    }

    /// A spectrum parameter that may also name a texture.
    fn texture_param(
        &mut self,
        p: &Params,
        name: &str,
        default: Rgb,
        statement: &str,
        loc: &Loc,
    ) -> crate::Result<Texture> {
        if let Some(q) = p.find(name, &["texture"]).ok().flatten() {
            let tex = q.strs()[0].clone();
            return match self.textures.get(&tex) {
                Some(t) => Ok(t.clone()),
                None => Err(loc
                    .at(q.line, q.col)
                    .error(format!("{statement}: no spectrum texture named \"{tex}\""))),
            };
        }
        let c = self.spectrum(p, name, Kind::Reflectance, statement, loc)?;
        Ok(Texture::Constant(c.unwrap_or(default)))
    }

    /// A float parameter that may also name a (constant) float texture.
    fn float_param(
        &mut self,
        p: &Params,
        name: &str,
        default: f64,
        statement: &str,
        loc: &Loc,
    ) -> crate::Result<f64> {
        let Some(q) = p.find(name, &["float", "texture"]).map_err(Self::pe(loc))? else {
            return Ok(default);
        };
        if q.ty == "float" {
            return Ok(q.nums()[0]);
        }
        let tex = q.strs()[0].clone();
        let qloc = loc.at(q.line, q.col);
        match self.float_textures.get(&tex) {
            Some(FloatTexture::Constant(v)) => Ok(*v),
            Some(FloatTexture::Unsupported) => {
                self.warn(
                    &qloc,
                    format!(
                        "{statement}: \"{name}\" varies by texture \"{tex}\", which raylink \
                         cannot evaluate; using {default}"
                    ),
                );
                Ok(default)
            }
            None => Err(qloc.error(format!("{statement}: no float texture named \"{tex}\""))),
        }
    }

    /// Isotropic roughness of a material as raylink's alpha.
    fn roughness(&mut self, p: &Params, prefix: &str, st: &str, loc: &Loc) -> crate::Result<f32> {
        let r = self.float_param(p, &format!("{prefix}roughness"), 0.0, st, loc)?;
        let u = self.float_param(p, &format!("{prefix}uroughness"), r, st, loc)?;
        let v = self.float_param(p, &format!("{prefix}vroughness"), r, st, loc)?;
        if u != v {
            self.warn(loc, format!("{st}: anisotropic roughness is averaged"));
        }
        let remap = p
            .bool("remaproughness")
            .map_err(Self::pe(loc))?
            .unwrap_or(true);
        let alpha = |x: f64| {
            if remap {
                roughness_to_alpha(x)
            } else {
                x.max(0.0)
            }
        };
        Ok((0.5 * (alpha(u) + alpha(v))) as f32)
    }

    /// An index of refraction ("float eta" or a spectrum).
    fn eta(
        &mut self,
        p: &Params,
        name: &str,
        default: f32,
        st: &str,
        loc: &Loc,
    ) -> crate::Result<f32> {
        if let Some(q) = p.find(name, &["float"]).ok().flatten() {
            return Ok(q.nums()[0] as f32);
        }
        let Some(rgb) = self.spectrum(p, name, Kind::Unbounded, st, loc)? else {
            return Ok(default);
        };
        if rgb.max_element() - rgb.min_element() > 1e-3 {
            self.warn(
                loc,
                format!("{st}: dispersion is not supported; using the mean index"),
            );
        }
        Ok(rgb.element_sum() / 3.0)
    }

    /// Conductor reflectance at normal incidence from `eta`/`k` or `reflectance`.
    fn conductor(
        &mut self,
        p: &Params,
        prefix: &str,
        st: &str,
        loc: &Loc,
    ) -> crate::Result<Texture> {
        let refl = format!("{prefix}reflectance");
        if p.find(&refl, &["rgb", "spectrum", "blackbody", "texture"])
            .ok()
            .flatten()
            .is_some()
        {
            p.ignore(&format!("{prefix}eta"));
            p.ignore(&format!("{prefix}k"));
            return self.texture_param(p, &refl, Rgb::ONE, st, loc);
        }
        let (cu_eta, cu_k) = spectrum::copper();
        let eta = match p.find(&format!("{prefix}eta"), &["float"]).ok().flatten() {
            Some(q) => Rgb::splat(q.nums()[0] as f32),
            None => self
                .spectrum(p, &format!("{prefix}eta"), Kind::Unbounded, st, loc)?
                .unwrap_or(cu_eta),
        };
        let k = self
            .spectrum(p, &format!("{prefix}k"), Kind::Unbounded, st, loc)?
            .unwrap_or(cu_k);
        Ok(Texture::Constant(conductor_f0(eta, k)))
    }

    pub(super) fn material(
        &mut self,
        ty: &str,
        name: &str,
        p: &Params,
        loc: &Loc,
    ) -> crate::Result<Material> {
        let st = if name.is_empty() {
            format!("Material \"{ty}\"")
        } else {
            format!("MakeNamedMaterial \"{name}\"")
        };
        let st = st.as_str();
        // Anonymous materials are named after their statement, for messages and TOML keys.
        let name = if name.is_empty() {
            format!("{ty}-line{}", loc.line)
        } else {
            name.to_string()
        };
        let base = Material {
            name: name.clone(),
            diffuse: Texture::Constant(Rgb::ZERO),
            ambient: None,
            specular: Rgb::ZERO,
            transmission: Rgb::ZERO,
            ior: 1.5,
            roughness: 0.0,
            fresnel: false,
            ..Material::default()
        };
        let diffuse_default = Rgb::splat(0.5);
        let substitute = |this: &mut Loader, what: &str| {
            this.warn(loc, format!("material \"{ty}\" is not supported; {what}"));
        };
        let m = match ty {
            "diffuse" => Material {
                diffuse: self.texture_param(p, "reflectance", diffuse_default, st, loc)?,
                ..base
            },
            "coateddiffuse" => {
                for q in ["thickness", "albedo", "g", "maxdepth", "nsamples"] {
                    p.ignore(q);
                }
                self.coated_diffuse(base, p, 1.5, st, loc)?
            }
            "conductor" => {
                let f0 = self.conductor(p, "", st, loc)?;
                Material {
                    specular: self.texture_to_constant(f0, st, loc),
                    roughness: self.roughness(p, "", st, loc)?,
                    ..base
                }
            }
            "dielectric" | "thindielectric" => {
                if ty == "thindielectric" {
                    substitute(self, "using a smooth dielectric (refracting) surface");
                }
                let roughness = self.roughness(p, "", st, loc)?;
                if roughness > 0.0 {
                    self.warn(
                        loc,
                        format!("{st}: rough dielectric: the reflection is rough, the transmission stays smooth"),
                    );
                }
                Material {
                    specular: Rgb::ONE,
                    transmission: Rgb::ONE,
                    fresnel: true,
                    ior: self.eta(p, "eta", 1.5, st, loc)?,
                    roughness,
                    ..base
                }
            }
            "diffusetransmission" => {
                substitute(
                    self,
                    "using its diffuse reflection (transmission is dropped)",
                );
                p.ignore("transmittance");
                p.ignore("scale");
                Material {
                    diffuse: self.texture_param(p, "reflectance", Rgb::splat(0.25), st, loc)?,
                    ..base
                }
            }
            "coatedconductor" => {
                substitute(self, "using the conductor without its coating");
                for q in [
                    "thickness",
                    "albedo",
                    "g",
                    "maxdepth",
                    "nsamples",
                    "interface.eta",
                ] {
                    p.ignore(q);
                }
                let f0 = self.conductor(p, "conductor.", st, loc)?;
                let _ = self.roughness(p, "interface.", st, loc)?;
                Material {
                    specular: self.texture_to_constant(f0, st, loc),
                    roughness: self.roughness(p, "conductor.", st, loc)?,
                    ..base
                }
            }
            "subsurface" => {
                substitute(self, "using a coated diffuse surface");
                for q in ["mfp", "sigma_a", "sigma_s", "scale", "g", "name"] {
                    p.ignore(q);
                }
                self.coated_diffuse(base, p, 1.33, st, loc)?
            }
            "interface" => {
                substitute(self, "using an invisible (index-matched) surface");
                Material {
                    transmission: Rgb::ONE,
                    ior: 1.0,
                    ..base
                }
            }
            "mix" => {
                let names = p.strings("materials").map_err(Self::pe(loc))?;
                let amount = self.float_param(p, "amount", 0.5, st, loc)?;
                let pick = names
                    .as_ref()
                    .and_then(|n| n.get(if amount < 0.5 { 0 } else { 1 }))
                    .cloned();
                substitute(
                    self,
                    "using the one of its two materials with the larger weight",
                );
                match pick.and_then(|n| self.named_materials.get(&n).copied()) {
                    Some(i) => Material {
                        name,
                        ..self.materials[i].clone()
                    },
                    None => {
                        return Err(loc.error(format!(
                            "{st}: \"materials\" must name two materials defined before"
                        )))
                    }
                }
            }
            _ => {
                // measured, hair and anything else.
                for q in p.list.iter() {
                    p.ignore(&q.name);
                }
                substitute(self, "using a grey diffuse surface");
                Material {
                    diffuse: Texture::Constant(diffuse_default),
                    ..base
                }
            }
        };
        for q in ["displacement", "normalmap"] {
            if p.find(q, &["texture", "string", "float"])
                .ok()
                .flatten()
                .is_some()
            {
                self.warn(loc, format!("{st}: \"{q}\" is not supported; ignored"));
            }
        }
        Ok(m)
    }

    /// A diffuse base under a dielectric coat: Fresnel-weighted specular over diffuse.
    fn coated_diffuse(
        &mut self,
        base: Material,
        p: &Params,
        eta: f32,
        st: &str,
        loc: &Loc,
    ) -> crate::Result<Material> {
        Ok(Material {
            diffuse: self.texture_param(p, "reflectance", Rgb::splat(0.5), st, loc)?,
            specular: Rgb::ONE,
            fresnel: true,
            ior: self.eta(p, "eta", eta, st, loc)?,
            roughness: self.roughness(p, "", st, loc)?,
            ..base
        })
    }

    /// raylink's specular coefficient is a colour, not a texture: a textured one uses its
    /// largest value.
    fn texture_to_constant(&mut self, t: Texture, st: &str, loc: &Loc) -> Rgb {
        match t {
            Texture::Constant(c) => c,
            other => {
                self.warn(
                    loc,
                    format!("{st}: a textured specular colour is replaced by its maximum"),
                );
                other.max_value()
            }
        }
    }

    pub(super) fn texture(
        &mut self,
        name: &str,
        ty: &str,
        class: &str,
        p: &Params,
        loc: &Loc,
    ) -> crate::Result<()> {
        let st = format!("Texture \"{name}\" \"{class}\"");
        let st = st.as_str();
        let is_float = match ty {
            "float" => true,
            "spectrum" | "color" | "rgb" => false,
            other => {
                return Err(loc.error(format!(
                    "Texture \"{name}\": type must be \"float\" or \"spectrum\", got \"{other}\""
                )))
            }
        };
        if is_float {
            let v = match class {
                "constant" => {
                    FloatTexture::Constant(p.float_or("value", 1.0).map_err(Self::pe(loc))?)
                }
                _ => {
                    for q in &p.list {
                        p.ignore(&q.name);
                    }
                    FloatTexture::Unsupported
                }
            };
            self.float_textures.insert(name.to_string(), v);
            return Ok(());
        }
        let mapping = self.mapping(p, st, loc)?;
        let tex = match class {
            "constant" => self.texture_param(p, "value", Rgb::ONE, st, loc)?,
            "checkerboard" => {
                let even = self.texture_param(p, "tex1", Rgb::ONE, st, loc)?;
                let odd = self.texture_param(p, "tex2", Rgb::ZERO, st, loc)?;
                let even = self.texture_to_constant(even, st, loc);
                let odd = self.texture_to_constant(odd, st, loc);
                let dim = p.int("dimension").map_err(Self::pe(loc))?.unwrap_or(2);
                if dim == 3 {
                    if self.state.ctm != DMat4::IDENTITY || self.mirror != DMat4::IDENTITY {
                        self.warn(
                            loc,
                            format!("{st}: the 3-D checkerboard is evaluated in world space"),
                        );
                    }
                    Texture::Checker {
                        even,
                        odd,
                        size: 1.0,
                    }
                } else {
                    Texture::UvChecker { even, odd, mapping }
                }
            }
            "imagemap" => {
                let file = p
                    .string("filename")
                    .map_err(Self::pe(loc))?
                    .ok_or_else(|| loc.error(format!("{st} needs a \"string filename\"")))?;
                let path = loc.dir().join(&file);
                let encoding = match p.string("encoding").map_err(Self::pe(loc))? {
                    None => Encoding::default_for(&path),
                    Some(e) => Encoding::parse(&e).ok_or_else(|| {
                        loc.error(format!(
                            "{st}: unknown encoding \"{e}\" (linear, sRGB or gamma G)"
                        ))
                    })?,
                };
                let scale = p.float_or("scale", 1.0).map_err(Self::pe(loc))? as f32;
                let invert = p.bool("invert").map_err(Self::pe(loc))?.unwrap_or(false);
                let wrap = p.string("wrap").map_err(Self::pe(loc))?;
                if wrap.as_deref().is_some_and(|w| w != "repeat") {
                    self.warn(loc, format!("{st}: only \"repeat\" wrapping is supported"));
                }
                p.ignore("filter");
                p.ignore("maxanisotropy");
                let image = ImageTexture::load(
                    &path,
                    PathBuf::from(&file),
                    encoding,
                    scale,
                    invert,
                    mapping,
                )
                .map_err(|e| loc.error(format!("{st}: {e}")))?;
                Texture::Image(Arc::new(image))
            }
            "scale" => {
                let tex = self.texture_param(p, "tex", Rgb::ONE, st, loc)?;
                let s = self.float_param(p, "scale", 1.0, st, loc)? as f32;
                match tex {
                    Texture::Constant(c) => Texture::Constant(c * s),
                    Texture::Image(img) => {
                        let mut img = (*img).clone();
                        img.scale *= s;
                        let path = loc.dir().join(&img.file);
                        // Reload to keep the cached maximum right.
                        let img = ImageTexture::load(
                            &path,
                            img.file.clone(),
                            img.encoding,
                            img.scale,
                            img.invert,
                            img.mapping,
                        )
                        .map_err(|e| loc.error(format!("{st}: {e}")))?;
                        Texture::Image(Arc::new(img))
                    }
                    other => {
                        if s != 1.0 {
                            self.warn(loc, format!("{st}: scaling this texture is not supported"));
                        }
                        other
                    }
                }
            }
            "mix" | "directionmix" => {
                self.warn(
                    loc,
                    format!("texture \"{class}\" is not supported; using its first texture"),
                );
                p.ignore("amount");
                p.ignore("dir");
                let t = self.texture_param(p, "tex1", Rgb::ZERO, st, loc)?;
                p.ignore("tex2");
                t
            }
            _ => {
                for q in &p.list {
                    p.ignore(&q.name);
                }
                self.warn(
                    loc,
                    format!("texture \"{class}\" is not supported; using a constant 0.5"),
                );
                Texture::Constant(Rgb::splat(0.5))
            }
        };
        self.textures.insert(name.to_string(), tex);
        Ok(())
    }

    fn mapping(&mut self, p: &Params, st: &str, loc: &Loc) -> crate::Result<UvMapping> {
        let pe = Self::pe(loc);
        if let Some(m) = p.string("mapping").map_err(&pe)? {
            if m != "uv" {
                self.warn(
                    loc,
                    format!("{st}: mapping \"{m}\" is not supported; using uv"),
                );
            }
        }
        for q in ["v1", "v2"] {
            p.ignore(q);
        }
        Ok(UvMapping {
            scale: Vec2::new(
                p.float_or("uscale", 1.0).map_err(&pe)? as f32,
                p.float_or("vscale", 1.0).map_err(&pe)? as f32,
            ),
            offset: Vec2::new(
                p.float_or("udelta", 0.0).map_err(&pe)? as f32,
                p.float_or("vdelta", 0.0).map_err(&pe)? as f32,
            ),
        })
    }

    pub(super) fn area_light(&mut self, ty: &str, p: &Params, loc: &Loc) -> crate::Result<()> {
        let st = format!("AreaLightSource \"{ty}\"");
        if ty != "diffuse" {
            self.warn(
                loc,
                format!("{st} is not supported; using a diffuse area light"),
            );
        }
        let l = self
            .spectrum(p, "L", Kind::Illuminant, &st, loc)?
            .unwrap_or(Rgb::ONE);
        let scale = p.float_or("scale", 1.0).map_err(Self::pe(loc))? as f32;
        if p.bool("twosided").map_err(Self::pe(loc))? == Some(true) {
            self.warn(
                loc,
                format!("{st}: two-sided emission is not supported; the light emits on the front side only"),
            );
        }
        let radiance = l * scale;
        if !radiance.is_finite() || radiance.min_element() < 0.0 {
            return Err(loc.error(format!(
                "{st}: the emitted radiance must be finite and not negative"
            )));
        }
        self.state.area = (radiance.max_element() > 0.0).then_some(AreaEmission { radiance });
        Ok(())
    }

    pub(super) fn light(&mut self, ty: &str, p: &Params, loc: &Loc) -> crate::Result<()> {
        let st = format!("LightSource \"{ty}\"");
        let st = st.as_str();
        let pe = Self::pe(loc);
        let m = self.mirror * self.state.ctm;
        let scale = p.float_or("scale", 1.0).map_err(&pe)? as f32;
        let point3 = |name: &str, default: DVec3| -> crate::Result<DVec3> {
            match p.floats(name, "point3").map_err(&pe)? {
                Some(v) if v.len() == 3 => Ok(DVec3::new(v[0], v[1], v[2])),
                Some(_) => Err(loc.error(format!("{st}: \"{name}\" takes one point"))),
                None => Ok(default),
            }
        };
        match ty {
            "point" | "spot" | "goniometric" | "projection" => {
                if ty != "point" {
                    self.warn(
                        loc,
                        format!("light \"{ty}\" is not supported; using a point light"),
                    );
                    for q in ["coneangle", "conedelta", "to", "filename", "fov"] {
                        p.ignore(q);
                    }
                }
                let from = point3("from", DVec3::ZERO)?;
                let i = self
                    .spectrum(p, "I", Kind::Illuminant, st, loc)?
                    .unwrap_or(Rgb::ONE);
                self.lights.push(Light::Point {
                    position: m.transform_point3(from).as_vec3(),
                    intensity: i * scale,
                });
            }
            "distant" => {
                let from = point3("from", DVec3::ZERO)?;
                let to = point3("to", DVec3::Z)?;
                let dir = m.transform_vector3(to - from).normalize_or_zero();
                if dir == DVec3::ZERO {
                    return Err(loc.error(format!("{st}: \"from\" and \"to\" must differ")));
                }
                let l = self
                    .spectrum(p, "L", Kind::Illuminant, st, loc)?
                    .unwrap_or(Rgb::ONE);
                self.lights.push(Light::Directional {
                    direction: dir.as_vec3(),
                    irradiance: l * scale,
                });
            }
            "infinite" => {
                let file = p.string("filename").map_err(&pe)?;
                let l = self.spectrum(p, "L", Kind::Illuminant, st, loc)?;
                match (file, l) {
                    (Some(_), Some(_)) => {
                        return Err(
                            loc.error(format!("{st}: give either \"L\" or \"filename\", not both"))
                        )
                    }
                    (Some(file), None) => {
                        if self.environment.is_some() {
                            self.warn(loc, format!("{st}: only one environment map is supported; the last one is used"));
                        }
                        let path = loc.dir().join(&file);
                        let transform = Mat3::from_cols(
                            m.x_axis.truncate().as_vec3(),
                            m.y_axis.truncate().as_vec3(),
                            m.z_axis.truncate().as_vec3(),
                        );
                        let env = Environment::load(
                            &path,
                            PathBuf::from(&file),
                            transform,
                            Rgb::splat(scale),
                        )
                        .map_err(|e| loc.error(format!("{st}: {e}")))?;
                        self.environment = Some(Arc::new(env));
                    }
                    (None, l) => self.background += l.unwrap_or(Rgb::ONE) * scale,
                }
            }
            _ => {
                for q in &p.list {
                    p.ignore(&q.name);
                }
                self.warn(loc, format!("light \"{ty}\" is not supported; ignored"));
            }
        }
        Ok(())
    }

    /// The material index for the next shape: the current material, or its emissive copy
    /// under an area light.
    fn shape_material(&mut self, loc: &Loc) -> usize {
        let base = match self.state.material {
            Some(i) => i,
            None => *self.default_material.get_or_insert_with(|| {
                self.materials.push(Material {
                    name: "pbrt-default".into(),
                    diffuse: Texture::Constant(Rgb::splat(0.5)),
                    specular: Rgb::ZERO,
                    ..Material::default()
                });
                self.materials.len() - 1
            }),
        };
        let Some(area) = self.state.area else {
            return base;
        };
        if self.object.is_some() {
            self.warn(loc, "area lights in object instances are not supported (nor by pbrt-v4); the shapes do not emit");
            return base;
        }
        let key = (base, area.radiance.to_array().map(f32::to_bits));
        if let Some(&i) = self.emissive.get(&key) {
            return i;
        }
        let mut m = self.materials[base].clone();
        m.emission = area.radiance;
        m.name = if m.name.is_empty() {
            "emitter".into()
        } else {
            format!("{}-emitter", m.name)
        };
        self.materials.push(m);
        self.emissive.insert(key, self.materials.len() - 1);
        self.materials.len() - 1
    }

    pub(super) fn shape(&mut self, ty: &str, p: &Params, loc: &Loc) -> crate::Result<()> {
        let st = format!("Shape \"{ty}\"");
        let st = st.as_str();
        let pe = Self::pe(loc);
        if let Some(q) = p.find("alpha", &["float", "texture"]).map_err(&pe)? {
            if q.ty == "texture" || q.nums()[0] < 1.0 {
                self.warn(
                    loc,
                    format!("{st}: \"alpha\" cut-outs are not supported; the shape is opaque"),
                );
            }
        }
        p.ignore("emission");
        // pbrt's transform for the shape; the world mirror (if any) comes on top.
        let ctm = self.state.ctm;
        let in_object = self.object.is_some();
        let m = if in_object { ctm } else { self.mirror * ctm };
        let det = glam::DMat3::from_mat4(m).determinant();
        if !det.is_finite() || det.abs() < 1e-30 {
            return Err(loc.error(format!(
                "{st}: the transform is singular (determinant {det})"
            )));
        }
        let reverse = self.state.reverse_orientation;
        // Meshes: normals carried as normals (negated by ReverseOrientation); without
        // normals, the winding flips with ReverseOrientation XOR a mirroring transform.
        let mesh_sign = if reverse { -1.0 } else { 1.0 };
        let mesh_flip = reverse ^ shapes::swaps_handedness(&m);
        // Quadrics: outward normals, negated when ReverseOrientation XOR pbrt's own
        // transform mirrors.
        let quadric_sign = if reverse ^ shapes::swaps_handedness(&ctm) {
            -1.0
        } else {
            1.0
        };
        let float = |name: &str, default: f64| p.float_or(name, default).map_err(&pe);
        let geometries: Vec<Geometry> = match ty {
            "trianglemesh" | "loopsubdiv" => {
                if ty == "loopsubdiv" {
                    self.warn(loc, "Shape \"loopsubdiv\" is not supported; using its base mesh without subdivision");
                    p.ignore("levels");
                }
                let mesh = self.mesh_params(p, 3, st, loc)?;
                shapes::place(mesh, &m, mesh_sign, mesh_flip)
            }
            "bilinearmesh" => {
                let mut mesh = self.mesh_params(p, 4, st, loc)?;
                // Patches list (p00, p10, p01, p11); as polygons (p00, p10, p11, p01).
                for q in &mut mesh.quads {
                    q.swap(2, 3);
                }
                shapes::place(mesh, &m, mesh_sign, mesh_flip)
            }
            "plymesh" => {
                let file = p
                    .string("filename")
                    .map_err(&pe)?
                    .ok_or_else(|| loc.error(format!("{st} needs a \"string filename\"")))?;
                if p.find("displacement", &["texture", "float"])
                    .ok()
                    .flatten()
                    .is_some()
                {
                    self.warn(loc, format!("{st}: displacement is not supported; ignored"));
                }
                p.ignore("edgelength");
                let path = loc.dir().join(&file);
                let mesh = ply::read(&path).map_err(|e| loc.error(format!("{st}: {e}")))?;
                if mesh.skipped_faces > 0 {
                    self.warn(
                        loc,
                        format!("{st}: faces with more than 4 vertices are left out"),
                    );
                }
                shapes::place(mesh, &m, mesh_sign, mesh_flip)
            }
            "sphere" => {
                let r = float("radius", 1.0)?;
                if r.is_nan() || r <= 0.0 {
                    return Err(loc.error(format!("{st}: radius must be positive, got {r}")));
                }
                let (zmin, zmax, phimax) = (
                    float("zmin", -r)?,
                    float("zmax", r)?,
                    float("phimax", 360.0)?,
                );
                let full = zmin <= -r && zmax >= r && phimax >= 360.0;
                match shapes::uniform_scale(&m) {
                    Some(s) if full && quadric_sign > 0.0 => vec![Geometry::Sphere {
                        center: m.transform_point3(DVec3::ZERO).as_vec3(),
                        radius: (r * s) as f32,
                    }],
                    _ => shapes::place(
                        shapes::sphere(r, zmin, zmax, phimax),
                        &m,
                        quadric_sign,
                        false,
                    ),
                }
            }
            "disk" => {
                let (h, r, ri, phimax) = (
                    float("height", 0.0)?,
                    float("radius", 1.0)?,
                    float("innerradius", 0.0)?,
                    float("phimax", 360.0)?,
                );
                if !(r > 0.0 && ri >= 0.0 && ri < r) {
                    return Err(loc.error(format!(
                        "{st}: need 0 <= innerradius < radius, got {ri} and {r}"
                    )));
                }
                shapes::place(shapes::disk(h, r, ri, phimax), &m, quadric_sign, false)
            }
            "cylinder" => {
                let (r, zmin, zmax, phimax) = (
                    float("radius", 1.0)?,
                    float("zmin", -1.0)?,
                    float("zmax", 1.0)?,
                    float("phimax", 360.0)?,
                );
                if !(r > 0.0 && zmin != zmax) {
                    return Err(loc.error(format!("{st}: need a positive radius and zmin != zmax")));
                }
                shapes::place(
                    shapes::cylinder(r, zmin, zmax, phimax),
                    &m,
                    quadric_sign,
                    false,
                )
            }
            _ => {
                for q in &p.list {
                    p.ignore(&q.name);
                }
                self.warn(loc, format!("{st} is not supported; the shape is left out"));
                return Ok(());
            }
        };
        for g in &geometries {
            let finite = match g {
                Geometry::Sphere { center, radius } => center.is_finite() && radius.is_finite(),
                Geometry::Triangles(t) => t.positions.iter().all(|p| p.is_finite()),
                Geometry::Quads(q) => q.positions.iter().all(|p| p.is_finite()),
            };
            if !finite {
                return Err(loc.error(format!(
                    "{st}: the transform moves the shape out of the range of finite numbers"
                )));
            }
        }
        let material = self.shape_material(loc);
        let new = geometries
            .into_iter()
            .map(|geometry| Shape { geometry, material });
        match &mut self.object {
            Some((_, shapes)) => shapes.extend(new),
            None => self.shapes.extend(new),
        }
        Ok(())
    }

    /// `P`, `indices`, `N`, `uv` of a triangle (`arity` 3) or bilinear (4) mesh.
    fn mesh_params(
        &mut self,
        p: &Params,
        arity: usize,
        st: &str,
        loc: &Loc,
    ) -> crate::Result<PlyMesh> {
        let pe = Self::pe(loc);
        let positions: Vec<Vec3> = p
            .floats("P", "point3")
            .map_err(&pe)?
            .ok_or_else(|| loc.error(format!("{st} needs \"point3 P\"")))?
            .chunks_exact(3)
            .map(|c| Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32))
            .collect();
        let n = positions.len();
        let indices = match p.ints("indices").map_err(&pe)? {
            Some(ix) => ix,
            None if n == arity => (0..arity as i64).collect(),
            None => {
                return Err(loc.error(format!(
                    "{st} needs \"integer indices\" (it has {n} points)"
                )))
            }
        };
        if indices.len() % arity != 0 {
            return Err(loc.error(format!(
                "{st}: \"indices\" must be a multiple of {arity} long, got {}",
                indices.len()
            )));
        }
        if let Some(&k) = indices.iter().find(|&&k| k < 0 || k as usize >= n) {
            return Err(loc.error(format!(
                "{st}: vertex index {k} out of range (the mesh has {n} points)"
            )));
        }
        let normals = match p.floats("N", "normal3").map_err(&pe)? {
            Some(v) if v.len() / 3 != n => {
                return Err(loc.error(format!(
                    "{st}: \"N\" needs one normal per point ({n}), got {}",
                    v.len() / 3
                )))
            }
            Some(v) => Some(
                v.chunks_exact(3)
                    .map(|c| Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32))
                    .collect(),
            ),
            None => None,
        };
        let uvs = match p.floats("uv", "point2").map_err(&pe)? {
            Some(v) if v.len() / 2 != n => {
                return Err(loc.error(format!(
                    "{st}: \"uv\" needs one uv per point ({n}), got {}",
                    v.len() / 2
                )))
            }
            Some(v) => Some(
                v.chunks_exact(2)
                    .map(|c| Vec2::new(c[0] as f32, c[1] as f32))
                    .collect(),
            ),
            None => None,
        };
        for q in ["S", "faceIndices"] {
            p.ignore(q);
        }
        if positions.iter().any(|p| !p.is_finite()) {
            return Err(loc.error(format!("{st}: \"P\" must be finite")));
        }
        let ix: Vec<u32> = indices.iter().map(|&k| k as u32).collect();
        let mut mesh = PlyMesh {
            positions,
            normals,
            uvs,
            ..PlyMesh::default()
        };
        if arity == 3 {
            mesh.triangles = ix.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        } else {
            mesh.quads = ix
                .chunks_exact(4)
                .map(|c| [c[0], c[1], c[2], c[3]])
                .collect();
        }
        Ok(mesh)
    }

    pub(super) fn finish(mut self) -> crate::Result<Scene> {
        let Some(camera) = self.camera_value.take() else {
            return Err(crate::Error::input(
                &self.source,
                "the file has no WorldBegin (truncated file?)",
            ));
        };
        if self.shapes.is_empty() {
            return Err(crate::Error::input(&self.source, "the scene has no shapes"));
        }
        // Keep only the materials shapes use, in their order.
        let mut map = vec![usize::MAX; self.materials.len()];
        let mut materials = Vec::new();
        for s in &mut self.shapes {
            if map[s.material] == usize::MAX {
                map[s.material] = materials.len();
                materials.push(self.materials[s.material].clone());
            }
            s.material = map[s.material];
        }
        Ok(Scene {
            source: self.source,
            camera,
            materials,
            shapes: self.shapes,
            lights: self.lights,
            ambient: Rgb::ZERO,
            background: self.background,
            environment: self.environment,
            settings: self.settings,
            warnings: self.warnings,
        })
    }
}
