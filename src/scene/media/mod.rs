//! Participating media: fog, smoke and the colour inside glass. Every kind of medium is one
//! file here with a type implementing [`MediumModel`], listed in [`MediumKind`]. A medium
//! fills the space a shape's [`MediumInterface`] bounds (or the whole scene, as the
//! camera's medium); techniques walk a ray through it by [`tracking::sample_majorant`],
//! which draws collisions against the medium's majorant, segment by segment.
//!
//! Adding a kind of medium: its own file here with a type implementing [`MediumModel`], a
//! variant of [`MediumKind`] and its line in [`MediumKind::model`], its readers (native
//! TOML, pbrt) and writer (`convert`), its tests and docs.

mod grid;
mod grid_space;
mod homogeneous;
pub mod nanovdb;
pub mod presets;
mod rgbgrid;
mod sparse;
pub mod tracking;

pub use grid::UniformGrid;
pub use grid_space::MAX_GRID_SAMPLES;
pub use homogeneous::Homogeneous;
pub use rgbgrid::{RgbGrid, RgbGrids};
pub use sparse::{SparseGrid, SparseSource, SparseValues};

use crate::math::{Ray, Rgb, Vec3};

/// What a medium is at one point: its absorption and scattering coefficients (per unit
/// length), the radiance it emits (per unit length, as absorbed light is: pbrt-v4's
/// σa·Le), and its Henyey–Greenstein asymmetry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MediumPoint {
    pub sigma_a: Rgb,
    pub sigma_s: Rgb,
    pub le: Rgb,
    pub g: f32,
}

/// A stretch of a ray, `t` in [`t0`, `t1`) (in units of the ray's length), over which the
/// medium's extinction is at most `sigma_maj` (per unit of the ray's length).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    pub t0: f32,
    pub t1: f32,
    pub sigma_maj: Rgb,
}

/// What every kind of medium answers.
pub trait MediumModel {
    /// The kind's name, as the native format and pbrt-v4 call it (`"homogeneous"`, ...).
    fn kind(&self) -> &'static str;

    /// The medium at the world-space point `p`.
    fn at(&self, p: Vec3) -> MediumPoint;

    /// Calls `visit` for the stretches of `ray` within [0, `t_max`) where the medium may
    /// extinguish light, in order along the ray, each with a bound of its extinction;
    /// stops when `visit` returns false. Stretches not visited hold nothing.
    fn segments(&self, ray: &Ray, t_max: f32, visit: &mut dyn FnMut(Segment) -> bool);

    /// Whether the medium emits anywhere (techniques skip the emission term otherwise).
    fn emits(&self) -> bool;

    /// The coefficients at density 1, when the medium is one set of colours scaled at each
    /// point by a density (σa, σs) and an emission scale (Le): homogeneous media and
    /// density grids. Spectral renders turn these colours into spectra once a path.
    fn colours(&self) -> Option<&MediumPoint> {
        None
    }
}

/// The kinds of medium, each a type of its own in a file of this folder.
#[derive(Clone, Debug, PartialEq)]
pub enum MediumKind {
    Homogeneous(Homogeneous),
    /// Boxed: its samples and transforms are much larger than a homogeneous medium.
    UniformGrid(Box<UniformGrid>),
    RgbGrid(Box<RgbGrid>),
    /// A NanoVDB grid too large to hold dense.
    SparseGrid(Box<SparseGrid>),
}

impl MediumKind {
    /// The kind's implementation of the interface.
    pub fn model(&self) -> &dyn MediumModel {
        match self {
            MediumKind::Homogeneous(m) => m,
            MediumKind::UniformGrid(m) => m.as_ref(),
            MediumKind::RgbGrid(m) => m.as_ref(),
            MediumKind::SparseGrid(m) => m.as_ref(),
        }
    }
}

/// A named medium of a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Medium {
    pub name: String,
    pub kind: MediumKind,
}

impl Medium {
    pub fn model(&self) -> &dyn MediumModel {
        self.kind.model()
    }
}

/// The media on the two sides of a shape's surface (indices into `Scene::media`; `None` is
/// vacuum): `inside` on the side its geometric normal points away from, `outside` on the
/// side it points to. A ray crossing the surface enters the medium of the side it goes to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MediumInterface {
    pub inside: Option<u32>,
    pub outside: Option<u32>,
}

impl MediumInterface {
    /// The interface between `inside` and `outside`, or `None` when they are the same (a
    /// surface that leaves rays in the medium they travel in).
    pub fn between(inside: Option<u32>, outside: Option<u32>) -> Option<MediumInterface> {
        (inside != outside).then_some(MediumInterface { inside, outside })
    }

    /// The medium a ray leaving the surface along `w` travels in, for geometric normal `ng`.
    pub fn towards(&self, w: Vec3, ng: Vec3) -> Option<u32> {
        if w.dot(ng) > 0.0 {
            self.outside
        } else {
            self.inside
        }
    }
}

/// Why a medium cannot be made: the field to blame, as the native format names it
/// (`sigma_a`, `emission`, `density`, `resolution`, `bounds`, ...), and the reason, in
/// pbrt-v4's words where they differ (`Le`, `Lescale`, `nx*ny*nz`).
#[derive(Clone, Debug, PartialEq)]
pub struct MediumProblem {
    pub field: &'static str,
    pub message: String,
}

impl std::fmt::Display for MediumProblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

/// Checks that a medium's coefficients (field, name in messages, value) are finite and not
/// negative; the problem names the first that is not.
pub(crate) fn check_coefficients(named: &[(&'static str, &str, Rgb)]) -> Result<(), MediumProblem> {
    for (field, name, v) in named {
        if !v.is_finite() || v.min_element() < 0.0 {
            return Err(MediumProblem {
                field,
                message: format!(
                    "{name} must be finite and not negative, got ({}, {}, {})",
                    v.x, v.y, v.z
                ),
            });
        }
    }
    Ok(())
}

/// Checks a Henyey–Greenstein asymmetry: strictly between −1 and 1.
pub(crate) fn check_g(g: f32) -> Result<(), MediumProblem> {
    if g.is_finite() && g.abs() < 1.0 {
        Ok(())
    } else {
        Err(MediumProblem {
            field: "g",
            message: format!("g must lie strictly between -1 and 1, got {g}"),
        })
    }
}
