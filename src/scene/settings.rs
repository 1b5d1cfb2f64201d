//! Render settings a scene file may carry (pbrt's `Sampler`, `Integrator`, `PixelFilter`;
//! a `[render]` table in TOML). Command-line options override them.

use crate::image::filter::Filter;

#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderSettings {
    /// raylink integrator name ("whitted", "path", "light", "bdpt", ...).
    pub integrator: Option<String>,
    /// Samples per pixel.
    pub spp: Option<u32>,
    /// Maximum path length (number of bounces).
    pub max_depth: Option<u32>,
    pub filter: Option<Filter>,
}
