//! The distribution process: light shot from the emitting nodes travels over the links until
//! the flux still to be shot falls below `tolerance` of the emitted flux.
//!
//! **Reflectance.** Each node's reflectance maps incoming links to outgoing links:
//! - diffuse kd: the paper's bypass: incoming flux is summed into one accumulator and leaves
//!   as the same radiance kd·Φ/W on every slot (flux ∝ w);
//! - the rest of the material (specular, transmission, roughness, Fresnel, refraction, a
//!   metal): the path tracer's BSDF without its diffuse lobe, as a table from in-slots to
//!   out-slots, T(l → o) = ∫ f cos θ dω over o's cell of directions averaged over l's,
//!   estimated by sampling the BSDF once per group of nodes with the same surface and normal
//!   (a planar polygon's), then for each node the light of out-slots that no line of its
//!   patch takes is moved to the neighbouring slots that carry it (`maps.rs`).
//!
//! A table's rows sum to the BSDF's directional albedo (kd + ks + kt is scaled down to at
//! most 1 per channel, with Fresnel the larger of ks and kd + kt). Tables are built here, not
//! in the preprocess: they depend on materials, which relighting may change.
//!
//! **Order.** Jacobi sweeps: in each sweep every node gathers what its neighbours shot in the
//! previous sweep over its links (links are symmetric, so gathering over a node's own links is
//! the scatter of its neighbours), then passes it through its reflectance. Each sweep is
//! parallel over nodes and independent of the thread count. Sweep k carries exactly the
//! light of k bounces, so the first sweep's output is direct illumination (kept for the
//! hybrid rendering). The gather is branchless for the diffuse light (`Ends::gather`);
//! directional ends add their rows on top.
//!
//! All-diffuse networks are solved by default with conjugate gradients on the symmetrised
//! system (`conjugate_gradients.rs`): the same gather, about 8 of them where the sweeps take
//! 13, and a smaller error. Networks with directional nodes (their maps are not symmetric)
//! use the sweeps whatever the order asked; `Order::Shoot` is the paper-era alternative,
//! sequential.
//!
//! Files: `surfaces.rs` (the nodes' surfaces from the scene's materials), `maps.rs` (the
//! directional nodes' reflectance tables), `gather.rs` (what a node gathers over its links),
//! `sweeps.rs` (the Jacobi sweeps, warm starts, and the choice of order), `shoot.rs` (largest
//! unshot first), `conjugate_gradients.rs`, and `solution.rs` (what rendering reads).

pub mod conjugate_gradients;
mod gather;
mod maps;
mod shoot;
mod solution;
mod surfaces;
mod sweeps;

pub(crate) use maps::{for_each_candidate, local};
pub use solution::{DistributeStats, Solution};
pub(crate) use surfaces::network_kd;
pub use surfaces::{lossless_channel, surfaces, surfaces_with, Surface};
pub use sweeps::distribute_from;

use super::Network;
use crate::scene::Scene;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DistributeOptions {
    /// Stop when the flux still to be shot is below this fraction of the emitted flux.
    pub tolerance: f32,
    pub max_sweeps: u32,
    /// Emission multiplier (relighting).
    pub light_scale: f32,
    pub order: Order,
}

/// The order in which nodes process their light.
pub use crate::settings::NetworkOrder as Order;

impl Default for DistributeOptions {
    fn default() -> Self {
        DistributeOptions {
            tolerance: super::DEFAULT_TOLERANCE,
            max_sweeps: 100_000,
            light_scale: 1.0,
            order: Order::ConjugateGradients,
        }
    }
}

/// When a distribution started (for its statistics), and what stops it early: a job's
/// cancel token, looked at between sweeps.
#[derive(Clone, Copy)]
pub struct Run<'a> {
    pub start: std::time::Instant,
    pub cancel: Option<&'a crate::control::CancelToken>,
    /// Told the unshot flux as a fraction of the emitted before each sweep (progress).
    pub report: Option<&'a (dyn Fn(f64) + Sync)>,
}

impl Run<'_> {
    /// A run starting now that nothing stops.
    pub fn now() -> Run<'static> {
        Run {
            start: std::time::Instant::now(),
            cancel: None,
            report: None,
        }
    }

    /// Reports how much is still unshot (`unshot` of `emitted`) and tells whether to stop
    /// before the next sweep.
    pub(crate) fn stopped(&self, unshot: f64, emitted: f64) -> bool {
        if let Some(report) = self.report {
            report(unshot / emitted.max(1e-300));
        }
        self.cancel.is_some_and(|c| c.is_cancelled())
    }
}

/// Carries light over the network until convergence.
pub fn distribute(net: &Network, scene: &Scene, options: &DistributeOptions) -> Solution {
    distribute_surfaces(
        net,
        surfaces(net, scene, options.light_scale),
        options,
        Run::now(),
    )
}

/// [`distribute`] for given node surfaces (their emission included).
pub fn distribute_surfaces(
    net: &Network,
    surfaces: Vec<Surface>,
    options: &DistributeOptions,
    run: Run,
) -> Solution {
    distribute_from(net, surfaces, options, run, None)
}
