//! An iteration's camera subpaths: each pixel sample follows its camera subpath and, at
//! every vertex whose BSDF is not purely specular, gathers light by every technique of
//! vertex connection and merging: emission it hits, next-event estimation, connections to
//! the vertices of one light subpath of the iteration, and merges with the light vertices
//! of every subpath within the merge radius (SmallVCM's camera loop).

use super::light_pass::{LightPaths, LightVertex};
use super::lights::{area_densities, background_densities, sample_towards};
use super::mis::{abs_cos, Subpath, Weights};
use crate::bsdf::{Bsdf, Transport};
use crate::integrators::camera_connection::camera_pdf_dir;
use crate::integrators::sppm::HashGrid;
use crate::math::sobol::Sampler;
use crate::math::spawn::Spot;
use crate::math::{Ray, Rgb, Vec3};
use crate::scene::camera::CameraBasis;
use crate::transport::{Context, MonteCarlo, RayStats, Splat};

/// What the camera samples of one iteration share: its light subpaths, the grid over
/// their vertices and the weights' constants.
pub(super) struct Iteration<'a> {
    pub paths: LightPaths<'a>,
    pub grid: HashGrid,
    pub weights: Weights,
    pub max_len: u32,
    /// The light subpaths over the image's pixels.
    pub paths_per_pixel: f32,
}

/// A camera subpath's vertex, as the techniques at it see it.
struct CameraVertex<'v, 'a> {
    at: &'v Spot,
    wo: Vec3,
    bsdf: &'v Bsdf<'a>,
    path: &'v Subpath,
}

impl MonteCarlo for Iteration<'_> {
    fn sample(
        &self,
        ctx: &Context,
        camera: &CameraBasis,
        ray: &Ray,
        sampler: &mut Sampler,
        stats: &mut RayStats,
        _splats: &mut Vec<Splat>,
    ) -> Rgb {
        let w = &self.weights;
        let pdf_cam = camera_pdf_dir(camera, ray.origin, ray.dir.normalize());
        if pdf_cam.is_nan() || pdf_cam <= 0.0 {
            return Rgb::ZERO;
        }
        let mut path = Subpath {
            beta: Rgb::ONE,
            len: 1,
            d_vcm: self.paths_per_pixel / pdf_cam,
            d_vc: 0.0,
            d_vm: 0.0,
        };
        // The light subpath the camera subpath connects to: any of the iteration's, drawn
        // uniformly.
        let count = self.paths.starts.len() - 1;
        let light = ((sampler.next_1d() * count as f32) as usize).min(count.saturating_sub(1));
        let mut ray = *ray;
        let mut radiance = Rgb::ZERO;
        loop {
            let Some(sp) = ctx.intersect(&ray, stats) else {
                radiance += path.beta * self.background(ctx, ray.dir.normalize(), &path);
                break;
            };
            let wo = -ray.dir.normalize();
            let at = sp.spot();
            let dist = (sp.p - ray.origin).length();
            path.arrive(dist, abs_cos(at.n, wo), false);
            let m = &ctx.scene.materials[sp.material];
            if m.is_emissive() {
                let light = sp.world_shape().and_then(|s| ctx.lights.light_of_shape(s));
                if let Some(light) = light {
                    let le = m.emission_at(sp.p, sp.uv, sp.ng);
                    radiance += path.beta * self.emitted(ctx, light, le, &at, wo, &path);
                }
            }
            if path.len >= self.max_len {
                break;
            }
            let bsdf = m.bsdf(&sp, wo);
            if bsdf.has_non_delta() {
                let v = CameraVertex {
                    at: &at,
                    wo,
                    bsdf: &bsdf,
                    path: &path,
                };
                let mut gathered = self.direct(ctx, &v, sampler, stats);
                for lv in self.paths.of(light) {
                    if lv.path.len + path.len + 1 > self.max_len {
                        break;
                    }
                    gathered += lv.path.beta * self.connect(ctx, &v, lv, stats);
                }
                gathered += self.merge(&v) * w.vm_normalization;
                radiance += path.beta * gathered;
            }
            let Some(wi) = path.bounce(w, (&bsdf, wo, at.n), Transport::Radiance, sampler) else {
                break;
            };
            ray = sp.spawn(wi);
        }
        radiance
    }
}

impl Iteration<'_> {
    /// The background seen along unit `dir`, weighted against the techniques that sample
    /// it from the light side.
    fn background(&self, ctx: &Context, dir: Vec3, path: &Subpath) -> Rgb {
        let Some(light) = ctx.lights.background_light() else {
            return Rgb::ZERO;
        };
        let le = ctx.lights.background_radiance(dir);
        if path.len == 1 || le == Rgb::ZERO {
            return le;
        }
        let (direct, emission) = background_densities(ctx, light, -dir);
        le / (1.0 + direct * path.d_vcm + emission * path.d_vc)
    }

    /// Emission `le` of area light `light` hit at `at`, seen along `wo`, weighted.
    fn emitted(
        &self,
        ctx: &Context,
        light: usize,
        le: Rgb,
        at: &Spot,
        wo: Vec3,
        path: &Subpath,
    ) -> Rgb {
        let crate::scene::lights::Emitter::Area(a) = &ctx.lights.emitters[light] else {
            return Rgb::ZERO;
        };
        let cos = a.emitting_cos(at.n.dot(wo));
        if cos <= 0.0 || le == Rgb::ZERO {
            return Rgb::ZERO;
        }
        if path.len == 1 {
            return le;
        }
        let Some((direct, emission)) = area_densities(ctx, light, cos) else {
            return Rgb::ZERO;
        };
        le / (1.0 + direct * path.d_vcm + emission * path.d_vc)
    }

    /// Next-event estimation at `v`: a light point drawn as light subpaths start.
    fn direct(
        &self,
        ctx: &Context,
        v: &CameraVertex,
        sampler: &mut Sampler,
        stats: &mut RayStats,
    ) -> Rgb {
        let u_choose = sampler.next_1d();
        let u_pos = sampler.next_2d();
        let u_dir = sampler.next_2d();
        if v.path.len + 1 > self.max_len {
            return Rgb::ZERO;
        }
        let Some((lp, wi, to)) = sample_towards(ctx, v.at.p, u_choose, u_pos, u_dir) else {
            return Rgb::ZERO;
        };
        let f = v.bsdf.eval(v.wo, wi, Transport::Radiance);
        if f == Rgb::ZERO || lp.radiance == Rgb::ZERO {
            return Rgb::ZERO;
        }
        let direct_pdf_w = match to {
            Some(q) => lp.direct_pdf_a * (q.p - v.at.p).length_squared() / lp.cos_at_light,
            None => lp.direct_pdf_a,
        };
        if direct_pdf_w.is_nan() || direct_pdf_w <= 0.0 {
            return Rgb::ZERO;
        }
        let pdf_dir = if lp.delta { 0.0 } else { v.bsdf.pdf(v.wo, wi) };
        let pdf_rev = v.bsdf.pdf(wi, v.wo);
        let cos_to_light = abs_cos(v.at.n, wi);
        let p = v.path;
        let w_light = pdf_dir / direct_pdf_w;
        let w_camera = (lp.emission_pdf_w * cos_to_light / (direct_pdf_w * lp.cos_at_light))
            * (self.weights.vm + p.d_vcm + p.d_vc * pdf_rev);
        let weight = 1.0 / (w_light + 1.0 + w_camera);
        let occluded = match to {
            Some(q) => ctx.occluded(&v.at.spawn_to(&q), stats),
            None => ctx.intersect(&v.at.spawn(wi), stats).is_some(),
        };
        if occluded {
            return Rgb::ZERO;
        }
        lp.radiance * f * (weight / direct_pdf_w)
    }

    /// Camera vertex `v` connected to light vertex `lv` (without `lv`'s throughput).
    fn connect(
        &self,
        ctx: &Context,
        v: &CameraVertex,
        lv: &LightVertex,
        stats: &mut RayStats,
    ) -> Rgb {
        let d = lv.at.p - v.at.p;
        let dist2 = d.length_squared();
        if dist2.is_nan() || dist2 <= 0.0 {
            return Rgb::ZERO;
        }
        let dir = d / dist2.sqrt();
        let f_cam = v.bsdf.eval(v.wo, dir, Transport::Radiance);
        if f_cam == Rgb::ZERO {
            return Rgb::ZERO;
        }
        let f_light = lv.bsdf.eval(lv.wo, -dir, Transport::Importance);
        if f_light == Rgb::ZERO {
            return Rgb::ZERO;
        }
        let cam_pdf_a = v.bsdf.pdf(v.wo, dir) * abs_cos(lv.at.n, dir) / dist2;
        let cam_rev = v.bsdf.pdf(dir, v.wo);
        let light_pdf_a = lv.bsdf.pdf(lv.wo, -dir) * abs_cos(v.at.n, dir) / dist2;
        let light_rev = lv.bsdf.pdf(-dir, lv.wo);
        let (pl, pc, vm) = (&lv.path, v.path, self.weights.vm);
        let w_light = cam_pdf_a * (vm + pl.d_vcm + pl.d_vc * light_rev);
        let w_camera = light_pdf_a * (vm + pc.d_vcm + pc.d_vc * cam_rev);
        let weight = 1.0 / (w_light + 1.0 + w_camera);
        if ctx.occluded(&v.at.spawn_to(&lv.at), stats) {
            return Rgb::ZERO;
        }
        f_cam * f_light * (weight / dist2)
    }

    /// The merges at `v`: every light vertex within the radius, weighted (before the
    /// kernel's normalisation).
    fn merge(&self, v: &CameraVertex) -> Rgb {
        let mut sum = Rgb::ZERO;
        let n = v.bsdf.shading_normal();
        let (pc, w) = (v.path, &self.weights);
        self.grid.query(v.at.p, |k| {
            let lv = &self.paths.vertices[k];
            if lv.path.len + pc.len > self.max_len {
                return;
            }
            let wi = lv.wo;
            let cos = wi.dot(n).abs();
            if cos == 0.0 {
                return;
            }
            let f = v.bsdf.eval(v.wo, wi, Transport::Radiance) / cos;
            if f == Rgb::ZERO {
                return;
            }
            let pdf_dir = v.bsdf.pdf(v.wo, wi);
            let pdf_rev = v.bsdf.pdf(wi, v.wo);
            let w_light = lv.path.d_vcm * w.vc + lv.path.d_vm * pdf_dir;
            let w_camera = pc.d_vcm * w.vc + pc.d_vm * pdf_rev;
            sum += f * lv.path.beta * (1.0 / (w_light + 1.0 + w_camera));
        });
        sum
    }
}
