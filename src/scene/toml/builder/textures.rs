//! Textures of a material: a colour, or a table (checkerboards, an image, and products and
//! mixes of other textures). Errors name the field under the material's key
//! (`diffuse.checker.even`, `roughness.mix.amount`, ...).

use super::Builder;
use crate::math::Vec2;
use crate::scene::texture::{Encoding, ImageTexture, TextureMix, UvMapping};
use crate::scene::toml::checks::{colour, finite, finite3, non_negative, positive};
use crate::scene::toml::diagnostics::Site;
use crate::scene::toml::schema::{DiffuseDesc, TextureTable};
use crate::scene::{NormalDetail, Texture};

impl Builder<'_> {
    /// The texture under `key`: a colour (a number is a grey) or a texture table.
    pub(super) fn texture(
        &self,
        site: &Site,
        key: &str,
        t: DiffuseDesc,
    ) -> crate::error::Result<Texture> {
        match t {
            DiffuseDesc::Colour(c) => Ok(Texture::Constant(
                colour(c).map_err(|m| self.ctx.fail(site, key, m))?,
            )),
            DiffuseDesc::Texture(t) => self.texture_table(site, key, t),
        }
    }

    fn texture_table(
        &self,
        site: &Site,
        key: &str,
        t: TextureTable,
    ) -> crate::error::Result<Texture> {
        let ctx = self.ctx;
        let fail = |field: &str| {
            let at = format!("{key}.{field}");
            move |m: String| ctx.fail(site, &at, m)
        };
        let count = [
            t.checker.is_some(),
            t.uv_checker.is_some(),
            t.image.is_some(),
            t.scale.is_some(),
            t.mix.is_some(),
            t.direction_mix.is_some(),
        ]
        .iter()
        .filter(|&&b| b)
        .count();
        if count != 1 {
            return Err(ctx.fail(
                site,
                key,
                "a texture table takes exactly one of checker, uv_checker, image, scale, mix or \
                 direction_mix",
            ));
        }
        let mapping = |us: Option<f32>, vs: Option<f32>, ud: Option<f32>, vd: Option<f32>| {
            let f = |v: Option<f32>, d: f32| finite(v.unwrap_or(d));
            Ok::<_, String>(UvMapping {
                scale: Vec2::new(f(us, 1.0)?, f(vs, 1.0)?),
                offset: Vec2::new(f(ud, 0.0)?, f(vd, 0.0)?),
            })
        };
        if let Some(c) = t.checker {
            return Ok(Texture::Checker {
                even: colour(c.even.0).map_err(fail("checker.even"))?,
                odd: colour(c.odd.0).map_err(fail("checker.odd"))?,
                size: positive(c.size.unwrap_or(1.0)).map_err(fail("checker.size"))?,
            });
        }
        if let Some(c) = t.uv_checker {
            return Ok(Texture::UvChecker {
                even: colour(c.even.0).map_err(fail("uv_checker.even"))?,
                odd: colour(c.odd.0).map_err(fail("uv_checker.odd"))?,
                mapping: mapping(c.uscale, c.vscale, c.udelta, c.vdelta)
                    .map_err(fail("uv_checker"))?,
            });
        }
        if let Some(s) = t.scale {
            let s = *s;
            return Ok(Texture::Scale(Box::new([
                self.texture(site, &format!("{key}.scale.texture"), s.texture)?,
                self.texture(site, &format!("{key}.scale.by"), s.by)?,
            ])));
        }
        if let Some(m) = t.mix {
            let [a, b] = m.textures;
            let amount = self.texture(site, &format!("{key}.mix.amount"), m.amount)?;
            if amount.max_value().x > 1.0 {
                return Err(fail("mix.amount")("must lie in [0, 1]".into()));
            }
            return Ok(Texture::Mix(Box::new(TextureMix {
                textures: [
                    self.texture(site, &format!("{key}.mix.textures[0]"), a)?,
                    self.texture(site, &format!("{key}.mix.textures[1]"), b)?,
                ],
                amount,
            })));
        }
        if let Some(m) = t.direction_mix {
            let [a, b] = m.textures;
            let dir = finite3(m.direction.0)
                .and_then(|d| {
                    d.try_normalize()
                        .ok_or_else(|| "must not be the zero vector".to_string())
                })
                .map_err(fail("direction_mix.direction"))?;
            return Ok(Texture::DirectionMix(
                Box::new([
                    self.texture(site, &format!("{key}.direction_mix.textures[0]"), a)?,
                    self.texture(site, &format!("{key}.direction_mix.textures[1]"), b)?,
                ]),
                dir,
            ));
        }
        let i = t.image.expect("counted above");
        let path = self.dir.join(&i.file);
        let encoding = match i.encoding {
            None => Encoding::default_for(&path),
            Some(e) => Encoding::parse(&e).ok_or_else(|| {
                fail("image.encoding")(format!(
                    "must be \"linear\", \"sRGB\" or \"gamma G\", got \"{e}\""
                ))
            })?,
        };
        let scale = non_negative(i.scale.unwrap_or(1.0)).map_err(fail("image.scale"))?;
        let mapping = mapping(i.uscale, i.vscale, i.udelta, i.vdelta).map_err(fail("image"))?;
        self.inputs.borrow_mut().push(path.clone());
        let image = ImageTexture::load_within(
            &path,
            i.file.into(),
            encoding,
            scale,
            i.invert.unwrap_or(false),
            mapping,
            &self.allowance(),
        )
        .map_err(|e| fail("image.file")(e.to_string()))?;
        self.hold_image(image.image());
        Ok(Texture::Image(std::sync::Arc::new(image)))
    }

    /// A material's `normal_map` (an image file, read linear) or `bump` (a float texture).
    pub(super) fn normal_detail(
        &self,
        site: &Site,
        normal_map: Option<String>,
        bump: Option<DiffuseDesc>,
    ) -> crate::error::Result<Option<NormalDetail>> {
        match (normal_map, bump) {
            (None, None) => Ok(None),
            (Some(_), Some(_)) => Err(self.ctx.fail(
                site,
                "bump",
                "a material takes a normal_map or a bump map, not both",
            )),
            (None, Some(b)) => Ok(Some(NormalDetail::Bump(self.texture(site, "bump", b)?))),
            (Some(file), None) => {
                let path = self.dir.join(&file);
                self.inputs.borrow_mut().push(path.clone());
                let image = ImageTexture::load_within(
                    &path,
                    file.into(),
                    Encoding::Linear,
                    1.0,
                    false,
                    UvMapping::default(),
                    &self.allowance(),
                )
                .map_err(|e| self.ctx.fail(site, "normal_map", e))?;
                self.hold_image(image.image());
                Ok(Some(NormalDetail::Map(std::sync::Arc::new(image))))
            }
        }
    }
}
