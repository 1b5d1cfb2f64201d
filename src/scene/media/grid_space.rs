//! What the grid media share: a box of samples placed in the world, trilinear lookups between
//! the samples (at the cells' centres, as pbrt-v4's `SampledGrid`), and a coarse grid of
//! majorants walked cell by cell along a ray (a 3D DDA), so that thin regions cost few null
//! collisions.

use super::{MediumProblem, Segment};
use crate::math::{Mat4, Ray, Rgb, Vec3};
use std::ops::{Add, Mul, Sub};

/// Samples a grid may hold (a 512³ grid: 512 MiB of densities).
pub const MAX_GRID_SAMPLES: usize = 512 * 512 * 512;

/// Cells of the majorant grid along each axis (pbrt-v4's choice).
pub(super) const MAJORANT_CELLS: usize = 16;

/// The samples whose interpolation reaches into majorant cell `c` along an axis of `n`
/// samples (one beyond its edges).
pub(super) fn cell_samples(c: usize, n: usize) -> std::ops::RangeInclusive<i64> {
    let (m, n) = (MAJORANT_CELLS as f32, n as f32);
    let a = ((c as f32 / m) * n - 0.5).floor() as i64;
    let b = (((c + 1) as f32 / m) * n - 0.5).floor() as i64 + 1;
    a..=b
}

/// A grid's samples placed in the world.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct GridSpace {
    /// Samples along x, y, z.
    pub(super) res: [usize; 3],
    /// The box the samples span, in the medium's own space.
    pub(super) lo: Vec3,
    pub(super) hi: Vec3,
    /// World to the medium's own space.
    to_medium: Mat4,
    /// The medium's own space to world.
    pub(super) to_world: Mat4,
}

fn problem(field: &'static str, message: impl Into<String>) -> MediumProblem {
    MediumProblem {
        field,
        message: message.into(),
    }
}

impl GridSpace {
    /// `res` samples over the box `lo`–`hi` of the medium's space, which `to_world` places.
    pub(super) fn new(
        res: [usize; 3],
        (lo, hi): (Vec3, Vec3),
        to_world: Mat4,
    ) -> Result<GridSpace, MediumProblem> {
        let n = res.iter().try_fold(1usize, |a, &r| a.checked_mul(r));
        if n.is_none_or(|n| n > MAX_GRID_SAMPLES) {
            return Err(problem(
                "resolution",
                format!(
                    "a grid of {}x{}x{} samples is more than raylink reads ({MAX_GRID_SAMPLES})",
                    res[0], res[1], res[2]
                ),
            ));
        }
        GridSpace::spanning(res, (lo, hi), to_world)
    }

    /// As [`GridSpace::new`], for a grid that does not hold its samples one by one (a sparse
    /// one): any number of them.
    pub(super) fn spanning(
        res: [usize; 3],
        (lo, hi): (Vec3, Vec3),
        to_world: Mat4,
    ) -> Result<GridSpace, MediumProblem> {
        if !(lo.is_finite() && hi.is_finite() && lo.cmplt(hi).all()) {
            return Err(problem(
                "bounds",
                "the grid's box p0-p1 must be finite with p0 < p1 on every axis",
            ));
        }
        let to_medium = to_world.inverse();
        if !to_world.is_finite() || !to_medium.is_finite() || to_world.determinant() == 0.0 {
            return Err(problem(
                "transform",
                "the medium's transform cannot be inverted",
            ));
        }
        Ok(GridSpace {
            res,
            lo,
            hi,
            to_medium,
            to_world,
        })
    }

    /// Samples in all.
    pub(super) fn len(&self) -> usize {
        self.res.iter().product()
    }

    /// The sample at integer coordinates, `zero` outside the grid.
    pub(super) fn sample<T: Copy>(&self, values: &[T], zero: T, x: i64, y: i64, z: i64) -> T {
        let res = self.res;
        let inside = |v: i64, n: usize| v >= 0 && (v as usize) < n;
        if !(inside(x, res[0]) && inside(y, res[1]) && inside(z, res[2])) {
            return zero;
        }
        values[(z as usize * res[1] + y as usize) * res[0] + x as usize]
    }

    /// `values` interpolated trilinearly at `u` (the box mapped to [0, 1]³), with samples at
    /// the cells' centres (pbrt-v4's `SampledGrid::Lookup`); `zero` beyond the samples.
    pub(super) fn lookup<T>(&self, values: &[T], zero: T, u: Vec3) -> T
    where
        T: Copy + Add<Output = T> + Sub<Output = T> + Mul<f32, Output = T>,
    {
        self.lookup_with(u, |x, y, z| self.sample(values, zero, x, y, z))
    }

    /// The samples `sample` gives (by integer coordinates) interpolated trilinearly at `u`,
    /// as [`GridSpace::lookup`].
    pub(super) fn lookup_with<T>(&self, u: Vec3, sample: impl Fn(i64, i64, i64) -> T) -> T
    where
        T: Copy + Add<Output = T> + Sub<Output = T> + Mul<f32, Output = T>,
    {
        let s = u * Vec3::new(self.res[0] as f32, self.res[1] as f32, self.res[2] as f32)
            - Vec3::splat(0.5);
        let f = s.floor();
        let d = s - f;
        let (x, y, z) = (f.x as i64, f.y as i64, f.z as i64);
        let at = |i, j, k| sample(x + i, y + j, z + k);
        let lerp = |a: T, b: T, t: f32| a + (b - a) * t;
        let y0 = lerp(
            lerp(at(0, 0, 0), at(1, 0, 0), d.x),
            lerp(at(0, 1, 0), at(1, 1, 0), d.x),
            d.y,
        );
        let y1 = lerp(
            lerp(at(0, 0, 1), at(1, 0, 1), d.x),
            lerp(at(0, 1, 1), at(1, 1, 1), d.x),
            d.y,
        );
        lerp(y0, y1, d.z)
    }

    /// A world point in the grid's unit box.
    pub(super) fn unit_coords(&self, p: Vec3) -> Vec3 {
        (self.to_medium.transform_point3(p) - self.lo) / (self.hi - self.lo)
    }

    /// Whether unit coordinates lie in the box (nothing lies outside it: the interpolation
    /// would reach half a cell beyond).
    pub(super) fn inside(u: Vec3) -> bool {
        u.cmpge(Vec3::ZERO).all() && u.cmple(Vec3::ONE).all()
    }

    /// The largest value of `at` within each majorant cell, per channel: every sample whose
    /// interpolation reaches into the cell (one sample beyond its edges).
    pub(super) fn majorants(&self, at: impl Fn(i64, i64, i64) -> Rgb) -> Vec<Rgb> {
        let m = MAJORANT_CELLS;
        let mut out = vec![Rgb::ZERO; m * m * m];
        let range = |c: usize, axis: usize| cell_samples(c, self.res[axis]);
        for cz in 0..m {
            for cy in 0..m {
                for cx in 0..m {
                    let mut max = Rgb::ZERO;
                    for z in range(cz, 2) {
                        for y in range(cy, 1) {
                            for x in range(cx, 0) {
                                max = max.max(at(x, y, z));
                            }
                        }
                    }
                    out[(cz * m + cy) * m + cx] = max;
                }
            }
        }
        out
    }

    /// Visits the stretches of `ray` within [0, `t_max`) that cross the box, cell by cell of
    /// the majorant grid (Amanatides & Woo), each bounded by `scale` times its cell's
    /// majorant; stops when `visit` returns false.
    pub(super) fn walk(
        &self,
        majorants: &[Rgb],
        scale: Rgb,
        ray: &Ray,
        t_max: f32,
        visit: &mut dyn FnMut(Segment) -> bool,
    ) {
        let m = MAJORANT_CELLS as f32;
        // The ray in majorant-grid coordinates ([0, m]³ over the box).
        let grid_scale = Vec3::splat(m) / (self.hi - self.lo);
        let o = (self.to_medium.transform_point3(ray.origin) - self.lo) * grid_scale;
        let d = self.to_medium.transform_vector3(ray.dir) * grid_scale;
        // Clip to the box.
        let (mut t0, mut t1) = (0.0f32, t_max);
        for a in 0..3 {
            let inv = 1.0 / d[a];
            let (mut near, mut far) = ((0.0 - o[a]) * inv, (m - o[a]) * inv);
            if near > far {
                std::mem::swap(&mut near, &mut far);
            }
            if near.is_nan() || far.is_nan() {
                // Parallel to this slab: inside it or never.
                if o[a] < 0.0 || o[a] > m {
                    return;
                }
                continue;
            }
            t0 = t0.max(near);
            t1 = t1.min(far);
        }
        if t0 >= t1 {
            return;
        }
        let start = o + d * t0;
        let mut cell = [0i64; 3];
        let mut next = [0f32; 3];
        let mut delta = [0f32; 3];
        let mut step = [0i64; 3];
        let mut end = [0i64; 3];
        for a in 0..3 {
            cell[a] = (start[a].floor() as i64).clamp(0, MAJORANT_CELLS as i64 - 1);
            if d[a] == 0.0 || !d[a].is_finite() {
                next[a] = f32::INFINITY;
                delta[a] = f32::INFINITY;
                step[a] = 0;
                end[a] = -1;
            } else if d[a] > 0.0 {
                next[a] = t0 + ((cell[a] + 1) as f32 - start[a]) / d[a];
                delta[a] = 1.0 / d[a];
                step[a] = 1;
                end[a] = MAJORANT_CELLS as i64;
            } else {
                next[a] = t0 + (cell[a] as f32 - start[a]) / d[a];
                delta[a] = -1.0 / d[a];
                step[a] = -1;
                end[a] = -1;
            }
        }
        let mut t = t0;
        loop {
            let a = if next[0] < next[1] && next[0] < next[2] {
                0
            } else if next[1] < next[2] {
                1
            } else {
                2
            };
            let exit = next[a].min(t1);
            let index = ((cell[2] as usize * MAJORANT_CELLS) + cell[1] as usize) * MAJORANT_CELLS
                + cell[0] as usize;
            if exit > t
                && !visit(Segment {
                    t0: t,
                    t1: exit,
                    sigma_maj: scale * majorants[index],
                })
            {
                return;
            }
            if next[a] >= t1 || step[a] == 0 {
                return;
            }
            t = exit;
            cell[a] += step[a];
            if cell[a] == end[a] {
                return;
            }
            next[a] += delta[a];
        }
    }
}
