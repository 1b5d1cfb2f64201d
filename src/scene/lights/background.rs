//! The background: radiance arriving from every direction the scene does not block, a
//! constant or an environment map (importance-sampled by luminance, and through its portal
//! when it has one).

use super::directional::world_disk;
use super::portal_sampling::PortalSampler;
use super::{EmissionSample, LightModel, LightSample, World};
use crate::math::warp::{uniform_sphere, UNIFORM_SPHERE_PDF};
use crate::math::{luminance, Rgb, Vec2, Vec3};
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
    /// `p` is behind one.
    fn sample_from(&self, p: Vec3, u: Vec2) -> Option<(Vec3, f32, Rgb)> {
        if let Some(m) = &self.map {
            if let Some((portal, window)) = m.portal_window(p) {
                let (wi, pdf) = portal.sample(window, u)?;
                return Some((wi, pdf, m.env.eval(wi)));
            }
        }
        Some(self.sample(u))
    }
}

impl LightModel for Background {
    fn power(&self, world: &World) -> f32 {
        let mean = self.map.as_ref().map_or(self.radiance, |m| m.mean);
        4.0 * PI * PI * world.radius * world.radius * luminance(mean)
    }

    fn sample_li(&self, p: Vec3, u: Vec2, choice: f32, world: &World) -> Option<LightSample> {
        let (wi, pdf, radiance) = self.sample_from(p, u)?;
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

    fn pdf_li(&self, p: Vec3, q: Vec3, _n: Vec3, choice: f32) -> f32 {
        // For the background, `q - p` is the direction.
        choice
            * self
                .map
                .as_ref()
                .map_or(UNIFORM_SPHERE_PDF, |m| m.pdf_from(p, (q - p).normalize()))
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
}

impl EnvironmentSampler {
    pub fn new(env: Arc<Environment>) -> Self {
        let mut total = 0.0f64;
        let mut sum = Rgb::ZERO;
        let cdf = env
            .image
            .pixels
            .iter()
            .map(|p| {
                let v = p.max(Rgb::ZERO) * env.scale;
                sum += v;
                // A floor keeps every direction possible, so MIS never meets a zero density.
                total += (luminance(v) + 1e-4) as f64;
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
            env,
        }
    }

    /// The portal sampler and the window through which `p` sees the portal, when the map
    /// has a portal and `p` is behind it.
    fn portal_window(&self, p: Vec3) -> Option<(&PortalSampler, (Vec2, Vec2))> {
        let portal = self.portal.as_ref()?;
        Some((portal, portal.window(p)?))
    }

    /// The density with which next-event estimation at `p` picks `dir`.
    fn pdf_from(&self, p: Vec3, dir: Vec3) -> f32 {
        match self.portal_window(p) {
            Some((portal, window)) => portal.pdf(window, dir),
            None => self.pdf(dir),
        }
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
        let n = self.env.image.width;
        let (x, y) = ((i as u32 % n) as f32, (i as u32 / n) as f32);
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        let fx = ((target - lo) / self.texel_weight(i).max(f32::MIN_POSITIVE)).clamp(0.0, 0.999);
        let p = Vec2::new((x + fx) / n as f32, (y + u.y) / n as f32);
        let dir = (self.env.transform * equal_area_square_to_sphere(p)).normalize();
        (dir, self.pdf_texel(i))
    }

    fn pdf_texel(&self, i: usize) -> f32 {
        let texels = self.cdf.len() as f32;
        self.texel_weight(i) / self.total * texels / (4.0 * PI)
    }

    fn pdf(&self, dir: Vec3) -> f32 {
        self.env.texel(dir).map_or(0.0, |i| self.pdf_texel(i))
    }
}
