//! Materials: pbrt's material types as raylink's kinds of surface
//! ([`crate::scene::materials`]), and the closest substitute where raylink has no match.

use super::builder::Builder;
use super::params::Params;
use super::spectrum::{self, Kind};
use super::Loc;
use crate::math::Rgb;
use crate::scene::materials::{
    Classic, CoatedConductor, CoatedDiffuse, Dielectric, Diffuse, DiffuseTransmission, Interface,
    Metal, Surface, SurfaceModel, ThinDielectric,
};
use crate::scene::texture::{Encoding, ImageTexture, UvMapping};
use crate::scene::{Coating, Conductor, Material, NormalDetail, RoughnessMap, Texture};
use std::path::PathBuf;
use std::sync::Arc;

/// pbrt-v4's roughness remapping for the Trowbridge–Reitz distribution: alpha = √roughness.
fn roughness_to_alpha(r: f64) -> f64 {
    r.max(0.0).sqrt()
}

impl Builder {
    /// Roughness of a material as GGX (α_x, α_y): `uroughness`/`vroughness` (defaulting to
    /// `roughness`), remapped by √ unless `remaproughness` is false, as pbrt-v4 does. Where
    /// one of them varies by texture, the map, and its largest α for both.
    fn roughness_map(
        &mut self,
        p: &Params,
        prefix: &str,
        st: &str,
        loc: &Loc,
    ) -> crate::error::Result<((f32, f32), Option<RoughnessMap>)> {
        let remap = p
            .bool("remaproughness")
            .map_err(Self::pe(loc))?
            .unwrap_or(true);
        let varies = ["roughness", "uroughness", "vroughness"]
            .iter()
            .any(|n| self.names_varying_texture(p, &format!("{prefix}{n}")));
        if !varies {
            // Constants in double precision, as they are read.
            let r = self.float_param(p, &format!("{prefix}roughness"), 0.0, st, loc)?;
            let u = self.float_param(p, &format!("{prefix}uroughness"), r, st, loc)?;
            let v = self.float_param(p, &format!("{prefix}vroughness"), r, st, loc)?;
            let alpha = |x: f64| {
                if remap {
                    roughness_to_alpha(x)
                } else {
                    x.max(0.0)
                }
            };
            return Ok(((alpha(u) as f32, alpha(v) as f32), None));
        }
        let r = self.float_texture_param(p, &format!("{prefix}roughness"), 0.0, st, loc)?;
        let along = |this: &mut Builder, name: String| -> crate::error::Result<Texture> {
            match p
                .find(&name, &["float", "texture"])
                .map_err(Self::pe(loc))?
            {
                Some(_) => this.float_texture_param(p, &name, 0.0, st, loc),
                None => Ok(r.clone()),
            }
        };
        let u = along(self, format!("{prefix}uroughness"))?;
        let v = along(self, format!("{prefix}vroughness"))?;
        let map = RoughnessMap {
            v: (v != u).then_some(v),
            u,
            remap,
        };
        let top = map.max_alpha();
        Ok(((top, top), Some(map)))
    }

    /// [`Builder::roughness_map`] for the materials that take one roughness: a textured one
    /// is its largest value, with a warning.
    fn roughness(
        &mut self,
        p: &Params,
        prefix: &str,
        st: &str,
        loc: &Loc,
    ) -> crate::error::Result<(f32, f32)> {
        let (alphas, map) = self.roughness_map(p, prefix, st, loc)?;
        if map.is_some() {
            self.warn(
                loc,
                format!("{st}: a textured roughness is replaced by its largest value"),
            );
        }
        Ok(alphas)
    }

    /// Isotropic roughness for the materials whose lobes are isotropic here: anisotropy is
    /// averaged, with a warning.
    fn isotropic_roughness(
        &mut self,
        p: &Params,
        prefix: &str,
        st: &str,
        loc: &Loc,
    ) -> crate::error::Result<f32> {
        let (u, v) = self.roughness(p, prefix, st, loc)?;
        if u != v {
            self.warn(loc, format!("{st}: anisotropic roughness is averaged"));
        }
        Ok(0.5 * (u + v))
    }

    /// A conductor material's metal: the complex index from `eta`/`k` (copper by default)
    /// or, given `reflectance`, the index with that normal-incidence reflectance.
    fn metal(
        &mut self,
        p: &Params,
        prefix: &str,
        st: &str,
        loc: &Loc,
    ) -> crate::error::Result<Metal> {
        let (alphas, map) = self.roughness_map(p, prefix, st, loc)?;
        let (conductor, reflectance_map) = self.conductor(p, prefix, st, loc)?;
        let measured = measured_metal(p, prefix);
        Ok(Metal::new(conductor, reflectance_map, alphas, map).with_measured(measured))
    }

    /// An index of refraction ("float eta" or a spectrum; a named glass is read as its index
    /// at 587.6 nm here, and by [`named_spectrum`] for spectral renders).
    fn eta(
        &mut self,
        p: &Params,
        name: &str,
        default: f32,
        st: &str,
        loc: &Loc,
    ) -> crate::error::Result<f32> {
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

    /// A conductor's complex index from `eta`/`k` or `reflectance`, and a textured
    /// reflectance (the index is then that of its largest value).
    fn conductor(
        &mut self,
        p: &Params,
        prefix: &str,
        st: &str,
        loc: &Loc,
    ) -> crate::error::Result<(Conductor, Option<Texture>)> {
        let refl = format!("{prefix}reflectance");
        if p.find(&refl, &["rgb", "spectrum", "blackbody", "texture"])
            .ok()
            .flatten()
            .is_some()
        {
            p.ignore(&format!("{prefix}eta"));
            p.ignore(&format!("{prefix}k"));
            let r = self.texture_param(p, &refl, Rgb::ONE, st, loc)?;
            return Ok(reflectance_conductor(r));
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
        Ok((Conductor { eta, k }, None))
    }

    pub(super) fn make_material(
        &mut self,
        ty: &str,
        name: &str,
        p: &Params,
        loc: &Loc,
    ) -> crate::error::Result<Material> {
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
        let diffuse_default = Rgb::splat(0.5);
        let substitute = |this: &mut Builder, what: &str| {
            this.warn(loc, format!("material \"{ty}\" is not supported; {what}"));
        };
        let surface = match ty {
            "diffuse" => Surface::Diffuse(Diffuse::new(self.texture_param(
                p,
                "reflectance",
                diffuse_default,
                st,
                loc,
            )?)),
            "coateddiffuse" => {
                let coating = self.coating(p, "", "eta", st, loc)?;
                let base = Classic {
                    diffuse: self.texture_param(p, "reflectance", Rgb::splat(0.5), st, loc)?,
                    specular: Rgb::ONE,
                    ..Classic::blank()
                };
                Surface::CoatedDiffuse(CoatedDiffuse::new(base, coating))
            }
            "conductor" => Surface::Conductor(self.metal(p, "", st, loc)?),
            "thindielectric" => {
                Surface::ThinDielectric(ThinDielectric::new(self.eta(p, "eta", 1.5, st, loc)?))
            }
            "dielectric" => {
                let (alphas, map) = self.roughness_map(p, "", st, loc)?;
                let ior = self.eta(p, "eta", 1.5, st, loc)?;
                let glass = named_spectrum(p, "eta")
                    .filter(|n| matches!(n.kind, crate::spectrum::named::NamedKind::Sellmeier(_)));
                Surface::Dielectric(Dielectric::new(ior, alphas, map).with_dispersion(glass))
            }
            "diffusetransmission" => {
                // pbrt-v4's DiffuseTransmissionBxDF: R/π on wo's side, T/π through, both
                // times `scale`.
                let scale = self.float_param(p, "scale", 1.0, st, loc)? as f32;
                let t = self.texture_param(p, "transmittance", Rgb::splat(0.25), st, loc)?;
                let t = self.scaled(t, scale, st, loc)?;
                let r = self.texture_param(p, "reflectance", Rgb::splat(0.25), st, loc)?;
                let r = self.scaled(r, scale, st, loc)?;
                Surface::DiffuseTransmission(DiffuseTransmission::new(r, t))
            }
            "coatedconductor" => {
                let coating = self.coating(p, "interface.", "interface.eta", st, loc)?;
                // pbrt-v4 names the metal's reflectance without the prefix.
                let metal = if p
                    .find("reflectance", &["rgb", "spectrum", "texture"])
                    .ok()
                    .flatten()
                    .is_some()
                {
                    let alphas = self.roughness(p, "conductor.", st, loc)?;
                    p.ignore("conductor.eta");
                    p.ignore("conductor.k");
                    let r = self.texture_param(p, "reflectance", Rgb::ONE, st, loc)?;
                    let (conductor, reflectance_map) = reflectance_conductor(r);
                    Metal::new(conductor, reflectance_map, alphas, None)
                } else {
                    self.metal(p, "conductor.", st, loc)?
                };
                let metal = metal.approximation().clone();
                Surface::CoatedConductor(CoatedConductor::new(metal, coating))
            }
            "subsurface" => {
                substitute(self, "using a coated diffuse surface");
                for q in ["mfp", "sigma_a", "sigma_s", "scale", "g", "name"] {
                    p.ignore(q);
                }
                Surface::Classic(self.coated_diffuse(p, 1.33, st, loc)?)
            }
            "interface" => Surface::Interface(Interface::default()),
            "mix" => {
                // pbrt-v4's MixMaterial: the second material with probability `amount`
                // (a float texture, evaluated at the hit), chosen at each hit.
                let names = p.strings("materials").map_err(Self::pe(loc))?;
                let amount = self.float_texture_param(p, "amount", 0.5, st, loc)?;
                let found = names.as_deref().and_then(|n| match n {
                    [a, b] => Some((*self.named_materials.get(a)?, *self.named_materials.get(b)?)),
                    _ => None,
                });
                let Some((a, b)) = found else {
                    return Err(loc.error(format!(
                        "{st}: \"materials\" must name two materials defined before"
                    )));
                };
                let (ma, mb) = (&self.materials[a], &self.materials[b]);
                let m = Material::mix_of(name, (a, ma), (b, mb), amount);
                let normal_detail = self.normal_detail(p, st, loc)?;
                return Ok(Material { normal_detail, ..m });
            }
            _ => {
                // measured, hair and anything else.
                for q in p.list.iter() {
                    p.ignore(&q.name);
                }
                substitute(self, "using a grey diffuse surface");
                Surface::Diffuse(Diffuse::new(Texture::Constant(diffuse_default)))
            }
        };
        let m = Material::new(name, surface);
        let normal_detail = self.normal_detail(p, st, loc)?;
        Ok(Material { normal_detail, ..m })
    }

    /// pbrt-v4's `normalmap` (an image file, read linear) or `displacement` (a float
    /// texture, for bump mapping); a material given both uses the normal map, as pbrt-v4
    /// does.
    fn normal_detail(
        &mut self,
        p: &Params,
        st: &str,
        loc: &Loc,
    ) -> crate::error::Result<Option<NormalDetail>> {
        let file = p.string("normalmap").map_err(Self::pe(loc))?;
        let bump = match p
            .find("displacement", &["texture", "float"])
            .map_err(Self::pe(loc))?
        {
            Some(_) => Some(self.float_texture_param(p, "displacement", 0.0, st, loc)?),
            None => None,
        };
        if let Some(file) = file {
            if bump.is_some() {
                self.warn(
                    loc,
                    format!("{st}: \"displacement\" is ignored beside a normal map"),
                );
            }
            let path = loc.dir().join(&file);
            if !self.find_input(&path, st, &file, loc) {
                return Ok(None);
            }
            let image = ImageTexture::load_within(
                &path,
                PathBuf::from(&file),
                Encoding::Linear,
                1.0,
                false,
                UvMapping::default(),
                &self.allowance(),
            )
            .map_err(|e| loc.error(format!("{st}: normal map: {e}")))?;
            self.held.add_image(image.image());
            return Ok(Some(NormalDetail::Map(Arc::new(image))));
        }
        Ok(match bump {
            // A constant displacement moves nothing.
            Some(Texture::Constant(_)) | None => None,
            Some(t) => Some(NormalDetail::Bump(t)),
        })
    }

    /// The coat of pbrt-v4's coated materials: its roughness (`{prefix}roughness`, ..), index
    /// `eta_name`, `thickness`, the medium's `albedo` and `g`, `maxdepth` and `nsamples`.
    fn coating(
        &mut self,
        p: &Params,
        prefix: &str,
        eta_name: &str,
        st: &str,
        loc: &Loc,
    ) -> crate::error::Result<Coating> {
        let d = Coating::default();
        let (ax, ay) = self.roughness(p, prefix, st, loc)?;
        let thickness = self.float_param(p, "thickness", d.thickness as f64, st, loc)? as f32;
        let g = self.float_param(p, "g", d.g as f64, st, loc)? as f32;
        let albedo = self.texture_param(p, "albedo", d.albedo, st, loc)?;
        let albedo = match albedo {
            Texture::Constant(c) => c,
            other => {
                self.warn(
                    loc,
                    format!("{st}: a textured \"albedo\" is replaced by its maximum"),
                );
                other.max_value()
            }
        };
        let count = |name: &str, default: u32| -> crate::error::Result<u32> {
            match p.int(name).map_err(Self::pe(loc))? {
                None => Ok(default),
                Some(n) if (1..=1_000_000).contains(&n) => Ok(n as u32),
                Some(n) => Err(loc.error(format!(
                    "{st}: \"{name}\" must be between 1 and 1000000, got {n}"
                ))),
            }
        };
        let coating = Coating {
            ior: self.eta(p, eta_name, d.ior, st, loc)?,
            roughness: ax,
            roughness_v: (ay != ax).then_some(ay),
            thickness,
            albedo,
            g,
            max_depth: count("maxdepth", d.max_depth)?,
            samples: count("nsamples", d.samples)?,
        };
        if !(thickness >= 0.0 && thickness.is_finite()) {
            return Err(loc.error(format!(
                "{st}: \"thickness\" must be a finite number >= 0, got {thickness}"
            )));
        }
        if !(g > -1.0 && g < 1.0) {
            return Err(loc.error(format!("{st}: \"g\" must be within (-1, 1), got {g}")));
        }
        if !(albedo.min_element() >= 0.0 && albedo.max_element() <= 1.0) {
            return Err(loc.error(format!(
                "{st}: \"albedo\" must be within [0, 1], got {albedo}"
            )));
        }
        if !(coating.ior > 0.0 && coating.ior.is_finite()) {
            return Err(loc.error(format!(
                "{st}: \"{eta_name}\" must be positive, got {}",
                coating.ior
            )));
        }
        Ok(coating)
    }

    /// A diffuse base under a dielectric coat as Fresnel-weighted specular over diffuse,
    /// without the layers (the substitute for materials raylink does not have).
    fn coated_diffuse(
        &mut self,
        p: &Params,
        eta: f32,
        st: &str,
        loc: &Loc,
    ) -> crate::error::Result<Classic> {
        Ok(Classic {
            diffuse: self.texture_param(p, "reflectance", Rgb::splat(0.5), st, loc)?,
            specular: Rgb::ONE,
            fresnel: true,
            ior: self.eta(p, "eta", eta, st, loc)?,
            roughness: self.isotropic_roughness(p, "", st, loc)?,
            ..Classic::blank()
        })
    }
}

/// The conductor of pbrt-v4's `reflectance` r (η = 1, k from r): a constant, or one varying
/// with a texture (then the conductor of its largest value stands for it where one value
/// is taken).
fn reflectance_conductor(r: Texture) -> (Conductor, Option<Texture>) {
    match r {
        Texture::Constant(c) => (Conductor::from_reflectance(c), None),
        t => (Conductor::from_reflectance(t.max_value()), Some(t)),
    }
}

/// The named spectrum (`"spectrum NAME" "metal-Cu-eta"`, ...) parameter `name` gives, if any.
fn named_spectrum(p: &Params, name: &str) -> Option<&'static crate::spectrum::Named> {
    let q = p.find(name, &["spectrum"]).ok().flatten()?;
    crate::bsdf::interned(q.strs().first()?)
}

/// The measured η and k of a conductor's named spectra (pbrt-v4's copper when neither is
/// given, as its default), for spectral renders.
fn measured_metal(
    p: &Params,
    prefix: &str,
) -> Option<(
    &'static crate::spectrum::Named,
    &'static crate::spectrum::Named,
)> {
    let (eta, k) = (format!("{prefix}eta"), format!("{prefix}k"));
    let kinds = ["spectrum", "rgb", "float", "blackbody", "texture"];
    let given = |n: &str| p.find(n, &kinds).ok().flatten().is_some();
    if given(&format!("{prefix}reflectance")) {
        return None;
    }
    if !given(&eta) && !given(&k) {
        return crate::bsdf::SpectralParts::metal_named("Cu");
    }
    Some((named_spectrum(p, &eta)?, named_spectrum(p, &k)?))
}
