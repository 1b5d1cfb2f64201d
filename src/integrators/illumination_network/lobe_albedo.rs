//! What a directional surface's lobes reflect and transmit toward the eye (its directional
//! albedo by side, Fresnel and a metal's colour included), by the cosine of the eye
//! direction: rendering weighs the light it gathers around the mirror and refracted
//! directions by it. Worked out on a fixed set of cosines with many samples and interpolated
//! (an estimate from a few samples per pixel is off by several percent for a rough metal);
//! the same values whether a table holds them or they are worked out at each hit.

use super::distribute::Surface;
use crate::bsdf::Transport;
use crate::math::{Rgb, Vec3};

/// Cosines at which the albedo is worked out: (k + ½)/BINS.
const BINS: usize = 32;
/// Samples of each value: 32×32.
const SAMPLES: u32 = 32;

/// The albedo of one surface seen from one side, at the [`BINS`] cosines.
#[derive(Clone, Debug)]
pub struct LobeAlbedo {
    surface: Surface,
    side: u32,
    bins: Vec<(Rgb, Rgb)>,
}

/// The reflected and transmitted albedo of `surface` seen from `side` at cosine bin `k`.
fn bin(surface: &Surface, side: u32, k: usize) -> (Rgb, Rgb) {
    let c = (k as f32 + 0.5) / BINS as f32;
    let ng = if side == 0 { Vec3::Z } else { -Vec3::Z };
    // Rendering gathers a translucent sheet's kdt apart, over the whole hemisphere.
    let lobes = Surface {
        kdt: Rgb::ZERO,
        ..surface.clone()
    };
    let bsdf = lobes.directional_bsdf(ng, Vec3::Z);
    let wo = Vec3::new((1.0 - c * c).max(0.0).sqrt(), 0.0, c);
    bsdf.albedo_by_side(wo, SAMPLES, Transport::Radiance)
}

/// Linear interpolation between the bins around `cos`, clamped at the ends; `value(k)` gives
/// bin k.
fn interpolate(cos: f32, mut value: impl FnMut(usize) -> (Rgb, Rgb)) -> (Rgb, Rgb) {
    let x = (cos.clamp(0.0, 1.0) * BINS as f32 - 0.5).clamp(0.0, (BINS - 1) as f32);
    let k = (x as usize).min(BINS - 2);
    let t = x - k as f32;
    let (a, b) = (value(k), value(k + 1));
    (a.0 * (1.0 - t) + b.0 * t, a.1 * (1.0 - t) + b.1 * t)
}

impl LobeAlbedo {
    pub fn new(surface: Surface, side: u32) -> LobeAlbedo {
        LobeAlbedo {
            bins: (0..BINS).map(|k| bin(&surface, side, k)).collect(),
            surface,
            side,
        }
    }

    pub fn is_for(&self, surface: &Surface, side: u32) -> bool {
        self.side == side && same_lobes(&self.surface, surface)
    }

    /// The albedo toward an eye direction of cosine `cos` to the side's normal.
    pub fn at(&self, cos: f32) -> (Rgb, Rgb) {
        interpolate(cos, |k| self.bins[k])
    }

    pub fn memory(&self) -> usize {
        std::mem::size_of::<Self>() + self.bins.len() * std::mem::size_of::<(Rgb, Rgb)>()
    }
}

/// Whether two surfaces have the same directional lobes of their own (their diffuse colour,
/// emission and a mix's other part aside).
pub fn same_lobes(a: &Surface, b: &Surface) -> bool {
    (a.ks, a.kt, a.kdt, a.alpha, &a.optics) == (b.ks, b.kt, b.kdt, b.alpha, &b.optics)
}

/// [`LobeAlbedo::at`] without a table: the two bins needed, worked out now.
pub fn albedo_at(surface: &Surface, side: u32, cos: f32) -> (Rgb, Rgb) {
    interpolate(cos, |k| bin(surface, side, k))
}

/// The tables of every directional part of a surface (a mix has two) and side among
/// `surfaces`, in order of first use.
pub fn tables(surfaces: &[Surface], sides: impl Iterator<Item = u32>) -> Vec<LobeAlbedo> {
    let mut out: Vec<LobeAlbedo> = Vec::new();
    for (s, side) in surfaces.iter().zip(sides) {
        for (_, part) in s.parts() {
            if part.has_own_lobes() && !out.iter().any(|t| t.is_for(part, side)) {
                out.push(LobeAlbedo::new(own_lobes(part), side));
            }
        }
    }
    out
}

/// A part's own lobes, without a mix's other part (what [`same_lobes`] compares).
fn own_lobes(part: &Surface) -> Surface {
    Surface {
        blend: None,
        ..part.clone()
    }
}
