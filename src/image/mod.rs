//! Images in memory and on disk. Files are read and written through `io`: OpenImageIO
//! (`oiio`, the only unsafe OpenImageIO code) where raylink is built with it, else the
//! pure-Rust `codecs`; `output` chooses encoding by extension and writes atomically.

pub mod codecs;
pub mod compare;
pub mod display;
pub mod filter;
pub mod io;
#[cfg(feature = "oiio")]
pub mod oiio;
#[cfg(feature = "oiio")]
mod oiio_sys;
pub mod output;

use crate::math::Rgb;

/// A linear RGB float image, row-major, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<Rgb>,
}

impl Image {
    pub fn new(width: u32, height: u32) -> Self {
        Image {
            width,
            height,
            pixels: vec![Rgb::ZERO; width as usize * height as usize],
        }
    }

    /// A black image, or [`crate::error::Error::OutOfMemory`] if its pixels cannot be allocated.
    pub(crate) fn try_new(width: u32, height: u32) -> crate::error::Result<Self> {
        let pixels = crate::platform::try_vec(width as usize * height as usize, Rgb::ZERO, || {
            format!("a {width}x{height} image")
        })?;
        Ok(Image {
            width,
            height,
            pixels,
        })
    }

    pub fn get(&self, x: u32, y: u32) -> Rgb {
        self.pixels[(y * self.width + x) as usize]
    }

    pub fn set(&mut self, x: u32, y: u32, c: Rgb) {
        self.pixels[(y * self.width + x) as usize] = c;
    }

    /// Root-mean-square difference over all channels of all pixels.
    pub fn rmse(&self, other: &Image) -> f32 {
        assert_eq!((self.width, self.height), (other.width, other.height));
        let sum: f64 = self
            .pixels
            .iter()
            .zip(&other.pixels)
            .map(|(a, b)| {
                let d = *a - *b;
                d.dot(d) as f64
            })
            .sum();
        (sum / (3.0 * self.pixels.len() as f64)).sqrt() as f32
    }
}

/// A value attached to an image file (EXR header attribute).
#[derive(Clone, Debug, PartialEq)]
pub enum MetaValue {
    Str(String),
    Int(i32),
    Float(f32),
}

/// Named metadata, in the order it should be written.
pub type Metadata = Vec<(String, MetaValue)>;
