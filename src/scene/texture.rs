//! Image textures: an image looked up by surface (u, v), bilinearly, repeating. As in
//! pbrt-v4, v = 0 is the bottom row of the image file.

use crate::image::output::{read_image, srgb_decode};
use crate::image::Image;
use crate::math::{Rgb, Vec2};
use std::path::{Path, PathBuf};

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
    pub fn default_for(path: &Path) -> Encoding {
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
    ) -> crate::Result<ImageTexture> {
        let (mut image, _) = read_image(path)?;
        for p in &mut image.pixels {
            *p = Rgb::new(
                encoding.decode(p.x),
                encoding.decode(p.y),
                encoding.decode(p.z),
            );
        }
        if image.pixels.is_empty() {
            return Err(crate::Error::image(path, "the image has no pixels"));
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
        Ok(ImageTexture {
            file,
            encoding,
            scale,
            invert,
            mapping,
            image,
            max,
        })
    }

    pub fn image(&self) -> &Image {
        &self.image
    }

    pub fn max_value(&self) -> Rgb {
        self.max
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
