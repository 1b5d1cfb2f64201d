//! The background: radiance arriving from every direction the scene does not block, a
//! constant or an environment map (importance-sampled by luminance, and through its portal
//! when it has one). For a receiver that only reflects, next-event estimation weighs the
//! directions by their cosine too: cosine-weighted over the hemisphere for a constant, the
//! map's luminance times a bound on the cosine for a map (`env_facing`).

use super::directional::world_disk;
use super::env_facing::{texel_weight, FacingTables};
use super::portal_sampling::PortalSampler;
use super::{EmissionSample, LightModel, LightSample, World};
use crate::math::warp::{cosine_hemisphere, uniform_sphere, UNIFORM_SPHERE_PDF};
use crate::math::{frame, luminance, Rgb, Vec2, Vec3};
use crate::scene::environment::equal_area_square_to_sphere;
use crate::scene::Environment;
use std::f32::consts::PI;
use std::sync::Arc;

/// Radiance from every direction: `radiance`, or the environment map when there is one.
#[derive(Clone, Debug)]
pub struct Background {
    pub radiance: Rgb,
    pub map: Option<Arc<EnvironmentSampler>>,
}

impl Background {
    /// The background of environment map `env`.
    pub fn of_environment(env: Arc<Environment>) -> Background {
        Background {
            radiance: Rgb::ZERO,
            map: Some(Arc::new(EnvironmentSampler::new(env))),
        }
    }

    /// Radiance arriving along `-dir` (seen looking along `dir`).
    pub fn radiance_towards(&self, dir: Vec3) -> Rgb {
        match &self.map {
            Some(m) => m.env.eval(dir),
            None => self.radiance,
        }
    }

    /// A direction towards the background, its density and its radiance.
    fn sample(&self, u: Vec2) -> (Vec3, f32, Rgb) {
        match &self.map {
            Some(m) => {
                let (wi, pdf) = m.sample(u);
                (wi, pdf, m.env.eval(wi))
            }
            None => (uniform_sphere(u), UNIFORM_SPHERE_PDF, self.radiance),
        }
    }

    /// [`sample`](Self::sample) for next-event estimation at `p`: through the portal when
    /// `p` is behind one; for a receiver that reflects only on the side `facing` points to,
    /// weighted by the cosine with it.
    fn sample_from(&self, p: Vec3, facing: Option<Vec3>, u: Vec2) -> Option<(Vec3, f32, Rgb)> {
        let Some(m) = &self.map else {
            let Some(n) = facing else {
                return Some(self.sample(u));
            };
            let local = cosine_hemisphere(u);
            let (t, b) = frame(n);
            let wi = (t * local.x + b * local.y + n * local.z).normalize();
            let pdf = wi.dot(n).max(0.0) / PI;
            return (pdf > 0.0).then_some((wi, pdf, self.radiance));
        };
        if let Some((portal, window)) = m.portal_window(p) {
            let (wi, pdf) = portal.sample(window, u)?;
            return Some((wi, pdf, m.env.eval(wi)));
        }
        let (wi, pdf) = match facing {
            Some(n) => m.sample_facing(n, u),
            None => m.sample(u),
        };
        Some((wi, pdf, m.env.eval(wi)))
    }

    /// The density with which [`sample_from`](Self::sample_from) picks `dir`, without the
    /// choice of the light.
    fn pdf_from(&self, p: Vec3, facing: Option<Vec3>, dir: Vec3) -> f32 {
        match (&self.map, facing) {
            (Some(m), _) => m.pdf_from(p, facing, dir),
            (None, Some(n)) => dir.dot(n).max(0.0) / PI,
            (None, None) => UNIFORM_SPHERE_PDF,
        }
    }

    /// [`LightModel::sample_li`] for a receiver that reflects only on the side `facing`
    /// points to (`None`: any receiver).
    pub(crate) fn sample_li_facing(
        &self,
        p: Vec3,
        facing: Option<Vec3>,
        u: Vec2,
        choice: f32,
        world: &World,
    ) -> Option<LightSample> {
        let (wi, pdf, radiance) = self.sample_from(p, facing, u)?;
        Some(LightSample {
            radiance,
            wi,
            p: p + wi * (4.0 * world.radius + (p - world.center).length()),
            error: Vec3::ZERO,
            n: Vec3::ZERO,
            pdf: choice * pdf,
            delta: false,
        })
    }

    /// [`LightModel::pdf_li`] for the receiver of [`sample_li_facing`](Self::sample_li_facing).
    pub(crate) fn pdf_li_facing(&self, p: Vec3, facing: Option<Vec3>, q: Vec3, choice: f32) -> f32 {
        // For the background, `q - p` is the direction.
        choice * self.pdf_from(p, facing, (q - p).normalize())
    }
}

impl LightModel for Background {
    fn power(&self, world: &World) -> f32 {
        let mean = self.map.as_ref().map_or(self.radiance, |m| m.mean);
        4.0 * PI * PI * world.radius * world.radius * luminance(mean)
    }

    fn sample_li(&self, p: Vec3, u: Vec2, choice: f32, world: &World) -> Option<LightSample> {
        self.sample_li_facing(p, None, u, choice, world)
    }

    fn pdf_li(&self, p: Vec3, q: Vec3, _n: Vec3, choice: f32) -> f32 {
        self.pdf_li_facing(p, None, q, choice)
    }

    fn sample_le(
        &self,
        u_pos: Vec2,
        u_dir: Vec2,
        choice: f32,
        world: &World,
        light: usize,
    ) -> Option<EmissionSample> {
        let (to_light, pdf_dir, radiance) = self.sample(u_dir);
        let dir = -to_light;
        Some(EmissionSample {
            p: world_disk(world, dir, u_pos),
            error: Vec3::ZERO,
            n: dir,
            dir,
            radiance,
            pdf_pos: choice / (PI * world.radius * world.radius),
            pdf_dir,
            delta_pos: false,
            delta_dir: false,
            light,
        })
    }

    fn pdf_emission_direction(&self, w: Vec3) -> f32 {
        // `sample_le` sends light along the opposite of the direction it samples, over the
        // whole sphere (never through the portal: light paths must reach every direction).
        self.map
            .as_ref()
            .map_or(UNIFORM_SPHERE_PDF, |m| m.pdf((-w).normalize()))
    }

    fn is_infinite(&self) -> bool {
        true
    }
}

/// An environment map prepared for importance sampling. Its equal-area parameterisation
/// makes every texel the same solid angle (4π / texels), so choosing texels in proportion to
/// luminance and a point uniformly inside gives a piecewise-constant density over directions.
#[derive(Debug)]
pub struct EnvironmentSampler {
    pub env: Arc<Environment>,
    cdf: Vec<f32>,
    total: f32,
    /// Mean radiance over directions.
    pub mean: Rgb,
    /// Directions through the map's portal, for points behind it.
    portal: Option<PortalSampler>,
    /// Directions weighted by their cosine with a reflecting receiver's normal.
    facing: FacingTables,
}

impl EnvironmentSampler {
    pub fn new(env: Arc<Environment>) -> Self {
        let mut total = 0.0f64;
        let mut sum = Rgb::ZERO;
        let cdf = env
            .image
            .pixels
            .iter()
            .map(|&p| {
                sum += p.max(Rgb::ZERO) * env.scale;
                // A floor keeps every direction possible, so MIS never meets a zero density.
                total += texel_weight(p, env.scale) as f64;
                total as f32
            })
            .collect();
        let n = env.image.pixels.len().max(1) as f32;
        EnvironmentSampler {
            cdf,
            total: total as f32,
            mean: sum / n,
            portal: env
                .portal
                .clone()
                .map(|portal| PortalSampler::new(&env, portal)),
            facing: FacingTables::new(&env),
            env,
        }
    }

    /// The portal sampler and the window through which `p` sees the portal, when the map
    /// has a portal and `p` is behind it.
    fn portal_window(&self, p: Vec3) -> Option<(&PortalSampler, (Vec2, Vec2))> {
        let portal = self.portal.as_ref()?;
        Some((portal, portal.window(p)?))
    }

    /// The density with which next-event estimation at `p` (for a receiver facing
    /// `facing`, if it reflects only) picks `dir`.
    fn pdf_from(&self, p: Vec3, facing: Option<Vec3>, dir: Vec3) -> f32 {
        match (self.portal_window(p), facing) {
            (Some((portal, window)), _) => portal.pdf(window, dir),
            (None, Some(n)) => self.pdf_facing(n, dir),
            (None, None) => self.pdf(dir),
        }
    }

    /// A direction for a receiver facing `n`, and its solid-angle density.
    fn sample_facing(&self, n: Vec3, u: Vec2) -> (Vec3, f32) {
        let (i, fx) = self.facing.sample(n, u.x);
        let dir = self.texel_direction(i, Vec2::new(fx, u.y));
        (dir, self.pdf_facing_texel(n, i))
    }

    fn pdf_facing(&self, n: Vec3, dir: Vec3) -> f32 {
        self.env
            .texel(dir)
            .map_or(0.0, |i| self.pdf_facing_texel(n, i))
    }

    fn pdf_facing_texel(&self, n: Vec3, i: usize) -> f32 {
        let weight = texel_weight(self.env.image.pixels[i], self.env.scale);
        let texels = self.cdf.len() as f32;
        self.facing.texel_probability(n, i, weight) * texels / (4.0 * PI)
    }

    /// The direction through the point `f` (in [0, 1)²) of texel `i`.
    fn texel_direction(&self, i: usize, f: Vec2) -> Vec3 {
        let n = self.env.image.width;
        let (x, y) = ((i as u32 % n) as f32, (i as u32 / n) as f32);
        let p = Vec2::new((x + f.x) / n as f32, (y + f.y) / n as f32);
        (self.env.transform * equal_area_square_to_sphere(p)).normalize()
    }

    fn texel_weight(&self, i: usize) -> f32 {
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        self.cdf[i] - lo
    }

    /// A direction and its solid-angle density.
    fn sample(&self, u: Vec2) -> (Vec3, f32) {
        let target = u.x * self.total;
        let i = self
            .cdf
            .partition_point(|&c| c <= target)
            .min(self.cdf.len() - 1);
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        let fx = ((target - lo) / self.texel_weight(i).max(f32::MIN_POSITIVE)).clamp(0.0, 0.999);
        (
            self.texel_direction(i, Vec2::new(fx, u.y)),
            self.pdf_texel(i),
        )
    }

    fn pdf_texel(&self, i: usize) -> f32 {
        let texels = self.cdf.len() as f32;
        self.texel_weight(i) / self.total * texels / (4.0 * PI)
    }

    fn pdf(&self, dir: Vec3) -> f32 {
        self.env.texel(dir).map_or(0.0, |i| self.pdf_texel(i))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Image;
    use crate::math::Mat3;

    /// A map with a smooth sky, a dark half and one bright texel, turned off the axes.
    fn sampler() -> EnvironmentSampler {
        let n = 64;
        let mut image = Image::new(n, n);
        for y in 0..n {
            for x in 0..n {
                let d = equal_area_square_to_sphere(Vec2::new(
                    (x as f32 + 0.5) / n as f32,
                    (y as f32 + 0.5) / n as f32,
                ));
                let sky = 0.2 + 2.0 * d.z.max(0.0) + 0.5 * d.x.abs();
                image.pixels[(y * n + x) as usize] = Rgb::new(sky, 0.8 * sky, 0.6 * sky);
            }
        }
        image.pixels[(20 * n + 41) as usize] = Rgb::splat(400.0);
        let turn = Mat3::from_rotation_y(0.4) * Mat3::from_rotation_x(0.3);
        let env = Environment::new(image, "sky".into(), turn, Rgb::splat(1.5)).unwrap();
        EnvironmentSampler::new(Arc::new(env))
    }

    fn uniform_directions(count: u32) -> impl Iterator<Item = Vec3> {
        let side = (count as f32).sqrt() as u32;
        (0..side * side).map(move |k| {
            let (i, j) = (k % side, k / side);
            let u = Vec2::new(
                (i as f32 + 0.5) / side as f32,
                (j as f32 + 0.5) / side as f32,
            );
            uniform_sphere(u)
        })
    }

    fn normals() -> [Vec3; 5] {
        [
            Vec3::Z,
            -Vec3::Z,
            Vec3::new(0.3, -0.8, 0.5).normalize(),
            Vec3::new(-0.9, 0.1, -0.2).normalize(),
            Vec3::new(0.577, 0.577, 0.577),
        ]
    }

    #[test]
    fn facing_density_integrates_to_one_and_is_what_sampling_reports() {
        let m = sampler();
        for n in normals() {
            let count = 1_000_000;
            let sum: f64 = uniform_directions(count)
                .map(|d| m.pdf_facing(n, d) as f64)
                .sum();
            let integral = sum / count as f64 * 4.0 * std::f64::consts::PI;
            assert!((integral - 1.0).abs() < 0.01, "∫pdf = {integral} for {n}");
            let mut rng = crate::math::Rng::for_key(7, &[]);
            let mut mismatched = 0;
            for _ in 0..20_000 {
                let (wi, pdf) = m.sample_facing(n, Vec2::new(rng.uniform(), rng.uniform()));
                let again = m.pdf_facing(n, wi);
                if (pdf - again).abs() > 1e-3 * pdf {
                    mismatched += 1;
                }
            }
            // Directions on a texel's edge may be read back as its neighbour's.
            assert!(mismatched < 20, "{mismatched} of 20000 samples for {n}");
        }
    }

    #[test]
    fn facing_sampling_estimates_the_cosine_integral_with_less_variance() {
        let m = sampler();
        let lum = |d: Vec3| luminance(m.env.eval(d)) as f64;
        for n in normals() {
            let cos = |d: Vec3| d.dot(n).max(0.0) as f64;
            let count = 4_000_000;
            let reference: f64 = uniform_directions(count)
                .map(|d| lum(d) * cos(d))
                .sum::<f64>()
                / count as f64
                * 4.0
                * std::f64::consts::PI;
            let estimate = |facing: bool| {
                let mut rng = crate::math::Rng::for_key(11, &[]);
                let (mut s, mut s2, k) = (0.0f64, 0.0f64, 100_000);
                for _ in 0..k {
                    let u = Vec2::new(rng.uniform(), rng.uniform());
                    let (wi, pdf) = if facing {
                        m.sample_facing(n, u)
                    } else {
                        m.sample(u)
                    };
                    let v = if pdf > 0.0 {
                        lum(wi) * cos(wi) / pdf as f64
                    } else {
                        0.0
                    };
                    s += v;
                    s2 += v * v;
                }
                let mean = s / k as f64;
                (mean, (s2 / k as f64 - mean * mean) / k as f64)
            };
            let (facing, facing_var) = estimate(true);
            let (plain, plain_var) = estimate(false);
            let sigma = facing_var.sqrt();
            assert!(
                (facing - reference).abs() < 4.0 * sigma + 0.003 * reference,
                "{n}: facing {facing} ± {sigma}, reference {reference}"
            );
            assert!(
                (plain - reference).abs() < 4.0 * plain_var.sqrt() + 0.003 * reference,
                "{n}: plain {plain}, reference {reference}"
            );
            assert!(
                facing_var < 0.7 * plain_var,
                "{n}: variance {facing_var} against luminance alone {plain_var}"
            );
        }
    }

    #[test]
    fn a_constant_background_is_sampled_by_the_cosine_for_a_reflecting_receiver() {
        let bg = Background {
            radiance: Rgb::splat(2.0),
            map: None,
        };
        let n = Vec3::new(0.2, -0.4, 0.9).normalize();
        let mut rng = crate::math::Rng::for_key(3, &[]);
        for _ in 0..1000 {
            let u = Vec2::new(rng.uniform(), rng.uniform());
            let (wi, pdf, l) = bg.sample_from(Vec3::ZERO, Some(n), u).unwrap();
            // Cosine-weighted: radiance · cos / pdf is π · radiance for every sample.
            let v = l.x * wi.dot(n) / pdf;
            assert!((v - 2.0 * PI).abs() < 1e-3, "{v}");
            assert!((bg.pdf_from(Vec3::ZERO, Some(n), wi) - pdf).abs() < 1e-4 * pdf);
        }
        assert_eq!(bg.pdf_from(Vec3::ZERO, Some(n), -n), 0.0);
    }
}
