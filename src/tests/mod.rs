//! Tests that need the crate's internals (integrators called directly, caches looked into,
//! test integrators): moved here from tests/, one file per former test file.

mod irradiance_cache;
mod robustness;
mod whitted;
