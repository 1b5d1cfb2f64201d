//! raylink: a global-illumination renderer.
//!
//! The layers, bottom up:
//! - [`accel`]: one intersection interface; the Embree backend is the only place that talks to Embree, and
//!   `accel::bvh` is the pure-Rust backend (obvhs).
//! - [`scene`]: the scene description every reader produces (camera, materials, shapes, lights).
//! - [`image`]: images and their files, written and read through OpenImageIO.
//! - [`bsdf`]: scattering at surfaces (evaluate, sample, density) for the Monte Carlo integrators.
//! - [`integrators`]: one module per light-transport technique.
//! - [`render`]: tiles, threads, pixel sampling, progress and statistics.
//! - [`coherence`]: `raylink animate`, static-camera animation with object-space temporal coherence.
//! - [`bench`](mod@bench): `raylink bench`, Embree against the pure-Rust BVH.
//! - [`farm`]: rendering parts of an image (tiles, crops) on many machines, and merging them.

pub mod accel;
pub mod atomic_file;
pub mod bench;
pub mod binary_file;
pub mod bsdf;
pub mod coherence;
pub mod error;
pub mod farm;
#[doc(hidden)]
pub mod fuzzing;
pub mod image;
pub mod integrators;
pub mod interrupt;
pub mod lights;
pub mod math;
pub mod memory;
pub mod render;
pub mod scene;

pub use error::{Error, Result};

/// Version of this crate, as printed by `raylink --version`.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
