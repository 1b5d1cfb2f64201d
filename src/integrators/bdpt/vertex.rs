//! The vertices of bidirectional paths and the densities with which each strategy samples
//! them: surfaces, points in media, emitters (at infinity too) and the camera.

use crate::bsdf::{phase, Bsdf, Transport};
use crate::integrators::camera_connection::camera_pdf_dir;
use crate::math::spawn::Spot;
use crate::math::{Rgb, Vec3};
use crate::scene::camera::CameraBasis;
use crate::scene::lights::Emitter;
use crate::scene::media::MediumInterface;
use crate::transport::Context;
use std::f32::consts::PI;

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Kind {
    Camera,
    /// A light subpath's first vertex: emitter index, and whether it is a point light.
    Light {
        light: usize,
        point: bool,
    },
    Surface,
    /// A scattering point in a medium, with its Henyey–Greenstein asymmetry.
    Medium {
        g: f32,
    },
    /// A point at infinity, known by its direction only (the vertex's `n`, the way the
    /// light travels): a light subpath's start at the background or a directional light
    /// (`delta`), or a camera subpath that left the scene (`light` the background, if any).
    Infinite {
        light: Option<usize>,
        delta: bool,
    },
}

#[derive(Clone, Copy, Debug)]
pub(super) struct Vertex<'a> {
    pub kind: Kind,
    pub p: Vec3,
    /// A bound of `p`'s rounding error (zero for the camera, point lights and media).
    pub error: Vec3,
    /// Geometric normal (zero for the camera, point lights and media); at infinity the
    /// unit direction the light travels.
    pub n: Vec3,
    pub bsdf: Option<Bsdf<'a>>,
    /// Emitted radiance of the surface (for s = 0), with its emitter index.
    pub emission: Rgb,
    pub light: Option<usize>,
    pub beta: Rgb,
    /// Each channel's density of the subpath so far over its hero channel's (all ones
    /// without media): the spectral MIS of chromatic media divides by their average.
    pub r_u: Rgb,
    /// The medium the subpath reached the vertex in.
    pub medium: Option<u32>,
    /// The media on the two sides of the vertex's surface, if it bounds any.
    pub interface: Option<MediumInterface>,
    /// Scattered by a delta lobe.
    pub delta: bool,
    pub pdf_fwd: f32,
    pub pdf_rev: f32,
}

impl Vertex<'_> {
    pub fn new(kind: Kind, at: Spot, beta: Rgb) -> Self {
        Vertex {
            kind,
            p: at.p,
            error: at.error,
            n: at.n,
            bsdf: None,
            emission: Rgb::ZERO,
            light: None,
            beta,
            r_u: Rgb::ONE,
            medium: None,
            interface: None,
            delta: false,
            pdf_fwd: 0.0,
            pdf_rev: 0.0,
        }
    }

    /// Where connections to the vertex start and end.
    pub fn spot(&self) -> Spot {
        Spot {
            p: self.p,
            error: self.error,
            n: self.n,
        }
    }

    /// The medium a segment leaving the vertex along `w` travels in.
    pub fn medium_towards(&self, w: Vec3) -> Option<u32> {
        match self.interface {
            Some(interface) => interface.towards(w, self.n),
            None => self.medium,
        }
    }

    /// Whether a connection can end at the vertex (a light's start at infinity is reached
    /// only along its own direction, by the s = 1 strategy).
    pub fn connectible(&self) -> bool {
        match self.kind {
            Kind::Surface => self.bsdf.is_some_and(|b| b.has_non_delta()),
            Kind::Infinite { .. } => false,
            _ => true,
        }
    }

    pub fn is_infinite(&self) -> bool {
        matches!(self.kind, Kind::Infinite { .. })
    }

    /// A point light, or a directional light's start at infinity.
    pub fn is_delta_light(&self) -> bool {
        matches!(
            self.kind,
            Kind::Light { point: true, .. } | Kind::Infinite { delta: true, .. }
        )
    }

    /// The unit direction from this vertex to `to` (to or from a point at infinity, along
    /// the light's direction).
    pub fn dir_to(&self, to: &Vertex) -> Vec3 {
        if to.is_infinite() {
            -to.n
        } else if self.is_infinite() {
            self.n
        } else {
            (to.p - self.p).normalize()
        }
    }

    /// Converts a solid-angle density at this vertex towards `next` into an area density at
    /// `next` (a volume density for a point in a medium, which has no cosine). The
    /// transmittance between them is left out of every strategy's density alike. Towards a
    /// point at infinity the density stays in solid angle; from one, `pdf` is already a
    /// density over the plane the light crosses and only the cosine at `next` is applied.
    pub fn area_density(&self, pdf: f32, next: &Vertex) -> f32 {
        if next.is_infinite() {
            return pdf;
        }
        let (mut pdf, w) = if self.is_infinite() {
            (pdf, self.n)
        } else {
            let d = next.p - self.p;
            let dist2 = d.length_squared();
            if dist2 == 0.0 {
                return 0.0;
            }
            (pdf / dist2, d / dist2.sqrt())
        };
        if next.n != Vec3::ZERO {
            pdf *= next.n.dot(w).abs();
        }
        pdf
    }

    /// Area density at `next` of sampling it from this vertex (reached from `prev`).
    pub fn pdf(
        &self,
        ctx: &Context,
        camera: &CameraBasis,
        prev: Option<&Vertex>,
        next: &Vertex,
    ) -> f32 {
        let w = self.dir_to(next);
        let pdf = match (self.kind, prev) {
            (Kind::Camera, _) => camera_pdf_dir(camera, self.p, w),
            (Kind::Light { .. } | Kind::Infinite { .. }, _) => return self.pdf_light(ctx, next),
            (Kind::Surface, Some(prev)) => match self.bsdf {
                Some(b) => b.pdf(self.dir_to(prev), w),
                None => 0.0,
            },
            (Kind::Medium { g }, Some(prev)) => phase::hg(self.dir_to(prev), w, g),
            (_, None) => 0.0,
        };
        self.area_density(pdf, next)
    }

    /// Area density at `next` of a light path leaving this emitter vertex towards it (from
    /// infinity: uniform over the disk of the scene's bounding sphere the light crosses).
    pub fn pdf_light(&self, ctx: &Context, next: &Vertex) -> f32 {
        if self.is_infinite() {
            let r = ctx.lights.world.radius;
            return self.area_density(1.0 / (PI * r * r), next);
        }
        let w = self.dir_to(next);
        let pdf_dir = match self.kind {
            Kind::Light { light, point: true } => {
                ctx.lights.emitters[light].model().pdf_emission_direction(w)
            }
            _ => match self.area_light(ctx) {
                Some(a) if a.two_sided => 0.5 * w.dot(self.n).abs() / PI,
                _ => w.dot(self.n).max(0.0) / PI,
            },
        };
        self.area_density(pdf_dir, next)
    }

    /// The area light this vertex lies on (a light subpath's start or an emitter hit).
    pub fn area_light<'c>(&self, ctx: &'c Context) -> Option<&'c crate::scene::lights::AreaLight> {
        let light = match self.kind {
            Kind::Light { light, .. } => light,
            _ => self.light?,
        };
        match &ctx.lights.emitters[light] {
            Emitter::Area(a) => Some(a),
            _ => None,
        }
    }

    /// The emission cosine towards unit `w` from an area-light vertex: 0 behind a one-sided
    /// light, |cos| for a two-sided one.
    pub fn emitting_cos(&self, ctx: &Context, w: Vec3) -> f32 {
        let cos = w.dot(self.n);
        match self.area_light(ctx) {
            Some(a) => a.emitting_cos(cos),
            None => cos.max(0.0),
        }
    }

    /// Area density of choosing this emitter point when starting a light path; at infinity
    /// the solid-angle density of the background sending light along the vertex's direction
    /// (zero for a directional light, a delta).
    pub fn pdf_light_origin(&self, ctx: &Context) -> f32 {
        if let Kind::Infinite { light, delta } = self.kind {
            return match light {
                Some(i) if !delta => {
                    // Light subpaths choose their light by power; the vertex's normal is
                    // the direction the light travels.
                    let model = ctx.lights.emitters[i].model();
                    ctx.lights.pmf(i) * model.pdf_emission_direction(self.n)
                }
                _ => 0.0,
            };
        }
        let light = match self.kind {
            Kind::Light { light, .. } => light,
            _ => match self.light {
                Some(l) => l,
                None => return 0.0,
            },
        };
        match &ctx.lights.emitters[light] {
            Emitter::Area(a) => ctx.lights.pmf(light) / a.area,
            e if e.model().point_source().is_some() => ctx.lights.pmf(light),
            _ => 0.0,
        }
    }

    /// f·|cos| towards `next` (the connection step) for a surface vertex, the phase
    /// function's value for a point in a medium.
    pub fn f(&self, prev: Option<&Vertex>, next: &Vertex, mode: Transport) -> Rgb {
        let w = self.dir_to(next);
        match (self.kind, self.bsdf, prev) {
            (Kind::Surface, Some(b), Some(prev)) => b.eval(self.dir_to(prev), w, mode),
            (Kind::Medium { g }, _, Some(prev)) => Rgb::splat(phase::hg(self.dir_to(prev), w, g)),
            _ => Rgb::ZERO,
        }
    }
}
