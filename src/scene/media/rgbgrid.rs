//! A medium whose colours vary over a box: grids of RGB absorption, scattering and emission,
//! interpolated trilinearly (pbrt-v4's `rgbgrid`). A grid not given is 1 everywhere for σa
//! and σs (as pbrt-v4 has it) and 0 for the emission. Rays cross it through a coarse grid of
//! per-channel majorants, as a `uniformgrid`.

use super::grid_space::GridSpace;
use super::{check_g, MediumModel, MediumPoint, MediumProblem, Segment};
use crate::math::{Mat4, Ray, Rgb, Vec3};

#[derive(Clone, Debug, PartialEq)]
pub struct RgbGrid {
    /// Where the samples lie.
    space: GridSpace,
    /// Absorption, scattering and emitted radiance per sample, x fastest (`None`: 1, 1, 0).
    sigma_a: Option<Vec<Rgb>>,
    sigma_s: Option<Vec<Rgb>>,
    le: Option<Vec<Rgb>>,
    /// Multiplies σa and σs.
    scale: f32,
    g: f32,
    /// The largest σt of each majorant cell per channel (scale included), x fastest.
    majorants: Vec<Rgb>,
}

/// The three grids of an [`RgbGrid`], each `None` or one colour a sample.
pub struct RgbGrids {
    pub sigma_a: Option<Vec<Rgb>>,
    pub sigma_s: Option<Vec<Rgb>>,
    pub le: Option<Vec<Rgb>>,
}

impl RgbGrid {
    /// Grids of `res` samples spanning the box `bounds` of the medium's own space
    /// (`to_world` places it), σa and σs multiplied by `scale`, scattering by the
    /// Henyey–Greenstein asymmetry `g`. The problem names the field out of range.
    pub fn new(
        grids: RgbGrids,
        scale: f32,
        g: f32,
        res: [usize; 3],
        bounds: (Vec3, Vec3),
        to_world: Mat4,
    ) -> Result<RgbGrid, MediumProblem> {
        check_g(g)?;
        let fail = |field, message: String| Err(MediumProblem { field, message });
        if !(scale.is_finite() && scale >= 0.0) {
            return fail(
                "scale",
                format!("scale must be finite and not negative, got {scale}"),
            );
        }
        let space = GridSpace::new(res, bounds, to_world)?;
        let n = space.len();
        if grids.sigma_a.is_none() && grids.sigma_s.is_none() {
            return fail(
                "sigma_a_grid",
                "an rgbgrid needs sigma_a or sigma_s values (or both)".into(),
            );
        }
        if grids.le.is_some() && grids.sigma_a.is_none() {
            return fail(
                "sigma_a_grid",
                "an rgbgrid that emits (Le) needs sigma_a values".into(),
            );
        }
        let named = [
            ("sigma_a_grid", "sigma_a", &grids.sigma_a),
            ("sigma_s_grid", "sigma_s", &grids.sigma_s),
            ("emission_grid", "Le", &grids.le),
        ];
        for (field, name, values) in named {
            let Some(values) = values else { continue };
            if res.contains(&0) || values.len() != n {
                return fail(
                    field,
                    format!(
                        "{name} has {} values; expected nx*ny*nz = {}x{}x{}",
                        values.len(),
                        res[0],
                        res[1],
                        res[2]
                    ),
                );
            }
            if let Some(i) = values
                .iter()
                .position(|v| !v.is_finite() || v.min_element() < 0.0)
            {
                let v = values[i];
                return fail(
                    field,
                    format!(
                        "{name} value {} is ({}, {}, {}): it must be finite and not negative",
                        i + 1,
                        v.x,
                        v.y,
                        v.z
                    ),
                );
            }
        }
        let inside = |x: i64, y: i64, z: i64| {
            [x, y, z]
                .iter()
                .zip(res)
                .all(|(&c, n)| (0..n as i64).contains(&c))
        };
        let one = |grid: &Option<Vec<Rgb>>, x, y, z| match grid {
            Some(v) => space.sample(v, Rgb::ZERO, x, y, z),
            // 1 within the grid, nothing beyond it.
            None if inside(x, y, z) => Rgb::ONE,
            None => Rgb::ZERO,
        };
        let majorants = space.majorants(|x, y, z| {
            (one(&grids.sigma_a, x, y, z) + one(&grids.sigma_s, x, y, z)) * scale
        });
        Ok(RgbGrid {
            space,
            sigma_a: grids.sigma_a,
            sigma_s: grids.sigma_s,
            le: grids.le,
            scale,
            g,
            majorants,
        })
    }

    /// The absorption per sample (before `scale`), if given.
    pub fn sigma_a(&self) -> Option<&[Rgb]> {
        self.sigma_a.as_deref()
    }

    /// The scattering per sample (before `scale`), if given.
    pub fn sigma_s(&self) -> Option<&[Rgb]> {
        self.sigma_s.as_deref()
    }

    /// The emitted radiance per sample, if given.
    pub fn emission(&self) -> Option<&[Rgb]> {
        self.le.as_deref()
    }

    /// What multiplies σa and σs.
    pub fn scale(&self) -> f32 {
        self.scale
    }

    /// The Henyey–Greenstein asymmetry.
    pub fn g(&self) -> f32 {
        self.g
    }

    /// Samples along x, y and z.
    pub fn resolution(&self) -> [usize; 3] {
        self.space.res
    }

    /// The box the samples span in the medium's own space.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        (self.space.lo, self.space.hi)
    }

    /// The medium's own space to world.
    pub fn to_world(&self) -> Mat4 {
        self.space.to_world
    }

    /// A grid's value at unit coordinates `u`, or `default` for a grid not given.
    fn lookup(&self, grid: &Option<Vec<Rgb>>, default: Rgb, u: Vec3) -> Rgb {
        match grid {
            Some(v) => self.space.lookup(v, Rgb::ZERO, u),
            None => default,
        }
    }
}

impl MediumModel for RgbGrid {
    fn kind(&self) -> &'static str {
        "rgbgrid"
    }

    fn at(&self, p: Vec3) -> MediumPoint {
        let u = self.space.unit_coords(p);
        if !GridSpace::inside(u) {
            return MediumPoint {
                sigma_a: Rgb::ZERO,
                sigma_s: Rgb::ZERO,
                le: Rgb::ZERO,
                g: self.g,
            };
        }
        MediumPoint {
            sigma_a: self.lookup(&self.sigma_a, Rgb::ONE, u) * self.scale,
            sigma_s: self.lookup(&self.sigma_s, Rgb::ONE, u) * self.scale,
            le: self.lookup(&self.le, Rgb::ZERO, u),
            g: self.g,
        }
    }

    fn segments(&self, ray: &Ray, t_max: f32, visit: &mut dyn FnMut(Segment) -> bool) {
        let length = Rgb::splat(ray.dir.length());
        self.space.walk(&self.majorants, length, ray, t_max, visit);
    }

    fn emits(&self) -> bool {
        self.le
            .as_ref()
            .is_some_and(|le| le.iter().any(|v| v.max_element() > 0.0))
            && self.scale > 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

    /// Rays through a rotated grid of random colours (σs not given: 1): every stretch the
    /// walk gives bounds σt per channel at the points along it.
    #[test]
    fn the_walk_bounds_every_channel() {
        let mut rng = Rng::for_key(2, &[]);
        let res = [4, 3, 5];
        let mut colour = || Rgb::new(rng.uniform(), rng.uniform() * 3.0, rng.uniform() * 0.1);
        let sigma_a: Vec<Rgb> = (0..60).map(|_| colour()).collect();
        let grids = RgbGrids {
            sigma_a: Some(sigma_a),
            sigma_s: None,
            le: None,
        };
        let to_world = Mat4::from_rotation_x(0.4) * Mat4::from_scale(Vec3::new(1.0, 2.0, 0.5));
        let bounds = (Vec3::splat(-1.0), Vec3::ONE);
        let grid = RgbGrid::new(grids, 1.5, 0.0, res, bounds, to_world).unwrap();
        let mut uniform = || rng.uniform();
        for _ in 0..1000 {
            let mut v = || Vec3::new(uniform(), uniform(), uniform()) * 6.0 - Vec3::splat(3.0);
            let ray = Ray::new(v(), v());
            let mut stretches = Vec::new();
            grid.segments(&ray, 4.0, &mut |s| {
                stretches.push(s);
                true
            });
            for s in &stretches {
                for k in 0..8 {
                    let t = s.t0 + (s.t1 - s.t0) * (k as f32 + 0.5) / 8.0;
                    let p = grid.at(ray.origin + ray.dir * t);
                    let sigma_t = (p.sigma_a + p.sigma_s) * ray.dir.length();
                    assert!(
                        sigma_t.cmple(s.sigma_maj * 1.0001 + Rgb::splat(1e-6)).all(),
                        "{sigma_t} over {s:?}"
                    );
                }
            }
        }
    }
}
