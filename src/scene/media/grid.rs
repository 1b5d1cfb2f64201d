//! A medium whose density varies over a box: a grid of density samples, interpolated
//! trilinearly, scaling one absorption and scattering (pbrt-v4's `uniformgrid`). Rays cross
//! it through a coarse grid of majorants (the largest density each cell can take), walked
//! cell by cell (a 3D DDA), so that thin regions cost few null collisions.

use super::{check_coefficients, check_g, MediumModel, MediumPoint, Segment};
use crate::math::{Mat4, Ray, Vec3};

/// Density samples a grid may hold (a 512³ grid: 512 MiB of densities).
pub const MAX_GRID_SAMPLES: usize = 512 * 512 * 512;

/// Cells of the majorant grid along each axis (pbrt-v4's choice).
const MAJORANT_CELLS: usize = 16;

#[derive(Clone, Debug, PartialEq)]
pub struct UniformGrid {
    /// Coefficients and emission at density 1.
    unit: MediumPoint,
    /// Samples along x, y, z.
    res: [usize; 3],
    /// Density samples, x fastest.
    density: Vec<f32>,
    /// Emission scale samples (pbrt-v4's `Lescale`), the same layout; `None`: 1 everywhere.
    le_scale: Option<Vec<f32>>,
    /// The box the samples span, in the medium's own space.
    lo: Vec3,
    hi: Vec3,
    /// World to the medium's own space.
    to_medium: Mat4,
    /// The medium's own space to world.
    to_world: Mat4,
    /// The largest density of each majorant cell, x fastest.
    majorants: Vec<f32>,
}

impl UniformGrid {
    /// A grid of `res` density samples spanning the box `lo`–`hi` of the medium's own space
    /// (`to_world` places it in the world), with the coefficients of `unit` at density 1.
    /// The message names the value out of range.
    pub fn new(
        unit: MediumPoint,
        res: [usize; 3],
        density: Vec<f32>,
        le_scale: Option<Vec<f32>>,
        (lo, hi): (Vec3, Vec3),
        to_world: Mat4,
    ) -> Result<UniformGrid, String> {
        check_coefficients(&[
            ("sigma_a", unit.sigma_a),
            ("sigma_s", unit.sigma_s),
            ("Le", unit.le),
        ])?;
        check_g(unit.g)?;
        let n = res.iter().try_fold(1usize, |a, &r| a.checked_mul(r));
        if n.is_none_or(|n| n > MAX_GRID_SAMPLES) {
            return Err(format!(
                "a grid of {}x{}x{} samples is more than raylink reads ({MAX_GRID_SAMPLES})",
                res[0], res[1], res[2]
            ));
        }
        if res.contains(&0) || n != Some(density.len()) {
            return Err(format!(
                "density has {} values; expected nx*ny*nz = {}x{}x{}",
                density.len(),
                res[0],
                res[1],
                res[2]
            ));
        }
        if let Some(i) = density.iter().position(|d| !d.is_finite() || *d < 0.0) {
            return Err(format!(
                "density value {} is {}: densities must be finite and not negative",
                i + 1,
                density[i]
            ));
        }
        if let Some(s) = &le_scale {
            if s.len() != density.len() || s.iter().any(|v| !v.is_finite() || *v < 0.0) {
                return Err(format!(
                    "Lescale must give {} finite values that are not negative",
                    density.len()
                ));
            }
        }
        if !(lo.is_finite() && hi.is_finite() && lo.cmplt(hi).all()) {
            return Err("the grid's box p0-p1 must be finite with p0 < p1 on every axis".into());
        }
        let to_medium = to_world.inverse();
        if !to_world.is_finite() || !to_medium.is_finite() || to_world.determinant() == 0.0 {
            return Err("the medium's transform cannot be inverted".into());
        }
        let mut grid = UniformGrid {
            unit,
            res,
            density,
            le_scale,
            lo,
            hi,
            to_medium,
            to_world,
            majorants: Vec::new(),
        };
        grid.majorants = grid.build_majorants();
        Ok(grid)
    }

    /// The coefficients at density 1 (emission at emission scale 1).
    pub fn unit(&self) -> &MediumPoint {
        &self.unit
    }

    /// Samples along x, y and z.
    pub fn resolution(&self) -> [usize; 3] {
        self.res
    }

    /// The density samples, x fastest.
    pub fn density(&self) -> &[f32] {
        &self.density
    }

    /// The emission scale samples, if the grid has them.
    pub fn emission_scale(&self) -> Option<&[f32]> {
        self.le_scale.as_deref()
    }

    /// The box the samples span in the medium's own space.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        (self.lo, self.hi)
    }

    /// The medium's own space to world.
    pub fn to_world(&self) -> Mat4 {
        self.to_world
    }

    /// The sample at integer coordinates, 0 outside the grid.
    fn sample(values: &[f32], res: [usize; 3], x: i64, y: i64, z: i64) -> f32 {
        let inside = |v: i64, n: usize| v >= 0 && (v as usize) < n;
        if !(inside(x, res[0]) && inside(y, res[1]) && inside(z, res[2])) {
            return 0.0;
        }
        values[(z as usize * res[1] + y as usize) * res[0] + x as usize]
    }

    /// `values` interpolated trilinearly at `u` (the box mapped to [0, 1]³), with samples
    /// at the cells' centres (pbrt-v4's `SampledGrid::Lookup`).
    fn lookup(&self, values: &[f32], u: Vec3) -> f32 {
        let s = u * Vec3::new(self.res[0] as f32, self.res[1] as f32, self.res[2] as f32)
            - Vec3::splat(0.5);
        let f = s.floor();
        let d = s - f;
        let (x, y, z) = (f.x as i64, f.y as i64, f.z as i64);
        let at = |i, j, k| Self::sample(values, self.res, x + i, y + j, z + k);
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
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

    /// The largest density within each majorant cell: every sample whose interpolation
    /// reaches into the cell (one sample beyond its edges).
    fn build_majorants(&self) -> Vec<f32> {
        let m = MAJORANT_CELLS;
        let mut out = vec![0.0f32; m * m * m];
        let range = |c: usize, axis: usize| {
            let n = self.res[axis] as f32;
            let a = ((c as f32 / m as f32) * n - 0.5).floor() as i64;
            let b = (((c + 1) as f32 / m as f32) * n - 0.5).floor() as i64 + 1;
            a..=b
        };
        for cz in 0..m {
            for cy in 0..m {
                for cx in 0..m {
                    let mut max = 0.0f32;
                    for z in range(cz, 2) {
                        for y in range(cy, 1) {
                            for x in range(cx, 0) {
                                max = max.max(Self::sample(&self.density, self.res, x, y, z));
                            }
                        }
                    }
                    out[(cz * m + cy) * m + cx] = max;
                }
            }
        }
        out
    }

    /// A world point in the grid's unit box.
    fn unit_coords(&self, p: Vec3) -> Vec3 {
        (self.to_medium.transform_point3(p) - self.lo) / (self.hi - self.lo)
    }
}

impl MediumModel for UniformGrid {
    fn kind(&self) -> &'static str {
        "uniformgrid"
    }

    fn at(&self, p: Vec3) -> MediumPoint {
        let u = self.unit_coords(p);
        // Nothing outside the box (the interpolation would reach half a cell beyond it).
        let inside = u.cmpge(Vec3::ZERO).all() && u.cmple(Vec3::ONE).all();
        let d = if inside {
            self.lookup(&self.density, u)
        } else {
            0.0
        };
        let scale = match &self.le_scale {
            Some(s) => self.lookup(s, u),
            None => 1.0,
        };
        MediumPoint {
            sigma_a: self.unit.sigma_a * d,
            sigma_s: self.unit.sigma_s * d,
            le: self.unit.le * scale,
            g: self.unit.g,
        }
    }

    fn segments(&self, ray: &Ray, t_max: f32, visit: &mut dyn FnMut(Segment) -> bool) {
        let m = MAJORANT_CELLS as f32;
        let sigma_t = (self.unit.sigma_a + self.unit.sigma_s) * ray.dir.length();
        // The ray in majorant-grid coordinates ([0, m]³ over the box).
        let scale = Vec3::splat(m) / (self.hi - self.lo);
        let o = (self.to_medium.transform_point3(ray.origin) - self.lo) * scale;
        let d = self.to_medium.transform_vector3(ray.dir) * scale;
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
        // Walk the cells (Amanatides & Woo).
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
                    sigma_maj: sigma_t * self.majorants[index],
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

    fn emits(&self) -> bool {
        (self.unit.le * self.unit.sigma_a).max_element() > 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Rgb, Rng};

    /// Rays in every direction through a rotated, uneven grid: the stretches the walk gives
    /// follow one another without gaps, stay within the ray's interval and the box, and
    /// bound the density at every point along them.
    #[test]
    fn the_walk_bounds_the_density_along_every_ray() {
        let mut rng = Rng::for_key(1, &[]);
        let res = [5, 3, 7];
        let density: Vec<f32> = (0..105).map(|_| rng.uniform() * 4.0).collect();
        let unit = MediumPoint {
            sigma_a: Rgb::splat(1.0),
            sigma_s: Rgb::ZERO,
            le: Rgb::ZERO,
            g: 0.0,
        };
        let to_world = Mat4::from_rotation_y(0.7) * Mat4::from_scale(Vec3::new(2.0, 1.0, 0.5));
        let box_ = (Vec3::new(-1.0, -0.5, 0.0), Vec3::new(1.0, 0.5, 2.0));
        let grid = UniformGrid::new(unit, res, density, None, box_, to_world).unwrap();
        let mut uniform = || rng.uniform();
        for _ in 0..2000 {
            let mut v = || Vec3::new(uniform(), uniform(), uniform()) * 6.0 - Vec3::splat(3.0);
            let ray = Ray::new(v(), v());
            let t_max = uniform() * 3.0;
            let mut segments = Vec::new();
            grid.segments(&ray, t_max, &mut |s| {
                segments.push(s);
                true
            });
            for pair in segments.windows(2) {
                assert_eq!(pair[0].t1, pair[1].t0, "a gap between stretches");
            }
            for s in &segments {
                assert!(
                    0.0 <= s.t0 && s.t0 < s.t1 && s.t1 <= t_max,
                    "{s:?} outside [0, {t_max}]"
                );
                for k in 0..8 {
                    let t = s.t0 + (s.t1 - s.t0) * (k as f32 + 0.5) / 8.0;
                    let d = grid.at(ray.origin + ray.dir * t).sigma_a.x * ray.dir.length();
                    assert!(d <= s.sigma_maj.x * 1.0001 + 1e-6, "density {d} over {s:?}");
                }
            }
            // Points of the ray within the interval but outside every stretch hold nothing.
            for k in 0..16 {
                let t = t_max * (k as f32 + 0.5) / 16.0;
                if !segments.iter().any(|s| s.t0 <= t && t <= s.t1) {
                    let d = grid.at(ray.origin + ray.dir * t).sigma_a.x;
                    assert!(d == 0.0, "density {d} at t {t} outside every stretch");
                }
            }
        }
    }
}
