//! Textures: values that vary over a surface. Image textures are looked up by surface
//! (u, v), bilinearly, repeating; as in pbrt-v4, v = 0 is the bottom row of the image file.

use crate::image::output::{read_image_within, srgb_decode};
use crate::image::Image;
use crate::input_file::Allowance;
use crate::math::{Rgb, Vec2, Vec3};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Maps surface (u, v) to texture (s, t) = (u, v) · scale + offset (pbrt's `uscale`,
/// `vscale`, `udelta`, `vdelta`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvMapping {
    pub scale: Vec2,
    pub offset: Vec2,
}

impl Default for UvMapping {
    fn default() -> Self {
        UvMapping {
            scale: Vec2::ONE,
            offset: Vec2::ZERO,
        }
    }
}

impl UvMapping {
    pub fn map(&self, uv: Vec2) -> Vec2 {
        uv * self.scale + self.offset
    }
}

/// How the stored values of an image file become linear values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Encoding {
    Linear,
    Srgb,
    Gamma(f32),
}

impl Encoding {
    /// pbrt-v4's default: sRGB for 8-bit formats, linear for the others.
    pub(crate) fn default_for(path: &Path) -> Encoding {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        match ext.as_str() {
            "png" | "jpg" | "jpeg" | "tga" | "bmp" | "gif" => Encoding::Srgb,
            _ => Encoding::Linear,
        }
    }

    /// Parses pbrt's and the TOML format's spelling: `linear`, `sRGB`, `gamma 2.2`.
    pub fn parse(s: &str) -> Option<Encoding> {
        let s = s.trim();
        if s.eq_ignore_ascii_case("linear") {
            Some(Encoding::Linear)
        } else if s.eq_ignore_ascii_case("srgb") {
            Some(Encoding::Srgb)
        } else {
            let g: f32 = s.strip_prefix("gamma")?.trim().parse().ok()?;
            (g.is_finite() && g > 0.0).then_some(Encoding::Gamma(g))
        }
    }

    pub fn name(&self) -> String {
        match self {
            Encoding::Linear => "linear".into(),
            Encoding::Srgb => "sRGB".into(),
            Encoding::Gamma(g) => format!("gamma {g}"),
        }
    }

    pub fn decode(&self, v: f32) -> f32 {
        match *self {
            Encoding::Linear => v,
            Encoding::Srgb => srgb_decode(v),
            Encoding::Gamma(g) => v.max(0.0).powf(g),
        }
    }
}

/// An image texture with its parameters; the pixels are decoded to linear values.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageTexture {
    /// The file as the scene names it (relative paths are relative to the scene file).
    pub file: PathBuf,
    pub encoding: Encoding,
    /// Multiplies the looked-up value.
    pub scale: f32,
    /// pbrt's `invert`: the value is 1 − value (after the scale), clamped at zero.
    pub invert: bool,
    pub mapping: UvMapping,
    image: Image,
    max: Rgb,
    mean: Rgb,
}

impl ImageTexture {
    /// Reads the image at `path` (the resolved `file`).
    pub fn load(
        path: &Path,
        file: PathBuf,
        encoding: Encoding,
        scale: f32,
        invert: bool,
        mapping: UvMapping,
    ) -> crate::error::Result<ImageTexture> {
        let allowance = Allowance::machine();
        Self::load_within(path, file, encoding, scale, invert, mapping, &allowance)
    }

    /// [`load`](Self::load) within what `allowance` leaves of the job's memory budget,
    /// checked before the pixels are read.
    pub fn load_within(
        path: &Path,
        file: PathBuf,
        encoding: Encoding,
        scale: f32,
        invert: bool,
        mapping: UvMapping,
        allowance: &Allowance,
    ) -> crate::error::Result<ImageTexture> {
        let (image, _) = read_image_within(path, allowance)?;
        if image.pixels.is_empty() {
            return Err(crate::error::Error::image(path, "the image has no pixels"));
        }
        Ok(ImageTexture::from_image(
            image, file, encoding, scale, invert, mapping,
        ))
    }

    /// The texture of an image in memory (its values as stored, decoded by `encoding`);
    /// `file` names it in messages and converted scenes. The image must have pixels.
    pub(crate) fn from_image(
        mut image: Image,
        file: PathBuf,
        encoding: Encoding,
        scale: f32,
        invert: bool,
        mapping: UvMapping,
    ) -> ImageTexture {
        assert!(!image.pixels.is_empty(), "an image texture needs pixels");
        for p in &mut image.pixels {
            *p = Rgb::new(
                encoding.decode(p.x),
                encoding.decode(p.y),
                encoding.decode(p.z),
            );
        }
        let max = image
            .pixels
            .iter()
            .fold(Rgb::ZERO, |m, &p| m.max(p.max(Rgb::ZERO)));
        let max = if invert {
            Rgb::ONE
        } else {
            max * scale.max(0.0)
        };
        let value = |p: Rgb| {
            let v = p * scale;
            if invert {
                (Rgb::ONE - v).max(Rgb::ZERO)
            } else {
                v
            }
        };
        let sum = image.pixels.iter().fold(Rgb::ZERO, |s, &p| s + value(p));
        let mean = sum / image.pixels.len() as f32;
        ImageTexture {
            file,
            encoding,
            scale,
            invert,
            mapping,
            image,
            max,
            mean,
        }
    }

    pub fn image(&self) -> &Image {
        &self.image
    }

    pub(crate) fn max_value(&self) -> Rgb {
        self.max
    }

    /// The mean over the image's pixels.
    pub(crate) fn mean_value(&self) -> Rgb {
        self.mean
    }

    /// The value at surface coordinates `uv`.
    pub fn eval(&self, uv: Vec2) -> Rgb {
        let st = self.mapping.map(uv);
        let (w, h) = (self.image.width as i64, self.image.height as i64);
        // Pixel centres at half-integers; t flipped so that t = 0 is the bottom row.
        let x = st.x as f64 * w as f64 - 0.5;
        let y = (1.0 - st.y as f64) * h as f64 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
        let texel = |i: i64, j: i64| {
            self.image
                .get(i.rem_euclid(w) as u32, j.rem_euclid(h) as u32)
        };
        let (i, j) = (x0 as i64, y0 as i64);
        let v = (texel(i, j) * (1.0 - fx) + texel(i + 1, j) * fx) * (1.0 - fy)
            + (texel(i, j + 1) * (1.0 - fx) + texel(i + 1, j + 1) * fx) * fy;
        let v = v * self.scale;
        if self.invert {
            (Rgb::ONE - v).max(Rgb::ZERO)
        } else {
            v
        }
    }
}

/// A colour that may vary over a surface. Float-valued parameters (roughness, a bump map's
/// displacement, a mix's amount) are textures too, read from the first channel, as pbrt-v4
/// reads a float image.
#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    Constant(Rgb),
    /// A solid (3-D) checkerboard in world space: cubes of side `size` alternate colours.
    Checker {
        even: Rgb,
        odd: Rgb,
        size: f32,
    },
    /// A checkerboard over the surface's (u, v) (pbrt's 2-D `checkerboard`): `even` where
    /// floor(s) + floor(t) is even for (s, t) = `mapping`(u, v).
    UvChecker {
        even: Rgb,
        odd: Rgb,
        mapping: UvMapping,
    },
    /// An image looked up by (u, v).
    Image(Arc<ImageTexture>),
    /// The product of two textures (pbrt's `scale`: `tex` times `scale`).
    Scale(Box<[Texture; 2]>),
    /// (1 − amount)·first + amount·second, the amount a float texture (pbrt's `mix`).
    Mix(Box<TextureMix>),
    /// |n·dir|·first + (1 − |n·dir|)·second with n the geometric normal (pbrt's
    /// `directionmix`).
    DirectionMix(Box<[Texture; 2]>, Vec3),
}

/// The parts of a [`Texture::Mix`].
#[derive(Clone, Debug, PartialEq)]
pub struct TextureMix {
    pub textures: [Texture; 2],
    pub amount: Texture,
}

impl Texture {
    /// The colour at world position `p` with surface coordinates `uv` and geometric normal
    /// `n`.
    pub fn eval(&self, p: Vec3, uv: Vec2, n: Vec3) -> Rgb {
        match self {
            Texture::Constant(c) => *c,
            Texture::Checker { even, odd, size } => {
                // A small bias keeps faces that lie exactly on a cell boundary on one side.
                let cell = ((p + Vec3::splat(1e-4)) / *size).floor();
                if (cell.x + cell.y + cell.z).rem_euclid(2.0) < 0.5 {
                    *even
                } else {
                    *odd
                }
            }
            Texture::UvChecker { even, odd, mapping } => {
                let st = mapping.map(uv).floor();
                if (st.x + st.y).rem_euclid(2.0) < 0.5 {
                    *even
                } else {
                    *odd
                }
            }
            Texture::Image(image) => image.eval(uv),
            Texture::Scale(t) => t[0].eval(p, uv, n) * t[1].eval_float(p, uv, n),
            Texture::Mix(m) => {
                let a = m.amount.eval_float(p, uv, n);
                let [t0, t1] = &m.textures;
                // Each side only where it has weight, as pbrt-v4 does.
                let v0 = if a != 1.0 {
                    t0.eval(p, uv, n)
                } else {
                    Rgb::ZERO
                };
                let v1 = if a != 0.0 {
                    t1.eval(p, uv, n)
                } else {
                    Rgb::ZERO
                };
                v0 * (1.0 - a) + v1 * a
            }
            Texture::DirectionMix(t, dir) => {
                let a = n.dot(*dir).abs();
                t[0].eval(p, uv, n) * a + t[1].eval(p, uv, n) * (1.0 - a)
            }
        }
    }

    /// The value of a float texture: the first channel.
    pub fn eval_float(&self, p: Vec3, uv: Vec2, n: Vec3) -> f32 {
        match self {
            Texture::Constant(c) => c.x,
            other => other.eval(p, uv, n).x,
        }
    }

    /// The largest value the texture takes (for contribution bounds and validation).
    pub(crate) fn max_value(&self) -> Rgb {
        match self {
            Texture::Constant(c) => *c,
            Texture::Checker { even, odd, .. } | Texture::UvChecker { even, odd, .. } => {
                even.max(*odd)
            }
            Texture::Image(image) => image.max_value(),
            Texture::Scale(t) => t[0].max_value() * t[1].max_value().x,
            Texture::Mix(m) => m.textures[0].max_value().max(m.textures[1].max_value()),
            Texture::DirectionMix(t, _) => t[0].max_value().max(t[1].max_value()),
        }
    }

    /// The texture's mean over one period of its pattern (exact for a constant, a
    /// checkerboard and an image; a product or mix of textures takes the product or mix of
    /// their means, and a direction mix weighs its two textures equally). The techniques
    /// that take one value per surface use it.
    pub(crate) fn mean_value(&self) -> Rgb {
        match self {
            Texture::Constant(c) => *c,
            Texture::Checker { even, odd, .. } | Texture::UvChecker { even, odd, .. } => {
                (*even + *odd) * 0.5
            }
            Texture::Image(image) => image.mean_value(),
            Texture::Scale(t) => t[0].mean_value() * t[1].mean_value().x,
            Texture::Mix(m) => {
                let a = m.amount.mean_value().x;
                m.textures[0].mean_value() * (1.0 - a) + m.textures[1].mean_value() * a
            }
            Texture::DirectionMix(t, _) => (t[0].mean_value() + t[1].mean_value()) * 0.5,
        }
    }

    /// Whether the texture is the same everywhere.
    pub(crate) fn is_constant(&self) -> bool {
        matches!(self, Texture::Constant(_))
    }
}
