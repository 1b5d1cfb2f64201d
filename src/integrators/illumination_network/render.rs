//! Rendering from a converged network (figure 6). An eye ray finds the patch it hits through
//! the intersection backend; the radiance toward the eye is
//!
//! - emission, for the front of an emitter (exact, not interpolated);
//! - the diffuse out-buffer, bilinearly interpolated: each corner of the hit patch takes the
//!   average of the (up to four) patches sharing it, and the hit point interpolates the four
//!   corners (figure 6 b, c);
//! - for directional patches, the radiance that arrived over the links around the mirror
//!   and refracted directions of the eye (bilinearly over the four bounding slots, figure 6 a,
//!   or under the glossy lobe), weighted by what the material's BSDF reflects and transmits
//!   toward the eye, for every patch of the 8-neighbourhood before the spatial interpolation.
//!
//! Patches without a node on the side seen (no line reached them) are left out of the
//! averages. The image is a pure function of the network, its solution and the camera.

use super::corners::Corners;
use super::distribute::{for_each_candidate, local, network_kd, Solution, Surface};
use super::lobe_albedo::{self, albedo_at, same_lobes, LobeAlbedo};
use super::ray_space::SlotGeometry;
use super::{Network, ESCAPE, NONE};
use crate::bsdf::{Ggx, Transport};
use crate::math::{luminance, Ray, Rgb, Rng, Vec2, Vec3};
use crate::transport::{Context, Integrator, RayStats, Sample};
use std::f32::consts::FRAC_1_PI;

/// A directional surface seen from one side (its geometric normal) and what its lobes reflect
/// and transmit toward one eye direction.
type AlbedoCache = Option<(Surface, Vec3, (Rgb, Rgb))>;

pub struct NetworkRenderer<'a> {
    pub net: &'a Network,
    pub solution: &'a Solution,
    /// Hybrid mode: the diffuse reflection of light coming straight from the emitters is
    /// computed per pixel with a light sample and a shadow ray; the network gives the rest.
    pub hybrid: bool,
    /// What is worked out once per solution (the same image, sooner), or `None` to work
    /// every pixel out from the patches and the ray space.
    pub tables: Option<&'a Tables>,
}

/// What rendering works out once per solution: the corner values of the all-diffuse
/// polygon sides and each slot's direction and étendue.
pub struct Tables {
    pub corners: Corners,
    pub slots: SlotGeometry,
    /// What each directional surface reflects and transmits toward the eye.
    pub albedo: Vec<LobeAlbedo>,
}

impl Tables {
    pub fn new(net: &Network, solution: &Solution, hybrid: bool) -> Tables {
        let sides = (0..net.nodes() as u32).map(|node| net.node_place(node).2);
        Tables {
            corners: Corners::new(net, solution, hybrid),
            slots: SlotGeometry::new(&net.space),
            albedo: lobe_albedo::tables(&solution.surfaces, sides),
        }
    }

    /// Bytes held.
    pub fn memory(&self) -> usize {
        self.corners.memory()
            + self.slots.memory()
            + self.albedo.iter().map(LobeAlbedo::memory).sum::<usize>()
    }
}

impl NetworkRenderer<'_> {
    /// The reflected radiance of a node toward unit direction `wo` (leaving the node).
    ///
    /// Directional parts are *gathered* from the radiance that arrived over the node's
    /// links: a mirror takes the incoming radiance at the reflected direction, interpolated
    /// over the linked slots among the four bounding it; a glossy lobe averages the incoming
    /// radiance of the linked slots under the lobe, weighted by lobe × étendue; transmission
    /// does the same with the other side's incoming radiance around the line through the
    /// surface (refracted, or −wo through a thin sheet). Each is weighted by what the BSDF
    /// reflects or transmits toward `wo`. Reading the
    /// out-buffer of the eye's slot instead (the paper) shows which slots of each small patch
    /// happen to have links, a blotchy pattern; the gather only averages over them.
    /// `cache` keeps the last directional surface's albedo toward `wo` (the patches around a
    /// hit usually share theirs).
    fn node_radiance(&self, node: u32, wo: Vec3, cache: &mut AlbedoCache) -> Rgb {
        let sol = self.solution;
        let mut r = sol.diffuse_radiance(node, self.hybrid);
        let k = sol.dir_index[node as usize];
        if k == NONE {
            return r;
        }
        // A mix's two parts, each weighted; a plain surface is one part of weight 1.
        for (weight, part) in sol.surfaces[node as usize].parts() {
            if part.has_own_lobes() {
                self.part_radiance(node, k, part, weight, wo, cache, &mut r);
            }
        }
        r
    }

    /// r += `weight` × what the own directional lobes of `sfc` (a part of node `node`'s
    /// surface, row `k`) send toward `wo` ([`NetworkRenderer::node_radiance`]).
    #[allow(clippy::too_many_arguments)]
    fn part_radiance(
        &self,
        node: u32,
        k: u32,
        sfc: &Surface,
        weight: f32,
        wo: Vec3,
        cache: &mut AlbedoCache,
        r: &mut Rgb,
    ) {
        let sol = self.solution;
        let net = self.net;
        let n = net.node_normal(node);
        let (_, _, side) = net.node_place(node);
        let ng = if side == 0 { n } else { -n };
        // What the lobes send toward the eye of light arriving on each side (Fresnel and a
        // metal's colour included); the light is gathered around the mirror and the refracted
        // directions of the eye.
        let (reflected, transmitted) = match cache {
            Some((s, m, albedo)) if same_lobes(s, sfc) && *m == ng => *albedo,
            _ => {
                let cos = n.dot(wo);
                let table = self
                    .tables
                    .and_then(|t| t.albedo.iter().find(|a| a.is_for(sfc, side)));
                let albedo = match table {
                    Some(t) => t.at(cos),
                    None => albedo_at(sfc, side, cos),
                };
                *cache = Some((sfc.clone(), ng, albedo));
                albedo
            }
        };
        let (reflected, transmitted) = (reflected * weight, transmitted * weight);
        if let (Some(table), true) = (&sfc.optics.brdf, reflected.max_element() > 0.0) {
            // A table may reflect anywhere: the whole hemisphere, under f itself.
            let bsdf = crate::bsdf::Bsdf::tabulated(table, n, n);
            let lobe = |wi: Vec3| luminance(bsdf.eval(wo, wi, Transport::Radiance));
            *r += reflected * self.gather_hemisphere(node, k, lobe);
            return;
        }
        if reflected.max_element() > 0.0 {
            let refl = 2.0 * n.dot(wo) * n - wo;
            *r += reflected
                * self.gather(node, k, refl, sfc.alpha, |wi| {
                    let ggx = Ggx::isotropic(sfc.alpha.max(1e-3));
                    let (ci, co) = (n.dot(wi), n.dot(wo));
                    if ci <= 0.0 || co <= 0.0 {
                        return 0.0;
                    }
                    let h = (wi + wo).normalize();
                    ggx.d(local(n.dot(h))) * ggx.g(local(co), local(ci)) / (4.0 * ci * co)
                });
        }
        if transmitted.max_element() > 0.0 {
            let twin = net.twin(node);
            // Light from the other side along the line through the surface.
            let (_, through) = sfc.directional_bsdf(ng, n).smooth_directions(wo);
            if let (Some(through), true) = (through, twin != NONE) {
                if sol.dir_index[twin as usize] != NONE {
                    let sigma2 = (sfc.alpha * sfc.alpha).max(1e-12);
                    *r += transmitted
                        * self.gather(
                            twin,
                            sol.dir_index[twin as usize],
                            through,
                            sfc.alpha,
                            |wi| {
                                let c = wi.dot(through).clamp(-1.0, 1.0);
                                let th = c.acos();
                                (-0.5 * th * th / sigma2).exp()
                            },
                        );
                }
            }
        }
        let twin = net.twin(node);
        if sfc.kdt.max_element() > 0.0 && twin != NONE && sol.dir_index[twin as usize] != NONE {
            // A translucent sheet: kdt × the cosine-weighted mean radiance arriving behind.
            let behind = net.node_normal(twin);
            let k = sol.dir_index[twin as usize];
            *r += sfc.kdt * weight * self.gather_hemisphere(twin, k, |wi| wi.dot(behind));
        }
    }

    /// Incoming radiance of directional node `node` (row `k`) around direction `centre`
    /// (pointing away from the node), as seen through a lobe of width `alpha`.
    fn gather(
        &self,
        node: u32,
        k: u32,
        centre: Vec3,
        alpha: f32,
        lobe: impl Fn(Vec3) -> f32,
    ) -> Rgb {
        let net = self.net;
        let space = &net.space;
        let (row, links) = self.rows(k);
        let n = net.node_normal(node);
        let mut sum = Rgb::ZERO;
        let mut wsum = 0.0;
        if alpha <= 0.5 * space.slope_step() {
            for (l, wgt) in space.bounding_slots(centre) {
                if links[l as usize] < ESCAPE && wgt > 0.0 {
                    sum += row[l as usize] * wgt;
                    wsum += wgt;
                }
            }
        } else {
            let radius = ((3.0 * alpha * space.slopes as f32 / 2.0).ceil() as i64 + 1)
                .min(space.slopes as i64);
            for_each_candidate(space, centre, radius, |l| {
                if links[l as usize] < ESCAPE {
                    let (wi, etendue) = match self.tables {
                        Some(t) => (t.slots.direction_towards(l, n), t.slots.etendue(l)),
                        None => (space.direction_towards(l, n), space.etendue(l)),
                    };
                    let wgt = lobe(wi) * etendue;
                    if wgt > 0.0 && wgt.is_finite() {
                        sum += row[l as usize] * wgt;
                        wsum += wgt;
                    }
                }
            });
        }
        weighted_mean(sum, wsum)
    }

    /// The incoming radiance and the links of directional row `k`, per slot.
    fn rows(&self, k: u32) -> (&[Rgb], &[u32]) {
        let slots = self.net.slots();
        let range = k as usize * slots..(k as usize + 1) * slots;
        (
            &self.solution.incoming[range.clone()],
            &self.solution.dir_rows[range],
        )
    }

    /// Incoming radiance of directional node `node` (row `k`) over its whole hemisphere,
    /// weighted by `lobe(wi)` (f·cos θi) and each slot's solid angle.
    fn gather_hemisphere(&self, node: u32, k: u32, lobe: impl Fn(Vec3) -> f32) -> Rgb {
        let space = &self.net.space;
        let (row, links) = self.rows(k);
        let n = self.net.node_normal(node);
        let ds = space.slope_step();
        let (mut sum, mut wsum) = (Rgb::ZERO, 0.0);
        for l in 0..row.len() as u32 {
            if links[l as usize] < ESCAPE {
                let d = space.direction(l);
                let solid_angle = ds * ds / d.length_squared().powf(1.5);
                let wgt = lobe(space.direction_towards(l, n)) * solid_angle;
                if wgt > 0.0 && wgt.is_finite() {
                    sum += row[l as usize] * wgt;
                    wsum += wgt;
                }
            }
        }
        weighted_mean(sum, wsum)
    }

    /// Reflected radiance toward the eye at unit-space point `p` of polygon `poly`, side
    /// `side`, leaving in direction `wo`.
    pub fn radiance_at(&self, poly: u32, p: Vec3, side: u32, wo: Vec3) -> Rgb {
        let pg = &self.net.patches.polygons[poly as usize];
        let (s, t) = pg.st(p);
        let (x, y) = (
            (s * pg.ns as f32).clamp(0.0, pg.ns as f32),
            (t * pg.nt as f32).clamp(0.0, pg.nt as f32),
        );
        let (i, j) = (
            (x as u32).min(pg.ns - 1) as i32,
            (y as u32).min(pg.nt - 1) as i32,
        );
        let (fx, fy) = (x - i as f32, y - j as f32);
        if let Some(c) = self
            .tables
            .and_then(|t| t.corners.of_patch(self.net, poly, side, i as u32, j as u32))
        {
            return bilinear([[c[0], c[1]], [c[2], c[3]]], fx, fy);
        }
        // Values of the 4×4 block around the cell (cells i−1..=i+1), computed once.
        let mut value = [[None::<Rgb>; 3]; 3];
        let mut cache = None;
        for (a, row) in value.iter_mut().enumerate() {
            for (b, v) in row.iter_mut().enumerate() {
                let (ci, cj) = (i + a as i32 - 1, j + b as i32 - 1);
                if ci < 0 || cj < 0 || ci >= pg.ns as i32 || cj >= pg.nt as i32 {
                    continue;
                }
                let cell = pg.first_cell + ci as u32 * pg.nt + cj as u32;
                let node = self.net.node_of_key[(cell * 2 + side) as usize];
                if node != NONE {
                    *v = Some(self.node_radiance(node, wo, &mut cache));
                }
            }
        }
        // Corner (ca, cb) of the hit cell averages the cells sharing it.
        let corner = |ca: usize, cb: usize| {
            let mut sum = Rgb::ZERO;
            let mut n = 0;
            for row in &value[ca..ca + 2] {
                for v in row[cb..cb + 2].iter().flatten() {
                    sum += *v;
                    n += 1;
                }
            }
            (n > 0).then(|| sum / n as f32)
        };
        bilinear(
            [[corner(0, 0), corner(0, 1)], [corner(1, 0), corner(1, 1)]],
            fx,
            fy,
        )
    }
}

/// The bilinear interpolation of a patch's corners at (fx, fy), over the corners that have
/// a value.
#[inline]
fn bilinear(corners: [[Option<Rgb>; 2]; 2], fx: f32, fy: f32) -> Rgb {
    let mut sum = Rgb::ZERO;
    let mut wsum = 0.0;
    for (row, wa) in corners.iter().zip([1.0 - fx, fx]) {
        for (v, wb) in row.iter().zip([1.0 - fy, fy]) {
            if let Some(v) = v {
                sum += *v * (wa * wb);
                wsum += wa * wb;
            }
        }
    }
    if wsum > 0.0 {
        sum / wsum
    } else {
        Rgb::ZERO
    }
}

impl Integrator for NetworkRenderer<'_> {
    fn radiance(&self, ctx: &Context, ray: &Ray, rng: &mut Rng, stats: &mut RayStats) -> Sample {
        let Some(hit) = ctx.intersect_hit(ray, stats) else {
            return Sample {
                radiance: ctx.lights.background_radiance(ray.dir),
                object: u32::MAX,
            };
        };
        let net = self.net;
        let p = net.space.to_unit(ray.at(hit.t));
        let wo = -ray.dir.normalize();
        let mut radiance = Rgb::ZERO;
        if let Some((poly, _)) = net.patches.locate(hit.geom_id, hit.prim_id, p) {
            let pg = &net.patches.polygons[poly as usize];
            let side = u32::from(pg.normal_at(p).dot(wo) < 0.0);
            let m = &ctx.scene.materials[ctx.scene.shapes[hit.geom_id as usize].material];
            if side == 0 || m.two_sided_emission {
                radiance += m.emission * self.light_scale();
            }
            radiance += self.radiance_at(poly, p, side, wo);
            if self.hybrid {
                radiance += direct_diffuse(ctx, ray, &hit, rng, stats);
            }
        }
        Sample {
            radiance,
            object: hit.geom_id,
        }
    }
}

impl NetworkRenderer<'_> {
    /// The emission scale the solution was computed with (relighting).
    fn light_scale(&self) -> f32 {
        self.solution.light_scale
    }
}

/// sum / wsum, zero without weight.
fn weighted_mean(sum: Rgb, wsum: f32) -> Rgb {
    if wsum > 0.0 {
        sum / wsum
    } else {
        Rgb::ZERO
    }
}

/// The diffuse reflection of direct light at a hit: one light sample, one shadow ray
/// (kd/π · Le · cosθ / pdf), with kd as the network has it (scaled to kd + ks + kt ≤ 1, a
/// mix's blend).
fn direct_diffuse(
    ctx: &Context,
    ray: &Ray,
    hit: &crate::accel::Hit,
    rng: &mut Rng,
    stats: &mut RayStats,
) -> Rgb {
    let sp = hit.surface_point(ctx.scene, ray);
    let kd = network_kd(ctx.scene, sp.material, sp.p, sp.uv, sp.ng);
    if kd == Rgb::ZERO {
        return Rgb::ZERO;
    }
    let (u, v, w) = (rng.uniform(), rng.uniform(), rng.uniform());
    let Some(ls) = ctx.lights.sample_li(sp.p, u, Vec2::new(v, w)) else {
        return Rgb::ZERO;
    };
    let n = if sp.ng.dot(ray.dir) < 0.0 {
        sp.ng
    } else {
        -sp.ng
    };
    let cos = n.dot(ls.wi);
    if cos <= 0.0 || ls.pdf <= 0.0 {
        return Rgb::ZERO;
    }
    let shadow = sp.spot().spawn_to(&ls.spot());
    if ctx.occluded(&shadow, stats) {
        return Rgb::ZERO;
    }
    kd * FRAC_1_PI * ls.radiance * (cos / ls.pdf)
}
