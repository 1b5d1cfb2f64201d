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
    /// Whether it renders progressive Monte Carlo passes (and so takes a time limit,
    /// written-out intermediate images, checkpoints and resume).
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
    FILTER,
];

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
}

impl MonteCarloSettings {
    /// From the parameter set, with the defaults, every value checked.
    pub(crate) fn from_settings(s: &Settings, max_depth: u32) -> Result<MonteCarloSettings> {
        // With a time limit only a given spp caps the samples.
        let spp = s
            .spp
            .unwrap_or(if s.time_limit.is_some() { MAX_SPP } else { 16 });
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
        Ok(MonteCarloSettings {
            max_depth,
            spp,
            time_limit: s.time_limit,
            filter,
            reconstruction: Reconstruction::Splat,
        })
    }

    /// What of them changes pixels, for a job's settings key.
    pub(crate) fn key(&self) -> String {
        format!(" spp={} filter={}", self.spp, self.filter)
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
