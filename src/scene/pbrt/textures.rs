//! Textures: constant, checkerboard, image map, scale, mix and direction mix as raylink's,
//! for spectrum and float textures alike (a float texture's value in the first channel).

use super::builder::{Builder, FloatTexture};
use super::params::Params;
use super::Loc;
use crate::math::{Rgb, Vec2, Vec3};
use crate::scene::texture::{Encoding, ImageTexture, TextureMix, UvMapping};
use crate::scene::Texture;
use glam::{DMat4, DVec3};
use std::path::PathBuf;
use std::sync::Arc;

impl Builder {
    pub(super) fn make_texture(
        &mut self,
        name: &str,
        ty: &str,
        class: &str,
        p: &Params,
        loc: &Loc,
    ) -> crate::error::Result<()> {
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
            let v = self.float_texture(class, p, st, loc)?;
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
            "imagemap" => self.image_texture(p, mapping, st, loc)?,
            "scale" => {
                let tex = self.texture_param(p, "tex", Rgb::ONE, st, loc)?;
                match self.float_texture_param(p, "scale", 1.0, st, loc)? {
                    Texture::Constant(s) => self.scaled(tex, s.x, st, loc)?,
                    by => Texture::Scale(Box::new([tex, by])),
                }
            }
            "mix" => {
                let a = self.texture_param(p, "tex1", Rgb::ZERO, st, loc)?;
                let b = self.texture_param(p, "tex2", Rgb::ONE, st, loc)?;
                let amount = self.float_texture_param(p, "amount", 0.5, st, loc)?;
                mix(a, b, amount)
            }
            "directionmix" => {
                let a = self.texture_param(p, "tex1", Rgb::ZERO, st, loc)?;
                let b = self.texture_param(p, "tex2", Rgb::ONE, st, loc)?;
                let dir = self.mix_direction(p, st, loc)?;
                Texture::DirectionMix(Box::new([a, b]), dir)
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

    /// `tex` times `s`: folded into a constant or an image's scale, else a product.
    pub(super) fn scaled(
        &mut self,
        tex: Texture,
        s: f32,
        st: &str,
        loc: &Loc,
    ) -> crate::error::Result<Texture> {
        Ok(match tex {
            Texture::Constant(c) => Texture::Constant(c * s),
            Texture::Image(img) if s != 1.0 => {
                let mut img = (*img).clone();
                img.scale *= s;
                let path = loc.dir().join(&img.file);
                self.add_input(&path);
                // Reload to keep the cached maximum right.
                let img = ImageTexture::load_within(
                    &path,
                    img.file.clone(),
                    img.encoding,
                    img.scale,
                    img.invert,
                    img.mapping,
                    &self.allowance(),
                )
                .map_err(|e| loc.error(format!("{st}: {e}")))?;
                self.held.add_image(img.image());
                Texture::Image(Arc::new(img))
            }
            other if s == 1.0 => other,
            other => Texture::Scale(Box::new([other, Texture::Constant(Rgb::splat(s))])),
        })
    }

    /// An `imagemap` texture's image.
    fn image_texture(
        &mut self,
        p: &Params,
        mapping: UvMapping,
        st: &str,
        loc: &Loc,
    ) -> crate::error::Result<Texture> {
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
        if !self.find_input(&path, st, &file, loc) {
            // Reading goes on to find the other missing files; the scene is refused.
            return Ok(Texture::Constant(Rgb::ZERO));
        }
        let image = ImageTexture::load_within(
            &path,
            PathBuf::from(&file),
            encoding,
            scale,
            invert,
            mapping,
            &self.allowance(),
        )
        .map_err(|e| loc.error(format!("{st}: {e}")))?;
        self.held.add_image(image.image());
        Ok(Texture::Image(Arc::new(image)))
    }

    /// A float texture of class `class`: its value in the first channel.
    fn float_texture(
        &mut self,
        class: &str,
        p: &Params,
        st: &str,
        loc: &Loc,
    ) -> crate::error::Result<FloatTexture> {
        let tex = match class {
            "constant" => {
                return Ok(FloatTexture::Constant(
                    p.float_or("value", 1.0).map_err(Self::pe(loc))?,
                ))
            }
            "imagemap" => {
                let mapping = self.mapping(p, st, loc)?;
                self.image_texture(p, mapping, st, loc)?
            }
            "checkerboard" => {
                let mapping = self.mapping(p, st, loc)?;
                let even = self.float_param(p, "tex1", 1.0, st, loc)? as f32;
                let odd = self.float_param(p, "tex2", 0.0, st, loc)? as f32;
                let (even, odd) = (Rgb::splat(even), Rgb::splat(odd));
                match p.int("dimension").map_err(Self::pe(loc))?.unwrap_or(2) {
                    3 => Texture::Checker {
                        even,
                        odd,
                        size: 1.0,
                    },
                    _ => Texture::UvChecker { even, odd, mapping },
                }
            }
            "scale" => {
                let tex = self.float_texture_param(p, "tex", 1.0, st, loc)?;
                match self.float_texture_param(p, "scale", 1.0, st, loc)? {
                    Texture::Constant(s) => self.scaled(tex, s.x, st, loc)?,
                    by => Texture::Scale(Box::new([tex, by])),
                }
            }
            "mix" => {
                let a = self.float_texture_param(p, "tex1", 0.0, st, loc)?;
                let b = self.float_texture_param(p, "tex2", 1.0, st, loc)?;
                let amount = self.float_texture_param(p, "amount", 0.5, st, loc)?;
                mix(a, b, amount)
            }
            "directionmix" => {
                let a = self.float_texture_param(p, "tex1", 0.0, st, loc)?;
                let b = self.float_texture_param(p, "tex2", 1.0, st, loc)?;
                let dir = self.mix_direction(p, st, loc)?;
                Texture::DirectionMix(Box::new([a, b]), dir)
            }
            _ => {
                for q in &p.list {
                    p.ignore(&q.name);
                }
                return Ok(FloatTexture::Unsupported);
            }
        };
        Ok(match tex {
            Texture::Constant(c) => FloatTexture::Constant(f64::from(c.x)),
            varying => FloatTexture::Varying(varying),
        })
    }

    /// A `directionmix` texture's `dir` (default +y), from the texture's space to the
    /// world's, as a unit vector.
    fn mix_direction(&mut self, p: &Params, st: &str, loc: &Loc) -> crate::error::Result<Vec3> {
        let dir = match p
            .find("dir", &["vector3", "vector"])
            .map_err(Self::pe(loc))?
        {
            Some(q) => match q.nums() {
                [x, y, z] => DVec3::new(*x, *y, *z),
                _ => {
                    return Err(loc
                        .at(q.line, q.col)
                        .error(format!("{st}: \"dir\" takes 3 numbers")))
                }
            },
            None => DVec3::Y,
        };
        let world = self.state.ctm.transform_vector3(dir);
        world
            .try_normalize()
            .map(|d| d.as_vec3())
            .ok_or_else(|| loc.error(format!("{st}: \"dir\" must not be the zero vector")))
    }

    fn mapping(&mut self, p: &Params, st: &str, loc: &Loc) -> crate::error::Result<UvMapping> {
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

/// (1 − amount)·a + amount·b, folded when the amount is a constant 0 or 1.
fn mix(a: Texture, b: Texture, amount: Texture) -> Texture {
    match amount {
        Texture::Constant(c) if c.x <= 0.0 => a,
        Texture::Constant(c) if c.x >= 1.0 => b,
        amount => Texture::Mix(Box::new(TextureMix {
            textures: [a, b],
            amount,
        })),
    }
}
