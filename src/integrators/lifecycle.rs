//! The one technique lifecycle: a technique is created from its settings
//! ([`super::create`]), prepares once (the irradiance cache's overture, the network's
//! preprocess and distribution; nothing for the others), and then renders tiles through one
//! of the two tile kernels. The job's renderer (`crate::job::Renderer`) drives every
//! technique the same way.

use super::technique::MonteCarloSettings;
use crate::accel::Backend;
use crate::control::Control;
use crate::image::Image;
use crate::integrators::{Context, Integrator, MonteCarlo};
use crate::render::progressive::ProgressiveOptions;
use crate::render::{PixelSampling, Tile};
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
