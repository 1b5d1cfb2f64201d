//! Tests that need the crate's internals (integrators called directly, caches, networks and
//! coherence records looked into, test integrators), one file per theme.

mod adaptive_sampling;
mod binary_files;
mod bsdf;
mod coherence;
mod coherence_random;
pub(crate) mod coherence_scenes;
mod irradiance_cache;
mod layered;
mod layered_furnace;
mod light_selection;
mod materials;
mod network_build;
pub(crate) mod network_common;
mod network_directional;
mod network_files;
mod network_relight;
mod network_scenes;
mod network_transport;
mod normal_detail;
#[cfg(feature = "oiio")]
mod oiio;
mod path_guiding;
mod pixel_statistics;
mod reproductions;
mod robustness;
mod rough_glass;
mod spawn;
mod tabulated_brdf;
mod thin_sheet;
mod whitted;
