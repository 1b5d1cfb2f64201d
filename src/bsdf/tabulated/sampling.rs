//! Importance sampling of a tabulated BRDF, built once when the table is made.
//!
//! A direction is sampled given another one (the outgoing direction in radiance transport,
//! the incident one in importance transport). `Bsdf::pdf` takes no transport mode, so the
//! sampled density must not depend on it: the structure follows the symmetrised table
//! g(x, y) = ½ (f(x → y) + f(y → x)), which is f itself for a reciprocal table and serves
//! both modes of a table that is not. For each row of given angles (θ, and φ for an
//! anisotropic table, at the table's grid angles of either argument) it holds a
//! piecewise-constant distribution over the sampled direction's cells in (θ, φ relative to
//! the given φ), proportional to g·cos θ over each cell's solid angle: a marginal over the θ
//! cells and a conditional over the φ cells of each (as pbrt-v3's and Mitsuba's tabulated
//! BSDFs). Within a cell the direction is uniform in solid angle. For a given direction
//! between rows one of the bracketing rows is chosen with probability equal to its
//! interpolation weight, so the density is the weighted sum of the rows' densities.

use super::{clamped, wrapped, TabulatedBrdf};
use crate::math::{luminance, Vec3};
use rayon::prelude::*;
use std::f32::consts::{FRAC_PI_2, TAU};

/// Cells of the sampled direction for an isotropic table: 1° in θ, 2° in φ.
const CELLS: (usize, usize) = (90, 180);
/// At most this many cells over all rows (an anisotropic table has many rows): the cells
/// are made coarser until they fit.
const CELL_BUDGET: usize = 2 << 20;

/// The sampling structure of one table.
#[derive(Debug, PartialEq)]
pub(super) struct Sampler {
    /// The given direction's θ at the rows, radians, increasing.
    rows_theta: Vec<f32>,
    /// The given direction's φ at the rows, radians, increasing: `[0]` for an isotropic
    /// table, whose rows hold for every φ.
    rows_phi: Vec<f32>,
    /// Cells of the sampled direction in θ and in φ relative to the given direction.
    n_theta: usize,
    n_phi: usize,
    /// θ rows slowest.
    rows: Vec<Row>,
}

/// The distribution of the sampled direction for one given direction.
#[derive(Debug, PartialEq)]
struct Row {
    /// Cumulative probability of the θ cells: `n_theta + 1` entries from 0 to 1.
    marginal: Vec<f32>,
    /// Per θ cell, the cumulative probability of its φ cells: `n_phi + 1` entries each.
    conditional: Vec<f32>,
    /// Density in solid angle of each cell, φ fastest.
    density: Vec<f32>,
}

impl Sampler {
    /// The structure for `table`; `None` for a constant table, which the cosine samples
    /// exactly.
    pub(super) fn build(table: &TabulatedBrdf) -> Option<Sampler> {
        let first = table.values[0];
        if table.values.iter().all(|v| *v == first) {
            return None;
        }
        let isotropic = table.axes[1].len() == 1;
        let rows_theta = merged(&table.axes[0], &table.axes[2]);
        let rows_phi = if isotropic {
            vec![0.0]
        } else {
            merged(&table.axes[1], &table.axes[3])
        };
        let row_count = rows_theta.len() * rows_phi.len();
        let (mut n_theta, mut n_phi) = CELLS;
        while row_count * n_theta * n_phi > CELL_BUDGET && n_theta > 9 {
            n_theta /= 2;
            n_phi /= 2;
        }
        let given: Vec<(f32, f32)> = rows_theta
            .iter()
            .flat_map(|&t| rows_phi.iter().map(move |&p| (t, p)))
            .collect();
        // Rows are independent: built in parallel, collected in order (deterministic).
        let rows = given
            .par_iter()
            .map(|&(t, p)| Row::build(table, direction(t, p), p, n_theta, n_phi))
            .collect();
        Some(Sampler {
            rows_theta,
            rows_phi,
            n_theta,
            n_phi,
            rows,
        })
    }

    /// The rows for a given local direction and their probabilities (at most four).
    fn rows_of(&self, given: Vec3) -> impl Iterator<Item = (usize, f32)> + '_ {
        let (t, p) = super::angles(given);
        let pt = clamped(&self.rows_theta, t);
        let pp = wrapped(&self.rows_phi, p);
        let np = self.rows_phi.len();
        (0..4).filter_map(move |corner| {
            let (i, wi) = pt[corner & 1];
            let (j, wj) = pp[corner >> 1];
            let w = wi * wj;
            (w > 0.0).then_some((i * np + j, w))
        })
    }

    /// A direction sampled given local direction `given` (upper hemisphere): `u_row` picks
    /// a row, `u` the direction in it.
    pub(super) fn sample(&self, given: Vec3, u_row: f32, u: [f32; 2]) -> Vec3 {
        let mut chosen = None;
        let mut sum = 0.0;
        for (r, w) in self.rows_of(given) {
            chosen = Some(r);
            sum += w;
            if u_row < sum {
                break;
            }
        }
        // The weights sum to 1 up to rounding: the last row takes what rounding leaves.
        let row = &self.rows[chosen.unwrap_or(0)];
        let (i, s) = pick(&row.marginal, u[0]);
        let conditional = &row.conditional[i * (self.n_phi + 1)..(i + 1) * (self.n_phi + 1)];
        let (j, r) = pick(conditional, u[1]);
        let (z0, z1) = self.cell_cos(i);
        let z = z0 + (z1 - z0) * s;
        let phi = (j as f32 + r) * (TAU / self.n_phi as f32) + super::angles(given).1;
        let sin = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(sin * phi.cos(), sin * phi.sin(), z)
    }

    /// The density in solid angle with which [`Sampler::sample`] gives `sampled` for
    /// `given`.
    pub(super) fn pdf(&self, given: Vec3, sampled: Vec3) -> f32 {
        if sampled.z <= 0.0 {
            return 0.0;
        }
        let (ts, ps) = super::angles(sampled);
        let relative = (ps - super::angles(given).1).rem_euclid(TAU);
        let i = ((ts / (FRAC_PI_2 / self.n_theta as f32)) as usize).min(self.n_theta - 1);
        let j = ((relative / (TAU / self.n_phi as f32)) as usize).min(self.n_phi - 1);
        self.rows_of(given)
            .map(|(r, w)| w * self.rows[r].density[i * self.n_phi + j])
            .sum()
    }

    /// cos θ at the lower and upper θ edges of cell `i` (decreasing).
    fn cell_cos(&self, i: usize) -> (f32, f32) {
        let d = FRAC_PI_2 / self.n_theta as f32;
        let z0 = (i as f32 * d).cos();
        // The last edge is the horizon exactly.
        let z1 = if i + 1 == self.n_theta {
            0.0
        } else {
            ((i + 1) as f32 * d).cos()
        };
        (z0, z1)
    }
}

impl Row {
    /// The row for given local direction `given` (at azimuth `phi`).
    fn build(table: &TabulatedBrdf, given: Vec3, phi: f32, n_theta: usize, n_phi: usize) -> Row {
        let (dt, dp) = (
            (FRAC_PI_2 / n_theta as f32) as f64,
            (TAU / n_phi as f32) as f64,
        );
        // Weight of each cell: g·cos θ at its centre times its solid angle.
        let mut weights = vec![0.0f64; n_theta * n_phi];
        let mut solid = vec![0.0f64; n_theta];
        for i in 0..n_theta {
            let (t0, t1) = (i as f64 * dt, (i + 1) as f64 * dt);
            solid[i] = (t0.cos() - t1.cos()) * dp;
            let tc = (t0 + t1) * 0.5;
            for j in 0..n_phi {
                let pc = phi + ((j as f64 + 0.5) * dp) as f32;
                let y = direction(tc as f32, pc);
                let g = 0.5 * luminance(table.eval(given, y) + table.eval(y, given));
                weights[i * n_phi + j] = g.max(0.0) as f64 * tc.cos() * solid[i];
            }
        }
        let mut total: f64 = weights.iter().sum();
        if total <= 0.0 {
            // Nothing reflected for this direction: a cosine-like row keeps the density
            // defined (the table's value is 0 there, so its samples carry no weight).
            for i in 0..n_theta {
                let tc = (i as f64 + 0.5) * dt;
                for j in 0..n_phi {
                    weights[i * n_phi + j] = tc.cos() * solid[i];
                }
            }
            total = weights.iter().sum();
        }
        let mut marginal = Vec::with_capacity(n_theta + 1);
        let mut conditional = Vec::with_capacity(n_theta * (n_phi + 1));
        let mut density = Vec::with_capacity(n_theta * n_phi);
        let mut before = 0.0f64;
        marginal.push(0.0);
        for i in 0..n_theta {
            let cells = &weights[i * n_phi..(i + 1) * n_phi];
            let ring: f64 = cells.iter().sum();
            before += ring;
            marginal.push((before / total) as f32);
            let mut along = 0.0f64;
            conditional.push(0.0);
            for (j, w) in cells.iter().enumerate() {
                along += w;
                // A ring with no weight is never chosen; keep its cdf increasing anyway.
                let c = if ring > 0.0 {
                    along / ring
                } else {
                    (j + 1) as f64 / n_phi as f64
                };
                conditional.push(c as f32);
            }
            *conditional.last_mut().unwrap() = 1.0;
        }
        *marginal.last_mut().unwrap() = 1.0;
        // The density from the stored cdfs themselves: exactly what sampling them draws.
        for i in 0..n_theta {
            let p_ring = (marginal[i + 1] - marginal[i]) as f64;
            let c = &conditional[i * (n_phi + 1)..(i + 1) * (n_phi + 1)];
            for j in 0..n_phi {
                density.push((p_ring * (c[j + 1] - c[j]) as f64 / solid[i]) as f32);
            }
        }
        Row {
            marginal,
            conditional,
            density,
        }
    }
}

/// The cell of a cumulative distribution `cdf` (first entry 0, last 1) that `u` in [0, 1)
/// falls in, and where within it (in [0, 1)); cells of zero probability are never chosen.
fn pick(cdf: &[f32], u: f32) -> (usize, f32) {
    let n = cdf.len() - 1;
    let i = cdf.partition_point(|&c| c <= u).clamp(1, n) - 1;
    let width = cdf[i + 1] - cdf[i];
    let s = if width > 0.0 {
        ((u - cdf[i]) / width).clamp(0.0, 1.0 - f32::EPSILON)
    } else {
        0.5
    };
    (i, s)
}

/// The angles of two axes together, increasing, each once.
fn merged(a: &[f32], b: &[f32]) -> Vec<f32> {
    let mut all: Vec<f32> = a.iter().chain(b).copied().collect();
    all.sort_by(f32::total_cmp);
    all.dedup_by(|x, y| (*x - *y).abs() < 1e-6);
    all
}

/// The local direction at angles (θ, φ).
fn direction(theta: f32, phi: f32) -> Vec3 {
    let s = theta.sin();
    Vec3::new(s * phi.cos(), s * phi.sin(), theta.cos().max(0.0))
}
