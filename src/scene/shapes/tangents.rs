//! How a surface point moves and turns with its texture coordinates: ∂p/∂u, ∂p/∂v and
//! ∂n/∂u, ∂n/∂v, which normal maps and bump maps need to turn the shading normal (pbrt-v4
//! computes the same per shape); each kind of shape gives its own.

use crate::math::{frame, Vec3};

/// The partial derivatives of position and normal in (u, v) at a surface point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tangents {
    pub dpdu: Vec3,
    pub dpdv: Vec3,
    pub dndu: Vec3,
    pub dndv: Vec3,
}

impl Tangents {
    /// An arbitrary frame around unit normal `n`, for points whose parametrisation is
    /// degenerate (a sphere's pole, a triangle with repeated texture coordinates).
    pub(super) fn around(n: Vec3) -> Tangents {
        let (t, b) = frame(n);
        Tangents {
            dpdu: t,
            dpdv: b,
            dndu: Vec3::ZERO,
            dndv: Vec3::ZERO,
        }
    }
}
