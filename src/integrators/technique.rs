//! A technique with its settings: its name and typed settings. [`Settings`] is the parameter set a front
//! end fills (from a scene file's render settings, then its own options on top), every
//! entry optional; [`Technique::create`] picks the technique it names and builds that
//! technique's settings from it, with the defaults and the checks of that technique (as
//! pbrt-v4's `Integrator::Create` reads a parameter dictionary). Errors name the setting
//! ([`Error::Setting`]).

use crate::error::{Error, Result};
use crate::image::filter::Reconstruction;
use crate::integrators::illumination_network as net;
use crate::integrators::irradiance_cache::{self as ic, IcOptions};
use crate::integrators::path::{DEFAULT_MAX_DEPTH, MAX_DEPTH_LIMIT};
use crate::settings::{AntiAliasing, NetworkBuilder, Relight, Settings, TechniqueKind};
use crate::transport::passes::MAX_SPP;
pub use crate::transport::technique::MonteCarloSettings;
use crate::transport::{PixelSampling, DEFAULT_AA_DEPTH, DEFAULT_AA_THRESHOLD};
use std::path::PathBuf;

/// A technique with its settings, checked.
#[derive(Clone, Debug, PartialEq)]
pub enum Technique {
    Whitted(WhittedSettings),
    Path(MonteCarloSettings),
    Light(MonteCarloSettings),
    Bdpt(MonteCarloSettings),
    IrradianceCache(MonteCarloSettings, CacheSettings),
    Network(NetworkSettings),
}

/// Whitted's integrator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WhittedSettings {
    pub max_depth: u32,
    pub area_samples: u32,
    pub fresnel: bool,
    pub sampling: PixelSampling,
}

/// The irradiance cache's own settings.
#[derive(Clone, Debug, PartialEq)]
pub struct CacheSettings {
    pub options: IcOptions,
    /// Values are loaded from it if it exists, and the cache written to it; a file holding
    /// this view's whole overture is only read.
    pub file: Option<PathBuf>,
    /// Mark the first-level values the camera sees in the image (Ward's figure 5b).
    pub show_points: bool,
}

/// The illumination network's settings.
#[derive(Clone, Debug, PartialEq)]
pub struct NetworkSettings {
    /// Slopes, intercept step, patch size and jitter (the seed is the job's).
    pub params: net::NetworkParams,
    pub builder: NetworkBuilder,
    pub distribute: net::distribute::DistributeOptions,
    /// Loaded from it if it exists (no preprocess), else built and saved there.
    pub file: Option<PathBuf>,
    /// Direct light per pixel, only indirect light from the network.
    pub hybrid: bool,
    pub sampling: PixelSampling,
    pub max_depth: u32,
    /// Relighting the network in `file` (which must exist).
    pub relight: Option<Relight>,
}

impl Technique {
    /// The technique `settings` name (Whitted if none), with its settings: defaults where
    /// unset, every value checked. A setting the technique does not read is ignored here
    /// (see [`TechniqueKind::reads`]).
    pub fn create(settings: &Settings) -> Result<Technique> {
        let kind = settings.integrator.unwrap_or(TechniqueKind::Whitted);
        let max_depth = settings.max_depth.unwrap_or(DEFAULT_MAX_DEPTH);
        if max_depth > MAX_DEPTH_LIMIT {
            return Err(Error::setting(
                "max_depth",
                format!("must be at most {MAX_DEPTH_LIMIT}, got {max_depth}"),
            ));
        }
        Ok(match kind {
            TechniqueKind::Whitted => Technique::Whitted(WhittedSettings {
                max_depth: max_depth.max(1),
                area_samples: at_most(
                    "area_samples",
                    settings.area_samples.unwrap_or(16),
                    1 << 16,
                )?,
                fresnel: settings.fresnel.unwrap_or(false),
                sampling: pixel_sampling(settings)?,
            }),
            TechniqueKind::Path => Technique::Path(monte_carlo(settings, max_depth)?),
            TechniqueKind::Light => Technique::Light(monte_carlo(settings, max_depth)?),
            TechniqueKind::Bdpt => Technique::Bdpt(monte_carlo(settings, max_depth)?),
            TechniqueKind::IrradianceCache => {
                if settings.time_limit.is_some() {
                    return Err(Error::setting(
                        "time_limit",
                        "does not apply to the irradiance-cache integrator (its overture \
                         traces every sample first): give spp",
                    ));
                }
                let options = IcOptions {
                    bounces: settings.ab.unwrap_or(ic::DEFAULT_BOUNCES),
                    accuracy: settings.ic_accuracy.unwrap_or(ic::DEFAULT_ACCURACY),
                    samples: at_most(
                        "ic_samples",
                        settings.ic_samples.unwrap_or(ic::DEFAULT_SAMPLES),
                        1 << 20,
                    )?,
                    ar: settings.ar.unwrap_or(ic::DEFAULT_AR),
                    gradients: settings.ic_gradients.unwrap_or(ic::DEFAULT_GRADIENTS),
                    ..IcOptions::default()
                };
                options.validate()?;
                Technique::IrradianceCache(
                    monte_carlo(settings, max_depth)?,
                    CacheSettings {
                        options,
                        file: settings.cache_file.clone(),
                        show_points: settings.show_cache_points.unwrap_or(false),
                    },
                )
            }
            TechniqueKind::Network => Technique::Network(network(settings, max_depth)?),
        })
    }

    pub fn kind(&self) -> TechniqueKind {
        match self {
            Technique::Whitted(_) => TechniqueKind::Whitted,
            Technique::Path(_) => TechniqueKind::Path,
            Technique::Light(_) => TechniqueKind::Light,
            Technique::Bdpt(_) => TechniqueKind::Bdpt,
            Technique::IrradianceCache(..) => TechniqueKind::IrradianceCache,
            Technique::Network(_) => TechniqueKind::Network,
        }
    }

    /// The Monte Carlo settings, for the progressive techniques.
    pub fn monte_carlo(&self) -> Option<&MonteCarloSettings> {
        match self {
            Technique::Path(s) | Technique::Light(s) | Technique::Bdpt(s) => Some(s),
            Technique::IrradianceCache(s, _) => Some(s),
            _ => None,
        }
    }

    pub fn max_depth(&self) -> u32 {
        match self {
            Technique::Whitted(w) => w.max_depth,
            Technique::Network(n) => n.max_depth,
            other => other.monte_carlo().map_or(0, |m| m.max_depth),
        }
    }

    /// Whether a part of the image can be rendered alone, to the same pixels as the whole
    /// render: not for light paths, which splat onto every pixel.
    pub fn renders_parts(&self) -> bool {
        !matches!(self, Technique::Light(_) | Technique::Bdpt(_))
    }
}

/// `value` if it is at most `limit`: counts bound the work a job may ask for.
fn at_most(name: &str, value: u32, limit: u32) -> Result<u32> {
    if value > limit {
        return Err(Error::setting(
            name,
            format!("must be at most {limit}, got {value}"),
        ));
    }
    Ok(value)
}

/// The pixel sampling of Whitted and the network: uniform supersampling when `spp` is
/// given (a square) or `aa` asks for it, else adaptive.
fn pixel_sampling(s: &Settings) -> Result<PixelSampling> {
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
            if spp == 0 || n * n != spp {
                return Err(Error::setting(
                    "spp",
                    format!("must be a square number of samples (1, 4, 9, 16, ...), got {spp}"),
                ));
            }
            PixelSampling::Uniform { n }
        }
    };
    sampling.validate()?;
    Ok(sampling)
}

fn monte_carlo(s: &Settings, max_depth: u32) -> Result<MonteCarloSettings> {
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

fn network(s: &Settings, max_depth: u32) -> Result<NetworkSettings> {
    let step = s.intercept_step.unwrap_or(net::DEFAULT_STEP);
    let params = net::NetworkParams {
        slopes: s.slopes.unwrap_or(net::DEFAULT_SLOPES),
        step,
        patch_size: s.patch_size.unwrap_or(step),
        jitter: s.network_jitter.unwrap_or(1.0),
        seed: 0,
    };
    params.validate()?;
    let tolerance = s.tolerance.unwrap_or(net::DEFAULT_TOLERANCE);
    if !(tolerance > 0.0 && tolerance < 1.0) {
        return Err(Error::setting(
            "tolerance",
            format!("must be between 0 and 1 (exclusive), got {tolerance}"),
        ));
    }
    let light_scale = s.light_scale.unwrap_or(1.0);
    if !(light_scale.is_finite() && light_scale >= 0.0) {
        return Err(Error::setting(
            "light_scale",
            format!("must be a non-negative number, got {light_scale}"),
        ));
    }
    if s.relight.is_some() && s.network_file.is_none() {
        return Err(Error::setting(
            "network_file",
            "is needed to relight: a network saved by an earlier render",
        ));
    }
    Ok(NetworkSettings {
        params,
        builder: s.network_builder.unwrap_or(NetworkBuilder::Scan),
        distribute: net::distribute::DistributeOptions {
            tolerance,
            light_scale,
            order: s.network_order.unwrap_or_default(),
            ..Default::default()
        },
        file: s.network_file.clone(),
        hybrid: s.network_hybrid.unwrap_or(false),
        sampling: pixel_sampling(s)?,
        max_depth,
        relight: s.relight.clone(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::filter::Filter;

    #[test]
    fn the_factory_gives_each_technique_its_defaults() {
        let t = Technique::create(&Settings::default()).unwrap();
        assert_eq!(
            t,
            Technique::Whitted(WhittedSettings {
                max_depth: 8,
                area_samples: 16,
                fresnel: false,
                sampling: PixelSampling::default(),
            })
        );
        let path = Settings {
            integrator: Some(TechniqueKind::Path),
            ..Settings::default()
        };
        let Technique::Path(mc) = Technique::create(&path).unwrap() else {
            panic!("not a path tracer");
        };
        assert_eq!(
            (mc.spp, mc.max_depth, mc.filter),
            (16, 8, Filter::default())
        );
    }

    #[test]
    fn bad_settings_are_named() {
        let cases: Vec<(Settings, &str)> = vec![
            (
                Settings {
                    max_depth: Some(5000),
                    ..Settings::default()
                },
                "max_depth",
            ),
            (
                Settings {
                    spp: Some(5),
                    ..Settings::default()
                },
                "spp",
            ),
            (
                Settings {
                    integrator: Some(TechniqueKind::Path),
                    time_limit: Some(f64::NAN),
                    ..Settings::default()
                },
                "time_limit",
            ),
            (
                Settings {
                    integrator: Some(TechniqueKind::IrradianceCache),
                    ic_accuracy: Some(-1.0),
                    ..Settings::default()
                },
                "ic_accuracy",
            ),
            (
                Settings {
                    integrator: Some(TechniqueKind::Network),
                    tolerance: Some(2.0),
                    ..Settings::default()
                },
                "tolerance",
            ),
        ];
        for (settings, name) in cases {
            match Technique::create(&settings) {
                Err(Error::Setting { name: n, .. }) => assert_eq!(n, name),
                other => panic!("{name}: {other:?}"),
            }
        }
    }

    #[test]
    fn overlays_replace_only_what_they_give() {
        let scene = Settings {
            spp: Some(64),
            max_depth: Some(3),
            ..Settings::default()
        };
        let flags = Settings {
            spp: Some(4),
            ..Settings::default()
        };
        let s = scene.overlaid(&flags);
        assert_eq!((s.spp, s.max_depth), (Some(4), Some(3)));
        assert_eq!(s.given(), vec!["spp", "max_depth"]);
    }

    #[test]
    fn every_technique_reads_its_own_settings_only() {
        assert!(TechniqueKind::Whitted.reads("area_samples"));
        assert!(!TechniqueKind::Path.reads("area_samples"));
        assert!(!TechniqueKind::IrradianceCache.reads("time_limit"));
        assert!(TechniqueKind::Network.reads("network_file"));
        assert!(!TechniqueKind::Bdpt.reads("cache_file"));
        for k in TechniqueKind::ALL {
            assert_eq!(TechniqueKind::from_name(k.name()), Some(k));
        }
    }
}
