//! An iteration's camera subpaths: each pixel sample follows its camera subpath and, at
//! every vertex whose BSDF is not purely specular, gathers light by every technique of
//! vertex connection and merging: emission it hits, next-event estimation, connections to
//! the vertices of one light subpath of the iteration, and merges with the light vertices
//! of every subpath within the merge radius (SmallVCM's camera loop).

use super::light_pass::{LightPaths, LightVertex};
use super::lights::{area_densities, background_densities, sample_towards};
use super::media::{advance, leave, link, Around, End, Leaving, Scatter, Spectral, Step};
use super::mis::{abs_cos, Subpath, Weights};
use crate::bsdf::{LambertianFrom, Transport};
use crate::integrators::camera_connection::camera_pdf_dir;
use crate::integrators::sppm::HashGrid;
use crate::integrators::volumetric::{average, hero_channel};
use crate::math::sobol::Sampler;
use crate::math::spawn::Spot;
use crate::math::{luminance, Ray, Rgb, Rng, Vec3};
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
    /// Whether camera vertices merge (the grid is empty if not).
    pub merges: bool,
    /// The luminance below which a connection's expected share is small enough to be
    /// left to Russian roulette before its shadow ray (0: every connection is traced).
    pub connection_threshold: f32,
}

/// A camera subpath's vertex, as the techniques at it see it.
struct CameraVertex<'v, 'a> {
    at: &'v Spot,
    wo: Vec3,
    scatter: &'v Scatter<'a>,
    around: Around,
    path: &'v Subpath,
    /// The scatterer seen from `wo` when it is a Lambertian surface.
    lambertian: Option<LambertianFrom>,
}

impl CameraVertex<'_, '_> {
    /// The scatterer's f·|cos| towards unit `wi` and its densities (forward, reverse), for
    /// radiance.
    #[inline(always)]
    fn eval_and_pdfs(&self, wi: Vec3) -> (Rgb, f32, f32) {
        match &self.lambertian {
            Some(l) => l.eval_and_pdfs(wi, Transport::Radiance),
            None => self.scatter.eval_and_pdfs(self.wo, wi, Transport::Radiance),
        }
    }

    /// The weights' merge factor at the vertex: η at a surface, 0 in a medium.
    fn vm(&self, w: &Weights) -> f32 {
        if self.scatter.mergeable() {
            w.vm
        } else {
            0.0
        }
    }
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
            r_u: Rgb::ONE,
            len: 1,
            d_vcm: self.paths_per_pixel / pdf_cam,
            d_vc: 0.0,
            d_vm: 0.0,
        };
        // The light subpath the camera subpath connects to: any of the iteration's, drawn
        // uniformly.
        let count = self.paths.starts.len() - 1;
        let light = ((sampler.next_1d() * count as f32) as usize).min(count.saturating_sub(1));
        let mut spectral = ctx.has_media().then(|| Spectral {
            hero: hero_channel(sampler),
            rng: sampler.stream(),
        });
        let media = spectral.is_some();
        let mut medium = ctx.scene.camera_medium;
        let mut ray = *ray;
        let mut radiance = Rgb::ZERO;
        loop {
            let origin = ray.origin;
            // The emission of media met on the way: its one strategy (no light subpath
            // starts in a volume), up to the most bounces.
            let mut glow = Rgb::ZERO;
            let glows = path.len < self.max_len;
            let step = advance(
                ctx,
                &ray,
                &mut medium,
                spectral.as_ref(),
                &mut path,
                (sampler, stats),
                glows.then_some(&mut glow),
            );
            radiance += glow;
            let wo = -ray.dir.normalize();
            let (sp, at, scatter, around) = match step {
                (Step::Ended, _) => break,
                (Step::Escaped, grey) => {
                    path.d_vcm /= grey;
                    let le = self.background(ctx, ray.dir.normalize(), &path);
                    radiance += path.weighted() * le;
                    break;
                }
                (Step::Surface(sp), grey) => {
                    let at = sp.spot();
                    let dist = (sp.p - origin).length();
                    path.arrive(dist, abs_cos(at.n, wo), false, grey);
                    let m = &ctx.scene.materials[sp.material];
                    if m.is_emissive() {
                        let light = sp.world_shape().and_then(|s| ctx.lights.light_of_shape(s));
                        if let Some(light) = light {
                            let le = m.emission_at(sp.p, sp.uv, sp.ng);
                            let le = self.emitted(ctx, light, le, &at, wo, &path);
                            radiance += path.weighted() * le;
                        }
                    }
                    if path.len >= self.max_len {
                        break;
                    }
                    let around = if media {
                        Around::surface(ctx, &sp, medium)
                    } else {
                        Around::default()
                    };
                    (Some(sp), at, Scatter::Surface(m.bsdf(&sp, wo)), around)
                }
                (Step::Medium { p, g }, grey) => {
                    path.arrive((p - origin).length(), 1.0, false, grey);
                    if path.len >= self.max_len {
                        break;
                    }
                    let around = Around {
                        medium,
                        interface: None,
                    };
                    (None, Spot::exact(p), Scatter::Medium { g }, around)
                }
            };
            if scatter.connectible() {
                let v = CameraVertex {
                    at: &at,
                    wo,
                    scatter: &scatter,
                    around,
                    path: &path,
                    lambertian: scatter.lambertian_from(wo),
                };
                let mut gathered = self.direct(ctx, &v, (sampler, spectral.as_mut()), stats);
                let mut rng = sampler.stream();
                for lv in self.paths.of(light) {
                    if lv.path.len + path.len + 1 > self.max_len {
                        break;
                    }
                    let c = self.connect(ctx, &v, lv, (spectral.as_mut(), &mut rng), stats);
                    gathered += lv.path.weighted() * c;
                }
                if self.merges && scatter.mergeable() {
                    gathered += self.merge(&v) * w.vm_normalization;
                }
                radiance += path.beta * gathered;
            }
            let v = Leaving {
                at,
                scatter: &scatter,
                sp: sp.as_ref(),
                around,
                wo,
            };
            let mode = (Transport::Radiance, media);
            let Some(next) = leave(&mut path, w, v, mode, &mut medium, sampler) else {
                break;
            };
            ray = next;
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
        (sampler, spectral): (&mut Sampler, Option<&mut Spectral>),
        stats: &mut RayStats,
    ) -> Rgb {
        let u_choose = sampler.next_1d();
        let u_pos = sampler.next_2d();
        if v.path.len + 1 > self.max_len {
            return Rgb::ZERO;
        }
        let Some((lp, wi, to)) = sample_towards(ctx, v.at.p, u_choose, u_pos, || sampler.next_2d())
        else {
            return Rgb::ZERO;
        };
        let (f, pdf_fwd, pdf_rev) = v.eval_and_pdfs(wi);
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
        let from = (v.at, v.around.towards(wi, v.at.n));
        let end = match &to {
            Some(q) => End::At(q),
            None => End::Towards(wi),
        };
        let Some((through, grey)) = link(ctx, from, end, v.path.r_u, spectral, stats) else {
            return Rgb::ZERO;
        };
        let pdf_dir = if lp.delta { 0.0 } else { pdf_fwd };
        let cos_to_light = v.scatter.cos(v.at.n, wi);
        let p = v.path;
        let w_light = pdf_dir * grey / direct_pdf_w;
        let w_camera = (lp.emission_pdf_w * cos_to_light / (direct_pdf_w * lp.cos_at_light))
            * grey
            * (v.vm(&self.weights) + p.d_vcm + p.d_vc * pdf_rev);
        let weight = 1.0 / (w_light + 1.0 + w_camera);
        lp.radiance * f * (weight / direct_pdf_w) * through
    }

    /// Camera vertex `v` connected to light vertex `lv` (without `lv`'s throughput). A
    /// connection whose share of the pixel, shadow ray aside, falls below the iteration's
    /// threshold plays Russian roulette with `rng` before its ray: most connections of a
    /// long camera subpath to a long light subpath add little and cost a ray each.
    fn connect(
        &self,
        ctx: &Context,
        v: &CameraVertex,
        lv: &LightVertex,
        (spectral, rng): (Option<&mut Spectral>, &mut Rng),
        stats: &mut RayStats,
    ) -> Rgb {
        let d = lv.at.p - v.at.p;
        let dist2 = d.length_squared();
        if dist2.is_nan() || dist2 <= 0.0 {
            return Rgb::ZERO;
        }
        let dir = d / dist2.sqrt();
        let (f_cam, cam_pdf_w, cam_rev) = v.eval_and_pdfs(dir);
        if f_cam == Rgb::ZERO {
            return Rgb::ZERO;
        }
        let (f_light, light_pdf_w, light_rev) = lv.eval_and_pdfs(-dir);
        if f_light == Rgb::ZERO {
            return Rgb::ZERO;
        }
        let (pl, pc) = (&lv.path, v.path);
        let vm_light = if lv.scatter.mergeable() {
            self.weights.vm
        } else {
            0.0
        };
        // The weight through grey transmittance `grey` across the segment.
        let weight = |grey: f32| {
            let cam_pdf_a = cam_pdf_w * lv.scatter.cos(lv.at.n, dir) / dist2 * grey;
            let light_pdf_a = light_pdf_w * v.scatter.cos(v.at.n, dir) / dist2 * grey;
            let w_light = cam_pdf_a * (vm_light + pl.d_vcm + pl.d_vc * light_rev);
            let w_camera = light_pdf_a * (v.vm(&self.weights) + pc.d_vcm + pc.d_vc * cam_rev);
            1.0 / (w_light + 1.0 + w_camera)
        };
        let clear = f_cam * f_light * (weight(1.0) / dist2);
        let share = luminance(pc.beta * pl.weighted() * clear);
        let Some(kept) = roulette(share, self.connection_threshold, rng) else {
            return Rgb::ZERO;
        };
        let from = (v.at, v.around.towards(dir, v.at.n));
        let end = End::At(&lv.at);
        let Some((through, grey)) = link(ctx, from, end, v.path.r_u, spectral, stats) else {
            return Rgb::ZERO;
        };
        let value = if grey == 1.0 {
            clear
        } else {
            f_cam * f_light * (weight(grey) / dist2)
        };
        value * through * kept
    }

    /// The merges at surface vertex `v`: every light vertex at a surface within the radius,
    /// weighted (before the kernel's normalisation).
    fn merge(&self, v: &CameraVertex) -> Rgb {
        let Scatter::Surface(bsdf) = v.scatter else {
            return Rgb::ZERO;
        };
        let mut sum = Rgb::ZERO;
        let n = bsdf.shading_normal();
        let (pc, w) = (v.path, &self.weights);
        self.grid.query(v.at.p, |k| {
            let lv = &self.paths.vertices[k];
            if lv.path.len + pc.len > self.max_len || !lv.scatter.mergeable() {
                return;
            }
            let wi = lv.wo;
            let cos = wi.dot(n).abs();
            if cos == 0.0 {
                return;
            }
            let (f, pdf_dir, pdf_rev) = bsdf.eval_and_pdfs(v.wo, wi, Transport::Radiance);
            if f == Rgb::ZERO {
                return;
            }
            let f = f / cos;
            let w_light = lv.path.d_vcm * w.vc + lv.path.d_vm * pdf_dir;
            let w_camera = pc.d_vcm * w.vc + pc.d_vm * pdf_rev;
            sum += f * lv.path.weighted() * (1.0 / (w_light + 1.0 + w_camera));
        });
        sum / average(pc.r_u)
    }
}

/// Russian roulette on a connection expected to add `share` (luminance) to its pixel:
/// below `threshold` it survives with probability share / threshold. The factor a
/// survivor is weighted by (1 when no roulette is played); `None` if it is dropped.
fn roulette(share: f32, threshold: f32, rng: &mut Rng) -> Option<f32> {
    // A share that is not a number is traced as any other.
    if share >= threshold || share.is_nan() {
        return Some(1.0);
    }
    let p = share / threshold;
    (rng.uniform() < p).then(|| 1.0 / p)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The roulette keeps a connection's expected value: the mean of its weights over many
    /// draws is 1 at any share, and a share at or above the threshold is always kept.
    #[test]
    fn roulette_keeps_the_expected_value() {
        let mut rng = Rng::for_key(7, &[1]);
        for share in [0.001_f32, 0.02, 0.3, 0.9] {
            let n = 200_000;
            let sum: f64 = (0..n)
                .map(|_| f64::from(roulette(share, 1.0, &mut rng).unwrap_or(0.0)))
                .sum();
            let mean = sum / n as f64;
            // Standard error sqrt((1/p - 1)/n): at p = 0.001 about 0.07; five of them.
            let tolerance = 5.0 * ((1.0 / f64::from(share) - 1.0) / n as f64).sqrt();
            assert!(
                (mean - 1.0).abs() < tolerance.max(1e-9),
                "share {share}: {mean}"
            );
        }
        assert_eq!(roulette(1.0, 1.0, &mut rng), Some(1.0));
        assert_eq!(roulette(0.5, 0.0, &mut rng), Some(1.0));
        assert_eq!(roulette(0.0, 1.0, &mut rng), None);
    }
}
