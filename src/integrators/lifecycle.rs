//! The one technique lifecycle: a technique is created from its settings, prepares once
//! (the irradiance cache's overture, the network's preprocess and distribution; nothing for
//! the others), and then renders tiles through one of the two tile kernels. The job's
//! renderer (`crate::job::Renderer`) drives every technique the same way.

use super::technique::{MonteCarloSettings, Technique};
use crate::accel::Backend;
use crate::control::Control;
use crate::image::Image;
use crate::integrators::bdpt::{Bdpt, BdptOptions};
use crate::integrators::illumination_network::technique::NetworkTechnique;
use crate::integrators::irradiance_cache::technique::CacheTechnique;
use crate::integrators::light::{LightOptions, LightTracer};
use crate::integrators::path::{PathOptions, PathTracer};
use crate::integrators::whitted::{Whitted, WhittedOptions};
use crate::integrators::{Context, Integrator, MonteCarlo};
use crate::render::progressive::ProgressiveOptions;
use crate::render::{PixelSampling, Tile};
use crate::scene::Scene;
use crate::Result;

/// What a technique's preparation needs of the view a job renders.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct View {
    pub width: u32,
    pub height: u32,
    /// Only these pixels (a part of the image), if any.
    pub region: Option<Tile>,
    pub seed: u64,
    pub threads: Option<usize>,
    pub accel: Backend,
}

impl View {
    /// The Monte Carlo render of this view with `mc`'s samples and filter.
    pub(crate) fn progressive(&self, mc: &MonteCarloSettings) -> ProgressiveOptions {
        ProgressiveOptions {
            width: self.width,
            height: self.height,
            spp: mc.spp,
            time_limit: mc.time_limit,
            threads: self.threads,
            seed: self.seed,
            filter: mc.filter,
            reconstruction: mc.reconstruction,
        }
    }
}

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
    fn prepare(&mut self, _ctx: &Context, _view: &View, _control: &Control) -> Result<()> {
        Ok(())
    }

    /// Whether [`prepare`](Self::prepare) does any work (its time is then reported).
    fn prepares(&self) -> bool {
        false
    }

    /// Whether the preparation depends on the view (a new camera prepares again).
    fn view_dependent(&self) -> bool {
        false
    }

    /// What renders the tiles, once prepared.
    fn tiles(&self) -> Tiles<'_>;

    /// The preparation alone, saved for render jobs to read (`precompute`): the techniques
    /// without one refuse.
    fn precompute(&mut self, _ctx: &Context, _view: &View, _control: &Control) -> Result<()> {
        Err(crate::Error::Invalid(
            "only the irradiance cache and the network have something to precompute".into(),
        ))
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
        Technique::Light(mc) => {
            refuse_orthographic(scene, "light")?;
            Box::new(MonteCarloTechnique {
                integrator: LightTracer::new(LightOptions {
                    max_depth: mc.max_depth,
                }),
                settings: *mc,
            })
        }
        Technique::Bdpt(mc) => {
            refuse_orthographic(scene, "bdpt")?;
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

/// Light paths reach the camera by connecting to it, which an orthographic camera's
/// importance (a delta in direction) does not allow; pbrt-v4 refuses it too.
fn refuse_orthographic(scene: &Scene, integrator: &str) -> crate::Result<()> {
    if matches!(
        scene.camera.projection,
        crate::scene::Projection::Orthographic { .. }
    ) {
        return Err(crate::Error::input(
            &scene.source,
            format!(
                "the {integrator} integrator cannot connect light paths to an orthographic camera (projection = \"orthographic\"): use a perspective camera or the path integrator"
            ),
        ));
    }
    Ok(())
}
