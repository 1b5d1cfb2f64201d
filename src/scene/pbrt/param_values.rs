//! Parameters whose values the builder resolves: spectra (rgb, named, sampled, blackbody) as
//! RGB, and the names of spectrum and float textures.

use super::builder::{Builder, FloatTexture};
use super::params::{ParamError, Params};
use super::spectrum::{self, Kind};
use super::Loc;
use crate::math::Rgb;
use crate::scene::Texture;
use crate::spectrum::{BlackbodyEmission, ColorSpace};

impl Builder {
    pub(super) fn pe(loc: &Loc) -> impl Fn(ParamError) -> crate::error::Error + '_ {
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
    ) -> crate::error::Result<Option<Rgb>> {
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
                self.in_srgb(Rgb::new(v[0] as f32, v[1] as f32, v[2] as f32), &qloc)
            }
            "blackbody" if kind == Kind::Illuminant => match self.blackbody(p, name, loc)? {
                Some(body) => body.rgb(),
                None => Rgb::ZERO,
            },
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

    /// An RGB value of the current `ColorSpace` as linear sRGB, raylink's colours: through
    /// CIE XYZ (an emitter's white is its space's white). A reflectance outside sRGB's gamut
    /// (a negative component) is clipped to it, with a warning.
    fn in_srgb(&mut self, rgb: Rgb, loc: &Loc) -> Rgb {
        let space = self.state.color_space;
        if space == ColorSpace::srgb() {
            return rgb;
        }
        let srgb = crate::image::output::matrix_from_srgb(space).inverse() * rgb;
        if srgb.min_element() < -1e-4 * srgb.max_element().abs().max(1e-6) {
            self.warn(
                loc,
                format!(
                    "rgb {rgb} in {} lies outside sRGB's gamut; clipped to {}",
                    space.name,
                    srgb.max(Rgb::ZERO)
                ),
            );
        }
        srgb.max(Rgb::ZERO)
    }

    /// The blackbody a `blackbody` parameter `name` gives an emitter, if it is one.
    pub(super) fn blackbody(
        &self,
        p: &Params,
        name: &str,
        loc: &Loc,
    ) -> crate::error::Result<Option<BlackbodyEmission>> {
        let Ok(Some(q)) = p.find(name, &["blackbody"]) else {
            return Ok(None);
        };
        let qloc = loc.at(q.line, q.col);
        match q.nums() {
            [kelvin] => BlackbodyEmission::new(*kelvin)
                .map(Some)
                .map_err(|why| qloc.error(format!("parameter \"{name}\": {why}"))),
            v => Err(qloc.error(format!(
                "parameter \"{name}\": a blackbody takes one temperature, not {} numbers",
                v.len()
            ))),
        }
    }

    /// A spectrum parameter that may also name a texture.
    pub(super) fn texture_param(
        &mut self,
        p: &Params,
        name: &str,
        default: Rgb,
        statement: &str,
        loc: &Loc,
    ) -> crate::error::Result<Texture> {
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

    /// A float parameter's value: a number (given, a constant texture's, or `default` when
    /// absent or when it names a texture of a class raylink cannot evaluate, with a
    /// warning), or a texture that varies.
    fn float_value(
        &mut self,
        p: &Params,
        name: &str,
        default: f64,
        statement: &str,
        loc: &Loc,
    ) -> crate::error::Result<Result<f64, Texture>> {
        let Some(q) = p.find(name, &["float", "texture"]).map_err(Self::pe(loc))? else {
            return Ok(Ok(default));
        };
        if q.ty == "float" {
            return Ok(Ok(q.nums()[0]));
        }
        let tex = q.strs()[0].clone();
        let qloc = loc.at(q.line, q.col);
        match self.float_textures.get(&tex) {
            Some(FloatTexture::Constant(v)) => Ok(Ok(*v)),
            Some(FloatTexture::Varying(t)) => Ok(Err(t.clone())),
            Some(FloatTexture::Unsupported) => {
                self.warn(
                    &qloc,
                    format!(
                        "{statement}: \"{name}\" varies by texture \"{tex}\", which raylink \
                         cannot evaluate; using {default}"
                    ),
                );
                Ok(Ok(default))
            }
            None => Err(qloc.error(format!("{statement}: no float texture named \"{tex}\""))),
        }
    }

    /// A float parameter that may also name a float texture: a varying one gives its
    /// largest value, with a warning.
    pub(super) fn float_param(
        &mut self,
        p: &Params,
        name: &str,
        default: f64,
        statement: &str,
        loc: &Loc,
    ) -> crate::error::Result<f64> {
        match self.float_value(p, name, default, statement, loc)? {
            Ok(v) => Ok(v),
            Err(t) => {
                let top = f64::from(t.max_value().x);
                self.warn(
                    loc,
                    format!(
                        "{statement}: \"{name}\" cannot vary here; using its texture's \
                         largest value, {top}"
                    ),
                );
                Ok(top)
            }
        }
    }

    /// Whether parameter `name` names a float texture that varies over the surface.
    pub(super) fn names_varying_texture(&self, p: &Params, name: &str) -> bool {
        let Ok(Some(q)) = p.find(name, &["texture"]) else {
            return false;
        };
        matches!(
            q.strs().first().and_then(|t| self.float_textures.get(t)),
            Some(FloatTexture::Varying(_))
        )
    }

    /// A float parameter that may vary by texture, as a texture (its value in the first
    /// channel); a texture of a class raylink cannot evaluate is `default` with a warning.
    pub(super) fn float_texture_param(
        &mut self,
        p: &Params,
        name: &str,
        default: f64,
        statement: &str,
        loc: &Loc,
    ) -> crate::error::Result<Texture> {
        Ok(match self.float_value(p, name, default, statement, loc)? {
            Ok(v) => Texture::Constant(Rgb::splat(v as f32)),
            Err(t) => t,
        })
    }

    /// A colour where raylink takes no texture (a spectrum checkerboard's `tex1`, `tex2`):
    /// a textured one uses its largest value.
    pub(super) fn texture_to_constant(&mut self, t: Texture, st: &str, loc: &Loc) -> Rgb {
        match t {
            Texture::Constant(c) => c,
            other => {
                self.warn(
                    loc,
                    format!("{st}: a texture here is replaced by its largest value"),
                );
                other.max_value()
            }
        }
    }
}
