//! How Whitted's integrator and the network sample a pixel: Whitted's adaptive corner
//! subdivision, or regular supersampling (the sampler itself is in the render loops).

use crate::error::{Error, Result};
use crate::settings::{AntiAliasing, Settings, MAX_SPP};
use crate::transport::settings::Setting;

/// Deepest subdivision the adaptive sampler allows (a 256x256 lattice per pixel).
pub const MAX_ADAPTIVE_DEPTH: u32 = 8;
/// Default contrast threshold of adaptive anti-aliasing. On scenes/whitted.toml at 320x240,
/// 0.1 with depth 3 traces 45% of the rays of 4x4 supersampling for an RMSE (to 16x16) of
/// 0.0057 against 4x4's 0.0049.
pub const DEFAULT_AA_THRESHOLD: f32 = 0.1;
/// Default deepest subdivision level of adaptive anti-aliasing (up to 8x8 squares per pixel).
pub const DEFAULT_AA_DEPTH: u32 = 3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PixelSampling {
    /// Whitted's adaptive anti-aliasing: samples at the corners of the pixel square; a square
    /// whose corners differ by more than `threshold` (or see different objects) is split into
    /// four, recursively, down to `max_depth` levels; sub-squares are weighted by area.
    Adaptive { threshold: f32, max_depth: u32 },
    /// `n`×`n` samples on a regular grid inside each pixel, averaged (a box filter).
    Uniform { n: u32 },
}

impl Default for PixelSampling {
    fn default() -> Self {
        PixelSampling::Adaptive {
            threshold: DEFAULT_AA_THRESHOLD,
            max_depth: DEFAULT_AA_DEPTH,
        }
    }
}

/// As the metadata and the settings name it: `adaptive threshold=0.1 depth=3`, `uniform
/// spp=16`.
impl std::fmt::Display for PixelSampling {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            PixelSampling::Adaptive {
                threshold,
                max_depth,
            } => write!(f, "adaptive threshold={threshold} depth={max_depth}"),
            PixelSampling::Uniform { n } => write!(f, "uniform spp={}", n * n),
        }
    }
}

impl PixelSampling {
    /// As a job's settings key names it, in the settings' own words: `aa=adaptive
    /// aa_threshold=0.1 aa_depth=3`, `aa=uniform spp=16`.
    pub(crate) fn key(&self) -> String {
        match *self {
            PixelSampling::Adaptive {
                threshold,
                max_depth,
            } => format!("aa=adaptive aa_threshold={threshold} aa_depth={max_depth}"),
            PixelSampling::Uniform { n } => format!("aa=uniform spp={}", n * n),
        }
    }

    pub fn validate(&self) -> Result<()> {
        match *self {
            PixelSampling::Adaptive {
                threshold,
                max_depth,
            } => {
                if !(threshold >= 0.0 && threshold.is_finite()) {
                    return Err(Error::setting(
                        "aa_threshold",
                        format!("must be a non-negative number, got {threshold}"),
                    ));
                }
                if max_depth > MAX_ADAPTIVE_DEPTH {
                    return Err(Error::setting(
                        "aa_depth",
                        format!("must be at most {MAX_ADAPTIVE_DEPTH}, got {max_depth}"),
                    ));
                }
            }
            PixelSampling::Uniform { n } => {
                if n == 0 || n > 64 {
                    return Err(Error::setting(
                        "spp",
                        format!(
                            "must be 1 to 4096 for uniform supersampling (at most 64 per pixel \
                             side), got {}",
                            n * n
                        ),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// The pixel-sampling settings of Whitted's integrator and the network.
pub const PIXELS: &[Setting] = &[
    Setting {
        name: "aa",
        scene_key: Some(("render", "aa")),
        example: "\"uniform\"",
        doc: "Anti-aliasing: adaptive corner subdivision (the default without spp) or a \
              regular grid of spp samples.",
    },
    Setting {
        name: "aa_threshold",
        scene_key: Some(("render", "aa_threshold")),
        example: "0.1",
        doc: "Adaptive anti-aliasing: the largest corner difference accepted without \
              subdividing (default 0.1).",
    },
    Setting {
        name: "aa_depth",
        scene_key: Some(("render", "aa_depth")),
        example: "3",
        doc: "Adaptive anti-aliasing: the deepest subdivision level (default 3, at most 8).",
    },
];

impl PixelSampling {
    /// Uniform supersampling when `spp` is given (a square) or `aa` asks for it, else
    /// adaptive; every value checked.
    pub(crate) fn from_settings(s: &Settings) -> Result<PixelSampling> {
        let aa = s.aa.unwrap_or(if s.spp.is_some() {
            AntiAliasing::Uniform
        } else {
            AntiAliasing::Adaptive
        });
        let sampling = match aa {
            AntiAliasing::Adaptive => {
                if s.spp.is_some() {
                    return Err(Error::setting(
                        "spp",
                        "applies to uniform supersampling; adaptive anti-aliasing is set by \
                         aa_threshold and aa_depth",
                    ));
                }
                PixelSampling::Adaptive {
                    threshold: s.aa_threshold.unwrap_or(DEFAULT_AA_THRESHOLD),
                    max_depth: s.aa_depth.unwrap_or(DEFAULT_AA_DEPTH),
                }
            }
            AntiAliasing::Uniform => {
                let spp = s.spp.unwrap_or(16);
                let n = (spp as f64).sqrt().round() as u32;
                if spp == 0 || spp > MAX_SPP || n * n != spp {
                    return Err(Error::setting(
                        "spp",
                        format!(
                            "must be a square number of samples (1, 4, 9, 16, ...) up to \
                             {MAX_SPP}, got {spp}"
                        ),
                    ));
                }
                PixelSampling::Uniform { n }
            }
        };
        sampling.validate()?;
        Ok(sampling)
    }
}
