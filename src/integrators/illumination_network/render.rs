//! Rendering from a converged network (figure 6). An eye ray finds the patch it hits through
//! the intersection backend; the radiance toward the eye is
//!
//! - emission, for the front of an emitter (exact, not interpolated);
//! - the diffuse out-buffer, bilinearly interpolated: each corner of the hit patch takes the
//!   average of the (up to four) patches sharing it, and the hit point interpolates the four
//!   corners (figure 6 b, c);
//! - for directional patches, the out-buffers of the four slots bounding the eye direction,
//!   bilinearly interpolated in slope space (figure 6 a), for every patch of the
//!   8-neighbourhood before the spatial interpolation.
//!
//! Patches without a node on the side seen (no line reached them) are left out of the
//! averages. The image is a pure function of the network, its solution and the camera.

use super::distribute::Solution;
use super::{Network, NONE};
use crate::integrators::{Context, Integrator, RayStats, Sample};
use crate::math::{Ray, Rgb, Rng, Vec3};

pub struct NetworkRenderer<'a> {
    pub net: &'a Network,
    pub solution: &'a Solution,
}

impl NetworkRenderer<'_> {
    /// The reflected radiance of a node toward unit direction `wo` (leaving the node).
    fn node_radiance(&self, node: u32, wo: Vec3) -> Rgb {
        let sol = self.solution;
        let mut r = sol.diffuse[node as usize];
        let k = sol.dir_index[node as usize];
        if k == NONE {
            return r;
        }
        let space = &self.net.space;
        let slots = self.net.slots();
        let row = &sol.directional[k as usize * slots..(k as usize + 1) * slots];
        let links = self.net.row(node);
        let (f, su, sv) = space.slopes_of(wo);
        let (x, y) = (space.slope_coord(su), space.slope_coord(sv));
        let s = space.slopes as i32 - 1;
        let (x0, y0) = (x.floor() as i32, y.floor() as i32);
        let (fx, fy) = (x - x0 as f32, y - y0 as f32);
        let mut sum = Rgb::ZERO;
        let mut wsum = 0.0;
        for (dx, wx) in [(0, 1.0 - fx), (1, fx)] {
            for (dy, wy) in [(0, 1.0 - fy), (1, fy)] {
                let (ku, kv) = ((x0 + dx).clamp(0, s) as u32, (y0 + dy).clamp(0, s) as u32);
                let l = space.slot(f, ku, kv) as usize;
                let wgt = wx * wy;
                if links[l] != NONE && wgt > 0.0 {
                    sum += row[l] * wgt;
                    wsum += wgt;
                }
            }
        }
        if wsum > 0.0 {
            r += sum / wsum;
        }
        r
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
        // Values of the 4×4 block around the cell (cells i−1..=i+1), computed once.
        let mut value = [[None::<Rgb>; 3]; 3];
        for (a, row) in value.iter_mut().enumerate() {
            for (b, v) in row.iter_mut().enumerate() {
                let (ci, cj) = (i + a as i32 - 1, j + b as i32 - 1);
                if ci < 0 || cj < 0 || ci >= pg.ns as i32 || cj >= pg.nt as i32 {
                    continue;
                }
                let cell = pg.first_cell + ci as u32 * pg.nt + cj as u32;
                let node = self.net.node_of_key[(cell * 2 + side) as usize];
                if node != NONE {
                    *v = Some(self.node_radiance(node, wo));
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
        let mut sum = Rgb::ZERO;
        let mut wsum = 0.0;
        for (ca, wa) in [(0, 1.0 - fx), (1, fx)] {
            for (cb, wb) in [(0, 1.0 - fy), (1, fy)] {
                if let Some(v) = corner(ca, cb) {
                    sum += v * (wa * wb);
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
}

impl Integrator for NetworkRenderer<'_> {
    fn radiance(&self, ctx: &Context, ray: &Ray, _rng: &mut Rng, stats: &mut RayStats) -> Sample {
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
            let side = u32::from(pg.n.dot(wo) < 0.0);
            let m = &ctx.scene.materials[ctx.scene.shapes[hit.geom_id as usize].material];
            if side == 0 {
                radiance += m.emission * self.light_scale();
            }
            radiance += self.radiance_at(poly, p, side, wo);
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
