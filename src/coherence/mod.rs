//! Object-space temporal coherence for static-camera animation (Jevans 1992, "Object Space
//! Temporal Coherence for Ray Tracing"): voxels record which pixel blocks' rays crossed them,
//! and a frame retraces only the blocks whose rays crossed voxels where something changed.
//!
//! - `grid`: the voxel grid and the 3-D DDA.
//! - `adaptive`: the grid with cells cut finer where a frame's changes lie.
//! - `tables`: pixel-block bit tables (surface and shadow) per voxel.
//! - `segments`: the other form of the records: each block's segments, walked through
//!   the voxels that changed when a frame asks.
//! - `record`: the intersection wrapper that records every query's segment.
//! - `changes`: what changed between two frames.
//! - `renderer`: the incremental frame renderer.
//! - [`sequence`]: a sequence's frames rendered coherently (or verified), with statistics;
//!   [`report`] writes them for people.
//!
//! A sequence is rendered from the same [`Job`](crate::Job) as a still image (technique,
//! size, seed, threads, backend) and [`Coherence`], the engine's own settings:
//! [`render_frames`] for an animation's frames, [`Sequence`] for frames fed one at a time.

/// The adaptive grid, public only as `grid::ActiveVoxels` shows it: not an API.
#[doc(hidden)]
pub mod adaptive;
pub(crate) mod changes;
/// The voxel grid and its walk, public only for `benches/coherence.rs`: not an API.
#[doc(hidden)]
pub mod grid;
pub(crate) mod record;
pub(crate) mod renderer;
pub mod report;
pub(crate) mod segments;
pub mod sequence;
pub(crate) mod tables;

/// How animations choose lights for next-event estimation: by power, which a moving
/// light leaves unchanged elsewhere (a light hierarchy's choice at every point follows every
/// light's place, so one moving light would make every pixel change).
pub(crate) const LIGHT_SELECTION: crate::scene::lights::SelectionKind =
    crate::scene::lights::SelectionKind::Power;

pub use record::Records;
pub use renderer::FrameStats;
pub use sequence::{
    animates, render_frames, Coherence, FrameRow, Placement, Report, Sequence, SequenceMode, Time,
};
