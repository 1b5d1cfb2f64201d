//! What a technique says of itself: its name, what it is, the settings it reads (each with
//! its scene-file key, a valid value and its default) and how a front end may use it. Each
//! technique's file declares its [`TechniqueInfo`]; `crate::integrators::technique` lists
//! them, and the command line, the scene readers and messages go by that list (a test fails
//! when one of them misses a setting). The groups of settings several techniques share, and
//! the Monte Carlo settings they build, are here.

use crate::error::{Error, Result};
use crate::image::filter::{Filter, Reconstruction};
use crate::settings::{Settings, TechniqueKind};
use crate::transport::passes::MAX_SPP;

/// A technique, as it describes itself.
#[derive(Debug)]
pub struct TechniqueInfo {
    pub kind: TechniqueKind,
    /// One sentence for people (the command line's help).
    pub summary: &'static str,
    /// The settings it reads, in groups; a front end refuses the others.
    pub settings: &'static [&'static [Setting]],
    /// The pbrt-v4 `Integrator` types the pbrt reader renders with it.
    pub pbrt: &'static [&'static str],
    /// Whether it renders in passes over the whole image (Monte Carlo sample passes, SPPM's
    /// iterations), and so takes written-out intermediate images, checkpoints and resume.
    pub progressive: bool,
    /// Whether a part of the image can be rendered alone, to the same pixels as the whole
    /// render (not for light paths, which splat onto every pixel).
    pub renders_parts: bool,
    /// Whether it follows a moving scene through the shutter interval (motion blur); one
    /// that keeps values per point or patch renders the scene at shutter open, with a
    /// warning.
    pub follows_time: bool,
    /// Whether it renders participating media; one that does not refuses a scene with a
    /// medium.
    pub media: bool,
}

impl TechniqueInfo {
    /// Every setting it reads.
    pub fn all_settings(&self) -> impl Iterator<Item = &'static Setting> {
        self.settings.iter().flat_map(|g| g.iter())
    }

    /// Whether it reads the setting of [`Settings`] named `name`.
    pub fn reads(&self, name: &str) -> bool {
        self.all_settings().any(|s| s.name == name)
    }
}

/// One setting of [`Settings`] a technique reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Setting {
    /// Its field of [`Settings`], as messages name it (`ic_accuracy`). The command line's
    /// option is its name with dashes (`--ic-accuracy`).
    pub name: &'static str,
    /// Its table and key in a scene file (`render.irradiance-cache`, `accuracy`); `None`
    /// for a setting only a command gives.
    pub scene_key: Option<(&'static str, &'static str)>,
    /// A valid value, as TOML text.
    pub example: &'static str,
    /// What it sets, and its default.
    pub doc: &'static str,
}

/// Read by every technique.
pub const COMMON: &[Setting] = &[
    Setting {
        name: "integrator",
        scene_key: Some(("render", "integrator")),
        example: "\"path\"",
        doc: "The technique (default: Whitted's).",
    },
    Setting {
        name: "spp",
        scene_key: Some(("render", "spp")),
        example: "16",
        doc: "Samples per pixel (Monte Carlo: default 16; Whitted and the network: a square \
              number selects uniform supersampling).",
    },
    Setting {
        name: "max_depth",
        scene_key: Some(("render", "max_depth")),
        example: "5",
        doc: "Ray-tree depth (Whitted) or bounces (Monte Carlo; 1 is direct light only). \
              Default 8, at most 1024.",
    },
];

/// The pixel filter of the Monte Carlo techniques.
pub const FILTER: Setting = Setting {
    name: "filter",
    scene_key: Some(("render", "filter")),
    example: "{ type = \"box\", radius = 0.5 }",
    doc: "The pixel reconstruction filter (default pbrt's Gaussian: radius 1.5, sigma 0.5).",
};

/// Read by the progressive Monte Carlo techniques.
pub const MONTE_CARLO: &[Setting] = &[
    Setting {
        name: "time_limit",
        scene_key: Some(("render", "time_limit")),
        example: "30.0",
        doc: "Render whole passes until this many seconds have passed (spp, if given, still \
              caps the samples).",
    },
    Setting {
        name: "max_component_value",
        scene_key: Some(("render", "max_component_value")),
        example: "10.0",
        doc: "Scale every sample down so that no channel exceeds this value (pbrt-v4's \
              maxcomponentvalue): fewer fireflies in previews, at the cost of bias (default: \
              no clamping; the outputs' metadata records it).",
    },
    FILTER,
];

/// Adaptive sampling: read by the techniques whose pixels are estimated from their own
/// samples alone (the path tracer).
pub const ADAPTIVE: &[Setting] = &[
    Setting {
        name: "adaptive_threshold",
        scene_key: Some(("render", "adaptive_threshold")),
        example: "0.01",
        doc: "Stop sampling a pixel once its estimated error is below this (Cycles' noise \
              threshold; 0.01 is a good final image, 0.1 a preview). The render ends when \
              every pixel has, or at spp (default 4096 with a threshold). Off by default.",
    },
    Setting {
        name: "adaptive_min_samples",
        scene_key: Some(("render", "adaptive_min_samples")),
        example: "32",
        doc: "Samples every pixel takes before adaptive sampling may stop it (default: \
              16 / threshold^0.3, as Cycles, at most spp).",
    },
];

/// Path guiding: read by the path tracer.
pub const GUIDING: &[Setting] = &[Setting {
    name: "guiding",
    scene_key: Some(("render", "guiding")),
    example: "true",
    doc: "Path guiding: learn where light arrives from during the first half of the samples \
          and draw directions from it as well as from the BSDF (surfaces only; off by \
          default).",
}];

/// Spectral mode: read by the path tracer.
pub const SPECTRAL: &[Setting] = &[Setting {
    name: "spectral",
    scene_key: Some(("render", "spectral")),
    example: "true",
    doc: "Spectral mode: carry light at three sampled wavelengths instead of red, green and \
          blue, so named glasses disperse and named metals reflect by their measured index \
          (surfaces only; off by default).",
}];

/// Samples per pixel with an adaptive threshold and no sample count or time limit: the
/// most a pixel that never converges takes (Cycles' default).
pub const ADAPTIVE_DEFAULT_SPP: u32 = 4096;

/// Adaptive sampling: which pixels go on taking samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveSampling {
    /// A pixel stops when its error estimate falls below this.
    pub threshold: f32,
    /// Samples every pixel takes first.
    pub min_samples: u32,
}

impl AdaptiveSampling {
    /// Cycles' automatic minimum for a threshold: 16 / threshold^0.3, rounded up.
    pub fn default_min_samples(threshold: f32) -> u32 {
        (16.0 / threshold.powf(0.3))
            .ceil()
            .clamp(1.0, MAX_SPP as f32) as u32
    }
}

/// The settings of the progressive Monte Carlo techniques (and the irradiance cache's final
/// render).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MonteCarloSettings {
    pub max_depth: u32,
    /// Samples per pixel; with a time limit, the most that will be taken.
    pub spp: u32,
    pub time_limit: Option<f64>,
    pub filter: Filter,
    /// How camera samples become pixels: splatted through the filter (the default), or
    /// drawn from it so that each pixel depends on its own samples alone.
    pub reconstruction: Reconstruction,
    /// Adaptive sampling, if on (its pixels then take their samples from the filter).
    pub adaptive: Option<AdaptiveSampling>,
    /// Samples (and splats) scaled down so that no channel exceeds this.
    pub max_component_value: Option<f32>,
    /// Path guiding (the path tracer).
    pub guiding: bool,
    /// Spectral mode (the path tracer): light at sampled wavelengths, not RGB.
    pub spectral: bool,
}

impl MonteCarloSettings {
    /// From the parameter set, with the defaults, every value checked.
    pub(crate) fn from_settings(s: &Settings, max_depth: u32) -> Result<MonteCarloSettings> {
        // With a time limit only a given spp caps the samples.
        let spp = s.spp.unwrap_or(if s.time_limit.is_some() {
            MAX_SPP
        } else if s.adaptive_threshold.is_some() {
            ADAPTIVE_DEFAULT_SPP
        } else {
            16
        });
        if spp == 0 || spp > MAX_SPP {
            return Err(Error::setting(
                "spp",
                format!("must be between 1 and {MAX_SPP}, got {spp}"),
            ));
        }
        if let Some(t) = s.time_limit {
            if !(t.is_finite() && t > 0.0) {
                return Err(Error::setting(
                    "time_limit",
                    format!("must be a positive number of seconds, got {t}"),
                ));
            }
        }
        let filter = s.filter.unwrap_or_default();
        filter
            .validate()
            .map_err(|e| Error::setting("filter", format!("is invalid: {e}")))?;
        if let Some(m) = s.max_component_value {
            if !(m.is_finite() && m > 0.0) {
                return Err(Error::setting(
                    "max_component_value",
                    format!("must be a positive number, got {m}"),
                ));
            }
        }
        let adaptive = match (s.adaptive_threshold, s.adaptive_min_samples) {
            (None, None) => None,
            (None, Some(_)) => {
                return Err(Error::setting(
                    "adaptive_min_samples",
                    "needs an adaptive threshold (adaptive sampling is off without one)",
                ))
            }
            (Some(threshold), min) => {
                if !(threshold.is_finite() && threshold > 0.0 && threshold < 1.0) {
                    return Err(Error::setting(
                        "adaptive_threshold",
                        format!("must be between 0 and 1 (exclusive), got {threshold}"),
                    ));
                }
                let min_samples = match min {
                    Some(0) => {
                        return Err(Error::setting(
                            "adaptive_min_samples",
                            "must be at least 1, got 0",
                        ))
                    }
                    Some(m) if m > spp => {
                        return Err(Error::setting(
                            "adaptive_min_samples",
                            format!("must be at most spp ({spp}), got {m}"),
                        ))
                    }
                    Some(m) => m,
                    None => AdaptiveSampling::default_min_samples(threshold).min(spp),
                };
                Some(AdaptiveSampling {
                    threshold,
                    min_samples,
                })
            }
        };
        Ok(MonteCarloSettings {
            max_depth,
            spp,
            time_limit: s.time_limit,
            filter,
            // A pixel that stops on its own error must depend on its own samples alone.
            reconstruction: if adaptive.is_some() {
                Reconstruction::Importance
            } else {
                Reconstruction::Splat
            },
            adaptive,
            max_component_value: s.max_component_value,
            guiding: s.guiding.unwrap_or(false),
            spectral: s.spectral.unwrap_or(false),
        })
    }

    /// What of them changes pixels, for a job's settings key.
    pub(crate) fn key(&self) -> String {
        let mut key = format!(" spp={} filter={}", self.spp, self.filter);
        if let Some(a) = self.adaptive {
            key += &format!(
                " adaptive_threshold={} adaptive_min_samples={}",
                a.threshold, a.min_samples
            );
        }
        if let Some(m) = self.max_component_value {
            key += &format!(" max_component_value={m}");
        }
        if self.guiding {
            key += " guiding=true";
        }
        if self.spectral {
            key += " spectral=true";
        }
        key
    }
}

/// An error for the setting that lets pixels take different numbers of samples (a time
/// limit, adaptive sampling) or depend on the whole image (a guide learned from every
/// pixel), if one is on: a part of an image must take exactly the samples the whole
/// render gives its pixels.
pub(crate) fn refuse_for_parts(
    time_limit: Option<f64>,
    adaptive: Option<AdaptiveSampling>,
    guiding: bool,
) -> Result<()> {
    let refused = [
        (
            time_limit.is_some(),
            "time_limit",
            "every part must take the same samples",
        ),
        (
            adaptive.is_some(),
            "adaptive_threshold",
            "where a pixel stops depends on its neighbours",
        ),
        (
            guiding,
            "guiding",
            "the guide is learned from the whole image",
        ),
    ];
    match refused.into_iter().find(|r| r.0) {
        Some((_, name, why)) => Err(Error::setting(
            name,
            format!("cannot be used for a part of an image: {why}"),
        )),
        None => Ok(()),
    }
}

/// `value` if it is at most `limit`: counts bound the work a job may ask for.
pub(crate) fn at_most(name: &str, value: u32, limit: u32) -> Result<u32> {
    if value > limit {
        return Err(Error::setting(
            name,
            format!("must be at most {limit}, got {value}"),
        ));
    }
    Ok(value)
}
