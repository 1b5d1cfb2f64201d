//! Relighting by superposition. Light transport over a network is linear in the emission and
//! the colour channels never mix (every reflectance map multiplies a channel by its own
//! coefficient), so the solution for emissions E'_m of the emissive materials m is
//!
//! ```text
//! solution(E') = Σ_m (E'_m / E_m) ⊙ solution_m,
//! ```
//!
//! per channel, where solution_m is the converged network lit by material m alone at its
//! emission E_m. A *light basis* stores one solution per emissive material (for the nodes'
//! reflectances at the time it was computed, identified by a hash); relighting with other
//! light strengths then runs no distribution at all and does not need the link table (the
//! network file stores the basis before the links, so it is not even read). A change of
//! reflectance invalidates the basis: the distribution runs again.
//!
//! Each basis solution converges to the tolerance relative to its own emitted flux, so the
//! sum converges to the tolerance relative to the total. Scaling every light by a power of
//! two scales the result exactly.
//!
//! A *reflectance series* (`series.rs`) does the same for a new colour of one diffuse
//! material: a weighted sum of stored terms. `basis.rs` holds the light basis and its
//! superposition, `file_bytes.rs` both as bytes of the network file.

mod basis;
mod file_bytes;
mod series;

pub use basis::{BasisLight, LightBasis};
pub use series::{ReflectanceSeries, SeriesTerm, MAX_SERIES_TERMS};
