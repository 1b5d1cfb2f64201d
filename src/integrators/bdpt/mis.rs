//! The multiple importance sampling weight of one bidirectional strategy, from the forward
//! and reverse densities of every vertex of the path it made (pbrt's `MISWeight`, power
//! heuristic).

use super::vertex::Vertex;
use crate::scene::camera::CameraBasis;
use crate::transport::Context;

fn remap0(x: f32) -> f32 {
    if x != 0.0 {
        x
    } else {
        1.0
    }
}

/// The strategy (s, t): the path made of the light subpath's first `s` vertices connected to
/// the camera subpath's first `t`.
#[derive(Clone, Copy)]
pub(super) struct Connection<'p, 'a> {
    pub light: &'p [Vertex<'a>],
    pub camera: &'p [Vertex<'a>],
    pub s: usize,
    pub t: usize,
}

impl Connection<'_, '_> {
    /// The multiple importance sampling weight of the strategy for the path made of
    /// `light[..s]` and `camera[..t]`, with `sampled` replacing the connection vertex that
    /// strategy sampled anew (the camera for t = 1).
    pub fn mis_weight(&self, ctx: &Context, camera_basis: &CameraBasis) -> f32 {
        let Connection {
            light,
            camera,
            s,
            t,
        } = *self;
        if s + t == 2 {
            return 1.0;
        }
        let mut lv: Vec<Vertex> = light[..s].to_vec();
        let mut cv: Vec<Vertex> = camera[..t].to_vec();
        // The connection vertices are connected, so not delta for this strategy.
        if s > 0 {
            lv[s - 1].delta = false;
        }
        if t > 0 {
            cv[t - 1].delta = false;
        }
        // Reverse densities of the connection vertices and their predecessors.
        if t > 0 {
            let pt = cv[t - 1];
            let pt_minus = if t > 1 { Some(cv[t - 2]) } else { None };
            cv[t - 1].pdf_rev = if s > 0 {
                let qs_minus = if s > 1 { Some(&lv[s - 2]) } else { None };
                lv[s - 1].pdf(ctx, camera_basis, qs_minus, &pt)
            } else {
                pt.pdf_light_origin(ctx)
            };
            if let Some(ptm) = pt_minus {
                cv[t - 2].pdf_rev = if s > 0 {
                    pt.pdf(ctx, camera_basis, Some(&lv[s - 1]), &ptm)
                } else {
                    pt.pdf_light(ctx, &ptm)
                };
            }
        }
        if s > 0 {
            let qs = lv[s - 1];
            let pt = cv[t - 1];
            let pt_minus = if t > 1 { Some(&cv[t - 2]) } else { None };
            lv[s - 1].pdf_rev = pt.pdf(ctx, camera_basis, pt_minus, &qs);
            if s > 1 {
                let qsm = lv[s - 2];
                lv[s - 2].pdf_rev = qs.pdf(ctx, camera_basis, Some(&pt), &qsm);
            }
        }
        let mut sum = 0.0f32;
        let mut r = 1.0f32;
        for i in (1..t).rev() {
            r *= remap0(cv[i].pdf_rev) / remap0(cv[i].pdf_fwd);
            if !cv[i].delta && !cv[i - 1].delta {
                sum += r * r;
            }
        }
        r = 1.0;
        for i in (0..s).rev() {
            r *= remap0(lv[i].pdf_rev) / remap0(lv[i].pdf_fwd);
            let delta_before = if i > 0 {
                lv[i - 1].delta
            } else {
                lv[0].is_delta_light()
            };
            if !lv[i].delta && !delta_before {
                sum += r * r;
            }
        }
        1.0 / (1.0 + sum)
    }
}
