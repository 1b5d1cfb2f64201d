//! Shape alpha: `"float alpha"` and `"texture alpha"` naming a float `constant` or
//! `imagemap` texture.

use super::builder::{Builder, FloatTexture};
use super::params::Params;
use super::Loc;
use crate::scene::{Alpha, Texture};

impl Builder {
    /// The shape's `alpha` parameter: None for an opaque shape (no alpha, or alpha >= 1).
    pub(super) fn shape_alpha(
        &mut self,
        p: &Params,
        st: &str,
        loc: &Loc,
    ) -> crate::error::Result<Option<Alpha>> {
        let Some(q) = p
            .find("alpha", &["float", "texture"])
            .map_err(Self::pe(loc))?
        else {
            return Ok(None);
        };
        let qloc = loc.at(q.line, q.col);
        let constant = |a: f64| {
            if a.is_nan() {
                Err(qloc.error(format!("{st}: \"alpha\" must be a number, got {a}")))
            } else {
                Ok((a < 1.0).then_some(Alpha::Constant(a as f32)))
            }
        };
        if q.ty == "float" {
            return constant(q.nums()[0]);
        }
        let tex = q.strs()[0].clone();
        match self.float_textures.get(&tex) {
            Some(FloatTexture::Constant(a)) => constant(*a),
            Some(FloatTexture::Varying(Texture::Image(image))) => {
                Ok(Some(Alpha::Image(image.clone())))
            }
            Some(FloatTexture::Varying(_) | FloatTexture::Unsupported) => {
                self.warn(
                    &qloc,
                    format!(
                        "{st}: \"alpha\" texture \"{tex}\" is of a kind raylink cannot use \
                         as a cut-out (constant and imagemap only); the shape is opaque"
                    ),
                );
                Ok(None)
            }
            None => Err(qloc.error(format!("{st}: no float texture named \"{tex}\""))),
        }
    }
}
