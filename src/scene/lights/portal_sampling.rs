//! Next-event estimation of an environment map through a portal: from a point behind the
//! portal, directions are chosen only among those through it, in proportion to the map's
//! luminance times the cosine to the portal's normal (the flux each direction brings in),
//! over the portal's rectified coordinates ([`Portal`]). Points elsewhere, and light paths
//! leaving the environment, sample the whole sphere as without a portal; the map lights
//! every direction either way, so a portal changes the noise, not the image.

use crate::math::windowed::WindowedTable;
use crate::math::{luminance, Vec2, Vec3};
use crate::scene::{Environment, Portal};
use rayon::prelude::*;

/// Cells per side of the rectified table: the map's own resolution within these bounds
/// (near the portal's normal a cell of an n-wide table spans π²/n² sr, about a texel of an
/// equal-area map of the same width).
const MIN_CELLS: u32 = 32;
const MAX_CELLS: u32 = 512;

/// Points per side of each cell at which the map is read.
const CELL_SUPERSAMPLING: u32 = 2;

/// The map's directions through the portal, as a table over rectified coordinates.
#[derive(Debug)]
pub(super) struct PortalSampler {
    portal: Portal,
    table: WindowedTable,
}

impl PortalSampler {
    pub(super) fn new(env: &Environment, portal: Portal) -> PortalSampler {
        let n = env.image.width.clamp(MIN_CELLS, MAX_CELLS);
        let k = CELL_SUPERSAMPLING;
        let mut values: Vec<f32> = (0..n * n)
            .into_par_iter()
            .map(|c| {
                let (i, j) = (c % n, c / n);
                let mut sum = 0.0;
                for b in 0..k {
                    for a in 0..k {
                        let uv = Vec2::new(
                            ((i * k + a) as f32 + 0.5) / (n * k) as f32,
                            ((j * k + b) as f32 + 0.5) / (n * k) as f32,
                        );
                        let (dir, jacobian) = portal.direction_of(uv);
                        let cosine = dir.dot(portal.normal()).max(0.0);
                        sum += luminance(env.eval(dir)) * cosine * jacobian;
                    }
                }
                sum / (k * k) as f32
            })
            .collect();
        // A floor keeps every direction through the portal possible, so that MIS never
        // meets a zero density where the map is not black.
        let mean = values.iter().map(|&v| v as f64).sum::<f64>() / values.len() as f64;
        let floor = (1e-3 * mean).max(1e-12) as f32;
        for v in &mut values {
            *v = v.max(0.0) + floor;
        }
        PortalSampler {
            table: WindowedTable::new(n as usize, n as usize, &values),
            portal,
        }
    }

    /// The rectified window through which `p` sees the portal; `None` when `p` is not
    /// behind it.
    pub(super) fn window(&self, p: Vec3) -> Option<(Vec2, Vec2)> {
        self.portal.window(p)
    }

    /// A direction through the portal within `window` and its solid-angle density.
    pub(super) fn sample(&self, window: (Vec2, Vec2), u: Vec2) -> Option<(Vec3, f32)> {
        let (uv, density) = self.table.sample(u, window.0, window.1)?;
        let (dir, jacobian) = self.portal.direction_of(uv);
        (jacobian > 0.0 && density > 0.0).then(|| (dir, density / jacobian))
    }

    /// The solid-angle density with which [`sample`](Self::sample) picks `dir`.
    pub(super) fn pdf(&self, window: (Vec2, Vec2), dir: Vec3) -> f32 {
        match self.portal.uv_of(dir) {
            Some((uv, jacobian)) if jacobian > 0.0 => {
                self.table.pdf(uv, window.0, window.1) / jacobian
            }
            _ => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Image;
    use crate::math::warp::{uniform_sphere, UNIFORM_SPHERE_PDF};
    use crate::math::{Mat3, Rgb, Rng};

    /// A 32² map with a smooth gradient and one bright texel.
    fn environment(portal: Portal) -> Environment {
        let n = 32;
        let mut image = Image::new(n, n);
        for y in 0..n {
            for x in 0..n {
                let v = 0.2 + x as f32 / n as f32 + 0.5 * y as f32 / n as f32;
                let sun = if (x, y) == (9, 14) { 200.0 } else { 0.0 };
                image.set(x, y, Rgb::new(0.4 * v + sun, 0.6 * v + sun, v + sun));
            }
        }
        let mut env = Environment::new(image, "sky".into(), Mat3::IDENTITY, Rgb::ONE).unwrap();
        env.portal = Some(portal);
        env
    }

    fn window() -> Portal {
        Portal::new([
            Vec3::new(-1.0, 0.2, -0.8),
            Vec3::new(-1.0, 1.4, -0.8),
            Vec3::new(-1.0, 1.4, 0.7),
            Vec3::new(-1.0, 0.2, 0.7),
        ])
        .unwrap()
    }

    /// The irradiance through the window at a point inside, by portal sampling and by
    /// uniform sphere sampling (counting only directions through the window): independent
    /// estimators of one integral, within 4 standard errors; portal samples all pass
    /// through the window and, but for fewer than 1 in 1000 at the cells' edges, report
    /// the density `pdf` gives them.
    #[test]
    fn portal_samples_estimate_the_light_through_the_window() {
        let env = environment(window());
        let sampler = PortalSampler::new(&env, window());
        let (p, n) = (
            Vec3::new(0.3, 0.5, -0.1),
            Vec3::new(-0.6, 0.8, 0.0).normalize(),
        );
        let w = sampler.window(p).unwrap();
        let through = |dir: Vec3| {
            let t = (-1.0 - p.x) / dir.x;
            let q = p + dir * t;
            t > 0.0 && (0.2..=1.4).contains(&q.y) && (-0.8..=0.7).contains(&q.z)
        };
        let mut rng = Rng::for_key(21, &[]);
        let count = 200_000;
        let (mut portal, mut sphere) = (Vec::new(), Vec::new());
        let mut elsewhere = 0;
        for _ in 0..count {
            let u = Vec2::new(rng.uniform(), rng.uniform());
            let (dir, pdf) = sampler.sample(w, u).unwrap();
            assert!(through(dir), "{dir}");
            // The direction maps back into the cell it came from, but for rounding at
            // the cells' edges.
            let again = sampler.pdf(w, dir);
            if (again - pdf).abs() > 2e-3 * pdf {
                elsewhere += 1;
            }
            portal.push((luminance(env.eval(dir)) * dir.dot(n).max(0.0) / pdf) as f64);
            let dir = uniform_sphere(Vec2::new(rng.uniform(), rng.uniform()));
            let f = if through(dir) {
                luminance(env.eval(dir)) * dir.dot(n).max(0.0) / UNIFORM_SPHERE_PDF
            } else {
                0.0
            };
            sphere.push(f as f64);
        }
        let stats = |v: &[f64]| {
            let m = v.iter().sum::<f64>() / v.len() as f64;
            let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() - 1) as f64;
            (m, var / v.len() as f64)
        };
        assert!(
            elsewhere < count / 1000,
            "{elsewhere} samples in another cell"
        );
        let ((a, va), (b, vb)) = (stats(&portal), stats(&sphere));
        let z = (a - b) / (va + vb).sqrt();
        eprintln!(
            "portal {a:.4} ± {:.4}, sphere {b:.4} ± {:.4}, z = {z:.2}",
            va.sqrt(),
            vb.sqrt()
        );
        assert!(z.abs() < 4.0, "z = {z}");
        // The portal's estimate is the better one by far.
        assert!(va < 0.1 * vb, "variances {va} vs {vb}");
    }

    /// Every direction through the window has a positive density (the floor), and
    /// directions elsewhere have none.
    #[test]
    fn only_directions_through_the_window_have_a_density() {
        let env = environment(window());
        let sampler = PortalSampler::new(&env, window());
        let p = Vec3::new(0.3, 0.5, -0.1);
        let w = sampler.window(p).unwrap();
        let mut rng = Rng::for_key(22, &[]);
        for _ in 0..5000 {
            let dir = uniform_sphere(Vec2::new(rng.uniform(), rng.uniform()));
            let t = (-1.0 - p.x) / dir.x;
            let q = p + dir * t;
            let through = t > 0.0 && (0.2..=1.4).contains(&q.y) && (-0.8..=0.7).contains(&q.z);
            assert_eq!(sampler.pdf(w, dir) > 0.0, through, "{dir}");
        }
    }
}
