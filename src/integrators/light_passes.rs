//! What the path tracer records of a sample for the light passes
//! (`crate::transport::light_passes`). The tracer's loop is written once, generic over a
//! [`Record`]: the image's own samples record nothing ([`NoPasses`], whose calls compile
//! away), and the light passes' samples record each contribution into a [`PassSample`]
//! ([`Passes`]) as the loop adds it to the image value, so that the passes sum to it.
//!
//! A contribution is sorted by the vertex it is added at: at the first surface (vertex 0),
//! emission is `Emit` and the background `Env`; next-event estimation at vertex 0, and
//! emission or background reached from it (vertex 1), is direct light; everything later is
//! indirect light. Direct light from next-event estimation goes to the kinds of lobe by
//! their shares of f at the light's direction; all light through the direction sampled at
//! vertex 0 by the kinds' shares of that sample's weight (the throughput after it is the
//! same factor for every kind).

use crate::bsdf::{Bsdf, BsdfSample};
use crate::math::{Rgb, Vec3};
use crate::transport::light_passes::{direct_slot, PassSample, EMIT, ENV};

/// What the tracer tells a recorder. `vertex`: the path's vertex the contribution is added
/// at (0: the first surface the camera sees); `c`: the contribution as added to the image
/// value; `light`: the light it came from (evaluated only when groups are kept).
pub(crate) trait Record {
    /// Whether anything is recorded (work done only for the recorder is skipped if not).
    const ACTIVE: bool = true;

    /// The BSDF at the first surface.
    fn first_surface(&mut self, _bsdf: &Bsdf) {}

    /// Emission of a surface, or the background, reached at `vertex`.
    fn emission(
        &mut self,
        _vertex: u32,
        _background: bool,
        _c: Rgb,
        _light: impl FnOnce() -> Option<usize>,
    ) {
    }

    /// Next-event estimation at `vertex`, towards `wi`.
    fn direct(
        &mut self,
        _vertex: u32,
        _c: Rgb,
        _bsdf: &Bsdf,
        (_wo, _wi): (Vec3, Vec3),
        _light: impl FnOnce() -> Option<usize>,
    ) {
    }

    /// The direction sampled at `vertex`.
    fn scattered(&mut self, _vertex: u32, _bsdf: &Bsdf, _wo: Vec3, _s: &BsdfSample) {}
}

/// The image's own samples: nothing recorded.
pub(crate) struct NoPasses;

impl Record for NoPasses {
    const ACTIVE: bool = false;
}

/// The light passes' samples.
pub(crate) struct Passes<'a> {
    pub out: &'a mut PassSample,
    /// The shares of the lobe kinds in the direction sampled at the first surface.
    shares: [Rgb; 3],
}

impl<'a> Passes<'a> {
    pub fn new(out: &'a mut PassSample) -> Passes<'a> {
        Passes {
            out,
            shares: [Rgb::ZERO; 3],
        }
    }

    /// `c` split by `shares` into direct (`indirect` false) or indirect light.
    fn split(&mut self, c: Rgb, shares: [Rgb; 3], indirect: bool) {
        for (kind, share) in shares.iter().enumerate() {
            self.out.values[direct_slot(kind) + indirect as usize] += c * *share;
        }
    }
}

impl Record for Passes<'_> {
    fn first_surface(&mut self, bsdf: &Bsdf) {
        for (kind, colour) in bsdf.lobe_colours().into_iter().enumerate() {
            self.out.values[direct_slot(kind) + 2] = colour;
        }
    }

    fn emission(
        &mut self,
        vertex: u32,
        background: bool,
        c: Rgb,
        light: impl FnOnce() -> Option<usize>,
    ) {
        if vertex == 0 {
            self.out.values[if background { ENV } else { EMIT }] += c;
            return;
        }
        self.split(c, self.shares, vertex > 1);
        if self.out.groups > 0 {
            self.out.add_to_group(light(), c);
        }
    }

    fn direct(
        &mut self,
        vertex: u32,
        c: Rgb,
        bsdf: &Bsdf,
        (wo, wi): (Vec3, Vec3),
        light: impl FnOnce() -> Option<usize>,
    ) {
        if c == Rgb::ZERO {
            return;
        }
        if vertex == 0 {
            self.split(c, bsdf.eval_shares(wo, wi), false);
        } else {
            self.split(c, self.shares, true);
        }
        if self.out.groups > 0 {
            self.out.add_to_group(light(), c);
        }
    }

    fn scattered(&mut self, vertex: u32, bsdf: &Bsdf, wo: Vec3, s: &BsdfSample) {
        if vertex == 0 {
            self.shares = bsdf.sample_shares(wo, s);
        }
    }
}
