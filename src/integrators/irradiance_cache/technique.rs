//! The irradiance cache in the technique lifecycle: its preparation loads the cache file (if
//! any), runs the overture for the job's view and saves the cache; a file that already holds
//! this view's whole overture (precomputed for render jobs) is only read, so that every part
//! of the image reads the values the whole render would.

use super::{file, IcOptions, IrradianceCache};
use crate::control::Control;
use crate::error::{Error, Result};
use crate::image::Image;
use crate::math::Rgb;
use crate::scene::Scene;
use crate::settings::{Settings, TechniqueKind};
use crate::transport::settings::{
    at_most, MonteCarloSettings, Setting, TechniqueInfo, COMMON, FILTER,
};
use crate::transport::technique::{Lifecycle, Tiles};
use crate::transport::Context;
use crate::transport::ProgressiveOptions;
use crate::transport::View;
use std::path::PathBuf;

/// The irradiance cache, as the technique list shows it.
pub(crate) const TECHNIQUE: TechniqueInfo = TechniqueInfo {
    kind: TechniqueKind::IrradianceCache,
    summary: "Ward's irradiance caching: direct and specular light as in the path tracer, \
              indirect diffuse light from cached irradiance values.",
    // The overture traces the final render's samples first: no time limit.
    settings: &[
        COMMON,
        &[FILTER],
        &[
            Setting {
                name: "ab",
                scene_key: Some(("render.irradiance-cache", "ab")),
                example: "2",
                doc: "Diffuse bounces, each with its own value set (default 4).",
            },
            Setting {
                name: "ic_accuracy",
                scene_key: Some(("render.irradiance-cache", "accuracy")),
                example: "0.2",
                doc: "Accuracy a: values are used where the estimated error is below a \
                      (default 0.15).",
            },
            Setting {
                name: "ic_samples",
                scene_key: Some(("render.irradiance-cache", "samples")),
                example: "256",
                doc: "Rays per primary value at the first bounce, halved per bounce \
                      (default 512).",
            },
            Setting {
                name: "ic_gradients",
                scene_key: Some(("render.irradiance-cache", "gradients")),
                example: "false",
                doc: "Ward & Heckbert's irradiance gradients (default true).",
            },
            Setting {
                name: "ar",
                scene_key: Some(("render.irradiance-cache", "ar")),
                example: "32.0",
                doc: "A value's R is at least the scene's size / ar (default 64).",
            },
            Setting {
                name: "cache_file",
                scene_key: Some(("render.irradiance-cache", "cache_file")),
                example: "\"cache.irr\"",
                doc: "Values are loaded from this file if it exists, and the cache written \
                      to it; a file holding this view's overture is only read.",
            },
            Setting {
                name: "show_cache_points",
                scene_key: None,
                example: "true",
                doc: "Mark the pixels of the first-bounce values the camera sees.",
            },
        ],
    ],
    pbrt: &[],
    progressive: true,
    renders_parts: true,
    follows_time: false,
    media: false,
};

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

impl CacheSettings {
    /// From the parameter set, with the defaults, every value checked.
    pub(crate) fn from_settings(s: &Settings) -> Result<CacheSettings> {
        if s.time_limit.is_some() {
            return Err(Error::setting(
                "time_limit",
                "does not apply to the irradiance-cache integrator (its overture traces \
                 every sample first): give spp",
            ));
        }
        let options = IcOptions {
            bounces: s.ab.unwrap_or(super::DEFAULT_BOUNCES),
            accuracy: s.ic_accuracy.unwrap_or(super::DEFAULT_ACCURACY),
            samples: at_most(
                "ic_samples",
                s.ic_samples.unwrap_or(super::DEFAULT_SAMPLES),
                1 << 20,
            )?,
            ar: s.ar.unwrap_or(super::DEFAULT_AR),
            gradients: s.ic_gradients.unwrap_or(super::DEFAULT_GRADIENTS),
            ..IcOptions::default()
        };
        options.validate()?;
        Ok(CacheSettings {
            options,
            file: s.cache_file.clone(),
            show_points: s.show_cache_points.unwrap_or(false),
        })
    }

    /// What of them changes pixels, for a job's settings key.
    pub(crate) fn key(&self) -> String {
        let o = &self.options;
        format!(
            " ab={} ic_accuracy={} ic_samples={} ar={} ic_gradients={}",
            o.bounces, o.accuracy, o.samples, o.ar, o.gradients
        )
    }

    /// A part of the image reads a cache precomputed for the whole view.
    pub(crate) fn check_part(&self) -> Result<()> {
        if self.show_points {
            return Err(Error::setting(
                "show_cache_points",
                "cannot be used for a part of the image: the points are marked on the whole \
                 view's cache",
            ));
        }
        if self.file.is_none() {
            return Err(Error::setting(
                "cache_file",
                "is needed to render a part of the image with the irradiance cache: \
                 precompute one for this view first (`raylink precompute`, \
                 `Renderer::precompute`)",
            ));
        }
        Ok(())
    }
}

pub(crate) struct CacheTechnique {
    render: MonteCarloSettings,
    settings: CacheSettings,
    built: Option<IrradianceCache>,
    report: Vec<String>,
}

impl CacheTechnique {
    pub(crate) fn new(render: MonteCarloSettings, settings: CacheSettings) -> CacheTechnique {
        CacheTechnique {
            render,
            settings,
            built: None,
            report: Vec::new(),
        }
    }

    /// The cache for the job's view: loaded, completed by the overture, saved.
    fn build(&mut self, ctx: &Context, view: &View, control: &Control) -> Result<IrradianceCache> {
        let options = self.settings.options;
        let render = view.progressive(&self.render);
        let file = self.settings.file.as_deref();
        let key = match file {
            Some(_) => view_key(ctx.scene, &render, view.accel),
            None => 0,
        };
        let (loaded, frozen) = match file {
            // A new view starts from the values the last one computed.
            _ if self.built.is_some() => (self.built.take().map(|b| b.cache().clone()), false),
            Some(f) if f.exists() => {
                let (cache, saved) = file::load_with_view(f, ctx.scene, &options)?;
                (Some(cache), saved == Some(key))
            }
            _ => (None, false),
        };
        if let (Some(f), false, Some(_)) = (file, frozen, view.region) {
            return Err(Error::input(
                f,
                "missing or not precomputed for this view (scene, size, samples, filter, \
                 seed): precompute the cache with the render's settings first",
            ));
        }
        let start = std::time::Instant::now();
        let integrator = match loaded {
            Some(cache) if frozen => IrradianceCache::frozen(ctx, &render, options, cache)?,
            loaded => IrradianceCache::build(ctx, &render, options, loaded, control)?,
        };
        let stats = &integrator.stats;
        let line = format!(
            "irradiance cache: {} values ({} loaded, {} computed by the overture in {:.2} s, \
             {:.0} rays each); per bounce level: {:?}",
            integrator.cache().len(),
            stats.loaded,
            stats.overture_primaries,
            start.elapsed().as_secs_f64(),
            stats.overture_rays as f64 / stats.overture_primaries.max(1) as f64,
            integrator
                .cache()
                .levels
                .iter()
                .map(|l| l.len())
                .collect::<Vec<_>>()
        );
        self.report = vec![line];
        match file {
            Some(f) if frozen => control.note(&format!(
                "irradiance cache: {} values from {}, which holds this view's overture (read \
                 only; 0 computed)",
                integrator.cache().len(),
                f.display()
            )),
            Some(f) => file::save_for_view(f, integrator.cache(), ctx.scene, &options, key)?,
            None => {}
        }
        Ok(integrator)
    }
}

impl Lifecycle for CacheTechnique {
    fn prepares(&self) -> bool {
        true
    }

    fn prepare(&mut self, ctx: &Context, view: &View, control: &Control) -> Result<()> {
        self.built = Some(self.build(ctx, view, control)?);
        Ok(())
    }

    fn view_dependent(&self) -> bool {
        true
    }

    fn tiles(&self) -> Tiles<'_> {
        Tiles::Samples(
            self.built.as_ref().expect("the renderer prepares first"),
            self.render,
        )
    }

    fn precompute(&mut self, ctx: &Context, view: &View, control: &Control) -> Result<()> {
        if self.settings.file.is_none() {
            return Err(Error::setting(
                "cache_file",
                "is where a precomputed irradiance cache goes: give one",
            ));
        }
        self.build(ctx, view, control).map(drop)
    }

    fn annotate(&self, ctx: &Context, image: &mut Image, control: &Control) {
        if let (true, Some(ic)) = (self.settings.show_points, &self.built) {
            let shown = ic.show_points(ctx, image, Rgb::new(1.0, 0.0, 0.0));
            control.note(&format!("marked {shown} irradiance cache values"));
        }
    }

    fn report(&self) -> Vec<String> {
        self.report.clone()
    }
}

/// The key of the render view an overture traces: everything its camera rays and cached
/// values depend on besides the cache options (which the file's header holds): scene with
/// camera, size, samples, filter, seed and intersection backend.
pub(crate) fn view_key(
    scene: &Scene,
    render: &ProgressiveOptions,
    accel: crate::accel::Backend,
) -> u64 {
    let backend = match accel {
        crate::accel::Backend::Embree => "Embree",
        crate::accel::Backend::Bvh => "Bvh",
    };
    let text = format!(
        "{:016x}|{}x{}|{}|{:?}|{}|{backend}",
        crate::scene::scene_hash(scene),
        render.view.width,
        render.view.height,
        render.spp,
        render.filter,
        render.view.seed,
    );
    // Never 0, which marks a cache without a view.
    crate::binary_file::fnv1a(text.as_bytes()).max(1)
}
