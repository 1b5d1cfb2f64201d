//! The one technique lifecycle: a technique is made from its settings
//! (`crate::integrators::technique`), prepares once (the irradiance cache's overture, the network's
//! preprocess and distribution; nothing for the others), and then renders tiles through one
//! of the two tile kernels. The job's renderer (`crate::job::Renderer`) drives every
//! technique the same way.

use crate::control::{CancelToken, Control};
use crate::error::Result;
use crate::image::Image;
pub use crate::transport::settings::MonteCarloSettings;
use crate::transport::{Context, Integrator, MonteCarlo, PixelSampling, View};

/// What renders a prepared technique's tiles.
pub(crate) enum Tiles<'a> {
    /// One pass, each pixel's value from its own samples (Whitted's adaptive corner
    /// subdivision or uniform supersampling).
    Pixels(&'a dyn Integrator, PixelSampling),
    /// Progressive Monte Carlo sample passes.
    Samples(&'a dyn MonteCarlo, MonteCarloSettings),
    /// The whole image at once, in the technique's own iterations (stochastic progressive
    /// photon mapping, whose photons reach every pixel): no tiles, no part of an image.
    Whole(&'a dyn WholeImage),
}

/// A technique that renders the whole image itself, in passes over every pixel whose
/// results are not a mean of samples (stochastic progressive photon mapping: a pixel's
/// photon count, radius and flux change from pass to pass). Each pixel keeps
/// [`state_len`](Self::state_len) values of its own between passes; the render keeps them
/// (in its film, which a checkpoint saves), so that a render resumes exactly where it
/// stopped.
pub(crate) trait WholeImage: Sync {
    /// Values of state each pixel keeps.
    fn state_len(&self) -> usize;

    /// Each pixel's state before the first pass of a render of `view`, into `state`
    /// (row-major, [`state_len`](Self::state_len) values a pixel).
    fn start(&self, ctx: &Context, view: &View, state: &mut [f64]);

    /// Pass `index` over the image of `view`: updates every pixel's state, or returns
    /// `None`, the state unchanged, when `cancel` stops it before the end.
    fn pass(
        &self,
        ctx: &Context,
        view: &View,
        index: u32,
        state: &mut [f64],
        cancel: &CancelToken,
    ) -> Option<WholePass>;

    /// A pixel's value in the image of `view` from its state, times the passes taken (the
    /// film's image divides by them).
    fn value(&self, view: &View, pixel: &[f64]) -> [f64; 3];

    /// What a pass is, for people ("iterations of 100000 photons").
    fn unit(&self, view: &View) -> String;
}

/// What a [`WholeImage`] pass traced.
pub(crate) struct WholePass {
    pub rays: crate::transport::RayStats,
    /// Camera rays traced.
    pub samples: u64,
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
        Err(crate::error::Error::Invalid(
            "only the irradiance cache and the network have something to precompute".into(),
        ))
    }

    /// Marks added to the finished image (the irradiance cache's points).
    fn annotate(&self, _ctx: &Context, _image: &mut Image, _control: &Control) {}

    /// Statistics of the preparation, one line each, for people.
    fn report(&self) -> Vec<String> {
        Vec::new()
    }

    /// What the technique holds besides the film while it renders a `width` x `height`
    /// image, and its bytes (estimated), for the memory budget; `None`: nothing worth
    /// counting.
    fn memory(&self, _width: u32, _height: u32) -> Option<(String, u64)> {
        None
    }
}

/// A progressive Monte Carlo technique (path, light and bidirectional tracing): nothing to
/// prepare, sample passes over the whole image.
pub(crate) struct SampledTechnique<T> {
    pub integrator: T,
    pub settings: MonteCarloSettings,
}

impl<T: MonteCarlo + Send> Lifecycle for SampledTechnique<T> {
    fn tiles(&self) -> Tiles<'_> {
        Tiles::Samples(&self.integrator, self.settings)
    }

    fn memory(&self, width: u32, height: u32) -> Option<(String, u64)> {
        self.integrator.iteration_memory((width, height))
    }
}
