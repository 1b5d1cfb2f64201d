//! Normal maps and bump maps: detail that turns the shading normal without moving the
//! surface, as pbrt-v4's `normalmap` and `displacement` do (`NormalMap` and `BumpMap` in
//! its materials.h).

use super::shapes::Tangents;
use super::texture::{ImageTexture, Texture};
use crate::math::{Vec2, Vec3};
use std::sync::Arc;

/// The step in (u, v) of the bump map's finite differences: pbrt-v4's, for rays without
/// differentials.
const BUMP_STEP: f32 = 0.0005;

/// How a material turns the shading normal.
#[derive(Clone, Debug, PartialEq)]
pub enum NormalDetail {
    /// A tangent-space normal map: each texel's RGB is (n + 1)/2 in the frame of ∂p/∂u
    /// (x), the shading normal (z) and their cross product (y). Read without any encoding.
    Map(Arc<ImageTexture>),
    /// A displacement along the shading normal, in scene units (a float texture).
    Bump(Texture),
}

impl NormalDetail {
    /// The shading normal at a point with shading normal `ns` (unit), geometric normal `ng`,
    /// position `p`, texture coordinates `uv` and derivatives `d`; on `ng`'s side.
    pub(crate) fn shading_normal(
        &self,
        ns: Vec3,
        ng: Vec3,
        p: Vec3,
        uv: Vec2,
        d: &Tangents,
    ) -> Vec3 {
        let n = match self {
            NormalDetail::Map(image) => {
                let local = (image.eval(uv) * 2.0 - Vec3::ONE).normalize_or_zero();
                if local == Vec3::ZERO {
                    return ns;
                }
                // The frame's x axis: ∂p/∂u made perpendicular to the shading normal.
                let x = (d.dpdu - ns * d.dpdu.dot(ns)).normalize_or_zero();
                if x == Vec3::ZERO {
                    return ns;
                }
                let y = ns.cross(x);
                x * local.x + y * local.y + ns * local.z
            }
            NormalDetail::Bump(displacement) => {
                let at = |p: Vec3, uv: Vec2| displacement.eval_float(p, uv, ng);
                let h = at(p, uv);
                let hu = at(p + d.dpdu * BUMP_STEP, uv + Vec2::new(BUMP_STEP, 0.0));
                let hv = at(p + d.dpdv * BUMP_STEP, uv + Vec2::new(0.0, BUMP_STEP));
                let dpdu = d.dpdu + ns * ((hu - h) / BUMP_STEP) + d.dndu * h;
                let dpdv = d.dpdv + ns * ((hv - h) / BUMP_STEP) + d.dndv * h;
                let n = dpdu.cross(dpdv).normalize_or_zero();
                // The cross product's sign follows the parametrisation, not the surface.
                if n.dot(ns) < 0.0 {
                    -n
                } else {
                    n
                }
            }
        };
        on_side(n, ns, ng)
    }
}

/// `n` kept on the geometric normal's side (the renderer's convention for shading normals);
/// `fallback` if it has no direction.
fn on_side(n: Vec3, fallback: Vec3, ng: Vec3) -> Vec3 {
    if !n.is_finite() || n == Vec3::ZERO {
        return fallback;
    }
    let c = n.dot(ng);
    if c > 1e-3 {
        return n;
    }
    // Tilted past the horizon: bring it just above it.
    (n - ng * (c - 1e-3)).normalize_or_zero()
}
