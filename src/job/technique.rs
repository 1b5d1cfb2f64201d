//! The one technique lifecycle: a technique is created from its settings, prepares once
//! (the irradiance cache's overture, the network's preprocess and distribution; nothing for
//! the others), and then renders tiles through one of the two tile kernels. The renderer
//! ([`super::Renderer`]) drives every technique the same way.

use super::settings::{MonteCarloSettings, Technique};
use super::{Control, Job};
use crate::image::Image;
use crate::integrators::bdpt::{Bdpt, BdptOptions};
use crate::integrators::illumination_network::technique::NetworkTechnique;
use crate::integrators::irradiance_cache::technique::CacheTechnique;
use crate::integrators::light::{LightOptions, LightTracer};
use crate::integrators::path::{PathOptions, PathTracer};
use crate::integrators::whitted::{Whitted, WhittedOptions};
use crate::integrators::{Context, Integrator, MonteCarlo};
use crate::render::PixelSampling;
use crate::scene::Scene;
use crate::Result;

/// What renders a prepared technique's tiles.
pub(crate) enum Tiles<'a> {
    /// One pass, each pixel's value from its own samples (Whitted's adaptive corner
    /// subdivision or uniform supersampling).
    Pixels(&'a dyn Integrator, PixelSampling),
    /// Progressive Monte Carlo sample passes.
    Samples(&'a dyn MonteCarlo, MonteCarloSettings),
}

/// A technique's lifecycle.
pub(crate) trait Lifecycle: Send + Sync {
    /// The work done before any tile: for the job's view (the irradiance cache's overture
    /// traces that view's camera rays). Runs once per renderer.
    fn prepare(&mut self, _ctx: &Context, _job: &Job, _control: &Control) -> Result<()> {
        Ok(())
    }

    /// Whether the preparation depends on the view (a new camera prepares again).
    fn view_dependent(&self) -> bool {
        false
    }

    /// What renders the tiles, once prepared.
    fn tiles(&self) -> Tiles<'_>;

    /// The preparation alone, saved for render jobs to read (`precompute`): the techniques
    /// without one refuse.
    fn precompute(&mut self, _ctx: &Context, job: &Job, _control: &Control) -> Result<()> {
        Err(crate::Error::Invalid(format!(
            "the {} integrator has nothing to precompute",
            job.technique.kind()
        )))
    }

    /// Marks added to the finished image (the irradiance cache's points).
    fn annotate(&self, _ctx: &Context, _image: &mut Image, _control: &Control) {}

    /// Statistics of the preparation, one line each, for people.
    fn report(&self) -> Vec<String> {
        Vec::new()
    }
}

/// The technique `technique` describes, for `scene` (pbrt's `Integrator::Create`).
pub(crate) fn create(technique: &Technique, scene: &Scene) -> Result<Box<dyn Lifecycle>> {
    Ok(match technique {
        Technique::Whitted(w) => Box::new(WhittedTechnique {
            integrator: Whitted::new(WhittedOptions {
                max_depth: w.max_depth,
                area_samples: w.area_samples,
                fresnel: w.fresnel,
                ..WhittedOptions::default()
            }),
            sampling: w.sampling,
        }),
        Technique::Path(mc) => Box::new(MonteCarloTechnique {
            integrator: PathTracer::new(PathOptions {
                max_depth: mc.max_depth,
            }),
            settings: *mc,
        }),
        Technique::Light(mc) => Box::new(MonteCarloTechnique {
            integrator: LightTracer::new(LightOptions {
                max_depth: mc.max_depth,
            }),
            settings: *mc,
        }),
        Technique::Bdpt(mc) => {
            Bdpt::check_scene(scene).map_err(|e| crate::Error::input(&scene.source, e))?;
            Box::new(MonteCarloTechnique {
                integrator: Bdpt::new(BdptOptions {
                    max_depth: mc.max_depth,
                }),
                settings: *mc,
            })
        }
        Technique::IrradianceCache(mc, cache) => Box::new(CacheTechnique::new(*mc, cache.clone())),
        Technique::Network(n) => Box::new(NetworkTechnique::new(n.clone(), scene)),
    })
}

/// Whitted's ray tracer: nothing to prepare.
struct WhittedTechnique {
    integrator: Whitted,
    sampling: PixelSampling,
}

impl Lifecycle for WhittedTechnique {
    fn tiles(&self) -> Tiles<'_> {
        Tiles::Pixels(&self.integrator, self.sampling)
    }
}

/// The path, light and bidirectional tracers: nothing to prepare.
struct MonteCarloTechnique<T> {
    integrator: T,
    settings: MonteCarloSettings,
}

impl<T: MonteCarlo + Send> Lifecycle for MonteCarloTechnique<T> {
    fn tiles(&self) -> Tiles<'_> {
        Tiles::Samples(&self.integrator, self.settings)
    }
}
