//! The techniques, registered in one list. Each technique's file says what it is and which
//! settings it reads ([`TechniqueInfo`]), builds and checks its typed settings from the
//! parameter set, gives their settings key, and makes its lifecycle; this file lists them
//! ([`TECHNIQUES`]) and dispatches to them. [`Settings`] is the parameter set a front end
//! fills (from a scene file's render settings, then its own options on top), every entry
//! optional; [`Technique::create`] picks the technique it names and builds that technique's
//! settings from it (as pbrt-v4's `Integrator::Create` reads a parameter dictionary). Errors
//! name the setting ([`Error::Setting`]).
//!
//! Adding a technique: its file (with its `TECHNIQUE` info, settings, `key` and
//! `lifecycle`), its name in `crate::settings::TechniqueKind`, and a variant here with its
//! line in [`TECHNIQUES`] and in each match below (the compiler points at them). The command
//! line's options, the scene format's keys and the pbrt reader's `Integrator` types are
//! checked against [`TECHNIQUES`] by tests.

use crate::error::{Error, Result};
use crate::integrators::path::{DEFAULT_MAX_DEPTH, MAX_DEPTH_LIMIT};
use crate::integrators::{
    bdpt, illumination_network, irradiance_cache, light, path, sppm, vcm, whitted,
};
use crate::scene::Scene;
use crate::settings::{Settings, TechniqueKind};
use crate::transport::technique::Lifecycle;

pub use crate::integrators::illumination_network::technique::NetworkSettings;
pub use crate::integrators::irradiance_cache::technique::CacheSettings;
pub use crate::integrators::sppm::SppmSettings;
pub use crate::integrators::vcm::VcmSettings;
pub use crate::integrators::whitted::WhittedSettings;
pub use crate::transport::settings::{MonteCarloSettings, Setting, TechniqueInfo};

/// Every technique, in the order of [`TechniqueKind::ALL`].
pub const TECHNIQUES: [&TechniqueInfo; 8] = [
    &whitted::TECHNIQUE,
    &path::TECHNIQUE,
    &light::TECHNIQUE,
    &bdpt::TECHNIQUE,
    &irradiance_cache::technique::TECHNIQUE,
    &illumination_network::technique::TECHNIQUE,
    &sppm::TECHNIQUE,
    &vcm::TECHNIQUE,
];

/// What the technique `kind` says of itself.
pub fn info(kind: TechniqueKind) -> &'static TechniqueInfo {
    match kind {
        TechniqueKind::Whitted => &whitted::TECHNIQUE,
        TechniqueKind::Path => &path::TECHNIQUE,
        TechniqueKind::Light => &light::TECHNIQUE,
        TechniqueKind::Bdpt => &bdpt::TECHNIQUE,
        TechniqueKind::IrradianceCache => &irradiance_cache::technique::TECHNIQUE,
        TechniqueKind::Network => &illumination_network::technique::TECHNIQUE,
        TechniqueKind::Sppm => &sppm::TECHNIQUE,
        TechniqueKind::Vcm => &vcm::TECHNIQUE,
    }
}

/// A technique with its settings, checked.
#[derive(Clone, Debug, PartialEq)]
pub enum Technique {
    Whitted(WhittedSettings),
    Path(MonteCarloSettings),
    Light(MonteCarloSettings),
    Bdpt(MonteCarloSettings),
    IrradianceCache(MonteCarloSettings, CacheSettings),
    Network(NetworkSettings),
    Sppm(SppmSettings),
    Vcm(MonteCarloSettings, VcmSettings),
}

impl Technique {
    /// The technique `settings` name (Whitted if none), with its settings: defaults where
    /// unset, every value checked. A setting the technique does not read is ignored here
    /// (see [`TechniqueInfo::reads`]).
    pub fn create(settings: &Settings) -> Result<Technique> {
        let kind = settings.integrator.unwrap_or(TechniqueKind::Whitted);
        let max_depth = settings.max_depth.unwrap_or(DEFAULT_MAX_DEPTH);
        if max_depth > MAX_DEPTH_LIMIT {
            return Err(Error::setting(
                "max_depth",
                format!("must be at most {MAX_DEPTH_LIMIT}, got {max_depth}"),
            ));
        }
        let s = settings;
        let monte_carlo = || MonteCarloSettings::from_settings(s, max_depth);
        Ok(match kind {
            TechniqueKind::Whitted => {
                Technique::Whitted(WhittedSettings::from_settings(s, max_depth)?)
            }
            TechniqueKind::Path => Technique::Path(monte_carlo()?),
            TechniqueKind::Light => Technique::Light(monte_carlo()?),
            TechniqueKind::Bdpt => Technique::Bdpt(monte_carlo()?),
            TechniqueKind::IrradianceCache => {
                let cache = CacheSettings::from_settings(s)?;
                Technique::IrradianceCache(monte_carlo()?, cache)
            }
            TechniqueKind::Network => {
                Technique::Network(NetworkSettings::from_settings(s, max_depth)?)
            }
            TechniqueKind::Sppm => Technique::Sppm(SppmSettings::from_settings(s, max_depth)?),
            TechniqueKind::Vcm => Technique::Vcm(monte_carlo()?, VcmSettings::from_settings(s)?),
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
            Technique::Sppm(_) => TechniqueKind::Sppm,
            Technique::Vcm(..) => TechniqueKind::Vcm,
        }
    }

    /// What the technique says of itself.
    pub fn info(&self) -> &'static TechniqueInfo {
        info(self.kind())
    }

    /// The Monte Carlo settings, for the progressive techniques.
    pub fn monte_carlo(&self) -> Option<&MonteCarloSettings> {
        match self {
            Technique::Path(s) | Technique::Light(s) | Technique::Bdpt(s) => Some(s),
            Technique::IrradianceCache(s, _) | Technique::Vcm(s, _) => Some(s),
            Technique::Whitted(_) | Technique::Network(_) | Technique::Sppm(_) => None,
        }
    }

    /// The passes a progressive render takes (samples per pixel; SPPM's iterations): what
    /// its film counts, a checkpoint resumes and a live view shows converging. `None` for
    /// the techniques that render in one pass.
    pub fn passes(&self) -> Option<u32> {
        match self {
            Technique::Sppm(s) => Some(s.iterations),
            t => t.monte_carlo().map(|m| m.spp),
        }
    }

    pub fn max_depth(&self) -> u32 {
        match self {
            Technique::Whitted(w) => w.max_depth,
            Technique::Network(n) => n.max_depth,
            Technique::Path(m) | Technique::Light(m) | Technique::Bdpt(m) => m.max_depth,
            Technique::IrradianceCache(m, _) => m.max_depth,
            Technique::Sppm(s) => s.max_depth,
            Technique::Vcm(m, _) => m.max_depth,
        }
    }

    /// Whether its render takes one sample a pass: each sample index is an iteration over
    /// the whole image (vertex connection and merging). A film to resume must say so
    /// ([`Film::with_one_sample_passes`](crate::Film::with_one_sample_passes)).
    pub fn one_sample_passes(&self) -> bool {
        matches!(self, Technique::Vcm(..))
    }

    /// Whether a part of the image can be rendered alone, to the same pixels as the whole
    /// render: not for light paths, which splat onto every pixel.
    pub fn renders_parts(&self) -> bool {
        self.info().renders_parts
    }

    /// The technique's own settings that change pixels, for a job's settings key.
    pub(crate) fn key(&self) -> String {
        match self {
            Technique::Whitted(w) => w.key(),
            Technique::Path(m) | Technique::Light(m) | Technique::Bdpt(m) => m.key(),
            Technique::IrradianceCache(m, c) => m.key() + &c.key(),
            Technique::Network(n) => n.key(),
            Technique::Sppm(s) => s.key(),
            Technique::Vcm(m, v) => m.key() + &v.key(),
        }
    }

    /// What a part of the image needs besides the technique's `renders_parts`: the
    /// preparation it reads, made for the whole image first.
    pub(crate) fn check_part(&self) -> Result<()> {
        match self {
            Technique::IrradianceCache(_, c) => c.check_part(),
            Technique::Network(n) => n.check_part(),
            Technique::Whitted(_)
            | Technique::Path(_)
            | Technique::Light(_)
            | Technique::Bdpt(_)
            | Technique::Sppm(_)
            | Technique::Vcm(..) => Ok(()),
        }
    }

    /// The technique for `scene`, ready to prepare and render (pbrt's `Integrator::Create`).
    pub(crate) fn lifecycle(&self, scene: &Scene) -> Result<Box<dyn Lifecycle>> {
        refuse_media(scene, self.info())?;
        if self.monte_carlo().is_some_and(|m| m.spectral) {
            refuse_spectral(scene, self.info())?;
        }
        Ok(match self {
            Technique::Whitted(w) => w.lifecycle(),
            Technique::Path(mc) => path::lifecycle(mc)?,
            Technique::Light(mc) => light::lifecycle(mc, scene)?,
            Technique::Bdpt(mc) => bdpt::lifecycle(mc, scene)?,
            Technique::IrradianceCache(mc, cache) => Box::new(
                irradiance_cache::technique::CacheTechnique::new(*mc, cache.clone()),
            ),
            Technique::Network(n) => Box::new(
                illumination_network::technique::NetworkTechnique::new(n.clone(), scene),
            ),
            Technique::Sppm(s) => s.lifecycle(scene)?,
            Technique::Vcm(mc, v) => vcm::lifecycle(mc, v, scene)?,
        })
    }
}

/// Refuses a scene with participating media for a technique that does not render them.
pub(crate) fn refuse_media(scene: &Scene, info: &TechniqueInfo) -> Result<()> {
    if scene.media.is_empty() || info.media {
        return Ok(());
    }
    let renders: Vec<&str> = TECHNIQUES
        .iter()
        .filter(|t| t.media)
        .map(|t| t.kind.name())
        .collect();
    Err(Error::input(
        &scene.source,
        format!(
            "the scene has participating media ({}), which the {} integrator does not \
             render: render it with {}",
            scene.media.len(),
            info.kind.name(),
            listed(&renders, "or")
        ),
    ))
}

/// Refuses spectral mode for a technique that does not render it (one that does not read
/// the `spectral` setting), and a scene with what spectral mode does not render.
fn refuse_spectral(scene: &Scene, info: &TechniqueInfo) -> Result<()> {
    if !info.reads("spectral") {
        let renders: Vec<&str> = TECHNIQUES
            .iter()
            .filter(|t| t.reads("spectral"))
            .map(|t| t.kind.name())
            .collect();
        return Err(Error::setting(
            "spectral",
            format!(
                "does not apply to the {} integrator: spectral mode is the {} integrators'",
                info.kind.name(),
                listed(&renders, "and")
            ),
        ));
    }
    crate::transport::spectral::check_scene(scene)
}

/// "a", "a or b", "a, b or c" (with `conjunction` "or").
fn listed(names: &[&str], conjunction: &str) -> String {
    match names.split_last() {
        Some((last, [])) => last.to_string(),
        Some((last, rest)) => format!("{} {conjunction} {last}", rest.join(", ")),
        None => String::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::filter::Filter;
    use crate::transport::PixelSampling;

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
        assert!(info(TechniqueKind::Whitted).reads("area_samples"));
        assert!(!info(TechniqueKind::Path).reads("area_samples"));
        assert!(!info(TechniqueKind::IrradianceCache).reads("time_limit"));
        assert!(info(TechniqueKind::Network).reads("network_file"));
        assert!(!info(TechniqueKind::Bdpt).reads("cache_file"));
        for k in TechniqueKind::ALL {
            assert_eq!(TechniqueKind::from_name(k.name()), Some(k));
        }
    }

    /// The list holds every technique once, in the order of the names, and what each
    /// declares is a setting of the parameter set, read by some technique, each once.
    #[test]
    fn the_list_covers_every_technique_and_setting() {
        let kinds: Vec<TechniqueKind> = TECHNIQUES.iter().map(|t| t.kind).collect();
        assert_eq!(kinds, TechniqueKind::ALL.to_vec());
        for k in TechniqueKind::ALL {
            assert_eq!(info(k).kind, k);
            let names: Vec<&str> = info(k).all_settings().map(|s| s.name).collect();
            let mut unique = names.clone();
            unique.sort();
            unique.dedup();
            assert_eq!(unique.len(), names.len(), "{k}: {names:?}");
            for n in &names {
                assert!(Settings::NAMES.contains(n), "{k} declares {n}");
            }
            let progressive = Technique::create(&Settings {
                integrator: Some(k),
                // A square: Whitted and the network take it as uniform supersampling.
                spp: Some(4),
                network_file: Some("n.bin".into()),
                ..Settings::default()
            })
            .unwrap()
            .passes()
            .is_some();
            assert_eq!(progressive, info(k).progressive, "{k}");
        }
        for n in Settings::NAMES {
            assert!(
                TECHNIQUES.iter().any(|t| t.reads(n)),
                "no technique reads {n}"
            );
        }
    }
}
