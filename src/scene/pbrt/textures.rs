//! Textures: constant, checkerboard, image map and scale as raylink's, float textures kept
//! where they are constants.

use super::params::Params;
use super::{FloatTexture, Loader, Loc};
use crate::math::{Rgb, Vec2};
use crate::scene::texture::{Encoding, ImageTexture, UvMapping};
use crate::scene::Texture;
use glam::DMat4;
use std::path::PathBuf;
use std::sync::Arc;

impl Loader {
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
                self.add_input(&path);
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
                        self.add_input(&path);
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
}
