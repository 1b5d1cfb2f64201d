//! raylink: a global-illumination renderer over Embree. It implements Whitted ray tracing,
//! path, light and bidirectional path tracing, irradiance caching, illumination networks
//! and object-space temporal coherence for animations, and writes images through
//! OpenImageIO.
//!
//! A render is a [`Job`]: a [`Technique`] with its settings (made from [`Settings`] by
//! [`Technique::create`], which checks them), a view, a seed, the threads and the
//! intersection [`Backend`]. A [`Renderer`] runs it; the caller keeps the [`Control`]: a
//! [`CancelToken`] it can cancel from any thread, a [`MemoryBudget`] and a [`Progress`] sink.
//! The library holds no process-wide state and prints nothing. The image is a function of
//! (scene, settings, seed): the same bit for bit for any thread count.
//!
//! ```no_run
//! use raylink::{Control, Job, Renderer, Scene, Settings, Technique, TechniqueKind};
//!
//! let scene = Scene::load("scenes/cornell-box.toml".as_ref())?;
//! let technique = Technique::create(&Settings {
//!     integrator: Some(TechniqueKind::Path),
//!     spp: Some(64),
//!     ..Settings::default()
//! })?;
//! let job = Job { seed: 7, ..Job::new(&scene, technique) };
//! let control = Control::default();
//! let mut renderer = Renderer::new(scene, job, &control)?;
//! let rendered = renderer.render(&control)?;
//! raylink::write_image("cornell.exr".as_ref(), &rendered.image, &[], &Default::default())?;
//! println!("{}", rendered.stats.summary());
//! # Ok::<(), raylink::Error>(())
//! ```
//!
//! The layers, bottom up: [`accel`] (one intersection interface, Embree or a pure-Rust BVH),
//! [`scene`] (what every reader produces), [`image`] (images and their files), the
//! techniques and the tile driver (internal), [`job`] (the engine), and beside it
//! [`coherence`] (animations), [`farm`] (parts of an image, merged) and [`bench`](mod@bench)
//! (measurements).

pub mod accel;
pub mod atomic_file;
pub mod bench;
pub(crate) mod binary_file;
pub(crate) mod bsdf;
pub mod coherence;
pub mod control;
pub mod error;
pub mod farm;
#[doc(hidden)]
pub mod fuzzing;
pub(crate) mod guiding;
pub mod image;
pub mod input_file;
pub(crate) mod integrators;
pub mod job;
pub mod math;
pub mod output_paths;
pub mod platform;
pub(crate) mod render;
pub mod scene;
pub mod settings;
pub mod spectrum;
#[cfg(test)]
mod tests;
pub(crate) mod transport;

pub use accel::Backend;
pub use error::{Error, Result};
pub use image::output::{read_image, write_image, OutputOptions};
pub use image::{Image, MetaValue, Metadata};
/// The flux arriving at a set of surfaces, by gathering or by shooting.
pub use integrators::flux;
pub use job::{
    Aov, CancelToken, Control, Job, MemoryBudget, Progress, Relight, Rendered, Renderer, Settings,
    Technique, TechniqueKind,
};
pub use render::{checkpoint, Film, RenderStats, Shown, Tile, Watch};
pub use scene::Scene;

/// Version of this crate, as printed by `raylink --version`.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
