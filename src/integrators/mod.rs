//! Light-transport techniques, one module each, written against the transport layer
//! ([`crate::transport`]): they see the scene through its `Context` and render through its
//! `Integrator` or `MonteCarlo` interface; `technique` lists them.

pub mod bdpt;
mod camera_connection;
pub mod flux;
mod guided_path;
pub mod illumination_network;
pub mod irradiance_cache;
pub mod light;
pub(crate) mod light_passes;
pub mod path;
pub mod sppm;
pub(crate) mod technique;
pub mod vcm;
mod volumetric;
mod volumetric_light;
pub mod whitted;
