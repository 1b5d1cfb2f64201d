//! A medium whose density varies over a box: a grid of density samples, interpolated
//! trilinearly, scaling one absorption and scattering (pbrt-v4's `uniformgrid`). Rays cross
//! it through a coarse grid of majorants (the largest density each cell can take), walked
//! cell by cell (a 3D DDA), so that thin regions cost few null collisions.

use super::grid_space::GridSpace;
use super::{check_coefficients, check_g, MediumModel, MediumPoint, MediumProblem, Segment};
use crate::math::{Mat4, Ray, Rgb, Vec3};

#[derive(Clone, Debug, PartialEq)]
pub struct UniformGrid {
    /// Coefficients and emission at density 1.
    unit: MediumPoint,
    /// Where the samples lie.
    space: GridSpace,
    /// Density samples, x fastest.
    density: Vec<f32>,
    /// Emission scale samples (pbrt-v4's `Lescale`), the same layout; `None`: 1 everywhere.
    le_scale: Option<Vec<f32>>,
    /// The largest density of each majorant cell, x fastest.
    majorants: Vec<Rgb>,
}

impl UniformGrid {
    /// A grid of `res` density samples spanning the box `lo`–`hi` of the medium's own space
    /// (`to_world` places it in the world), with the coefficients of `unit` at density 1.
    /// The problem names the field out of range.
    pub fn new(
        unit: MediumPoint,
        res: [usize; 3],
        density: Vec<f32>,
        le_scale: Option<Vec<f32>>,
        bounds: (Vec3, Vec3),
        to_world: Mat4,
    ) -> Result<UniformGrid, MediumProblem> {
        check_coefficients(&[
            ("sigma_a", "sigma_a", unit.sigma_a),
            ("sigma_s", "sigma_s", unit.sigma_s),
            ("emission", "Le", unit.le),
        ])?;
        check_g(unit.g)?;
        let space = GridSpace::new(res, bounds, to_world)?;
        let fail = |field, message: String| Err(MediumProblem { field, message });
        if res.contains(&0) || space.len() != density.len() {
            return fail(
                "density",
                format!(
                    "density has {} values; expected nx*ny*nz = {}x{}x{}",
                    density.len(),
                    res[0],
                    res[1],
                    res[2]
                ),
            );
        }
        if let Some(i) = density.iter().position(|d| !d.is_finite() || *d < 0.0) {
            return fail(
                "density",
                format!(
                    "density value {} is {}: densities must be finite and not negative",
                    i + 1,
                    density[i]
                ),
            );
        }
        if let Some(s) = &le_scale {
            if s.len() != density.len() || s.iter().any(|v| !v.is_finite() || *v < 0.0) {
                return fail(
                    "emission_scale",
                    format!(
                        "Lescale must give {} finite values that are not negative",
                        density.len()
                    ),
                );
            }
        }
        let majorants = space.majorants(|x, y, z| Rgb::splat(space.sample(&density, 0.0, x, y, z)));
        Ok(UniformGrid {
            unit,
            space,
            density,
            le_scale,
            majorants,
        })
    }

    /// The coefficients at density 1 (emission at emission scale 1).
    pub fn unit(&self) -> &MediumPoint {
        &self.unit
    }

    /// Samples along x, y and z.
    pub fn resolution(&self) -> [usize; 3] {
        self.space.res
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
        (self.space.lo, self.space.hi)
    }

    /// The medium's own space to world.
    pub fn to_world(&self) -> Mat4 {
        self.space.to_world
    }
}

impl MediumModel for UniformGrid {
    fn kind(&self) -> &'static str {
        "uniformgrid"
    }

    fn at(&self, p: Vec3) -> MediumPoint {
        let u = self.space.unit_coords(p);
        let d = if GridSpace::inside(u) {
            self.space.lookup(&self.density, 0.0, u)
        } else {
            0.0
        };
        let scale = match &self.le_scale {
            Some(s) => self.space.lookup(s, 0.0, u),
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
        let sigma_t = (self.unit.sigma_a + self.unit.sigma_s) * ray.dir.length();
        self.space.walk(&self.majorants, sigma_t, ray, t_max, visit);
    }

    fn emits(&self) -> bool {
        (self.unit.le * self.unit.sigma_a).max_element() > 0.0
    }

    fn colours(&self) -> Option<&MediumPoint> {
        Some(&self.unit)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

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
