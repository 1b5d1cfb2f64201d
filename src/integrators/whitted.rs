//! Whitted's recursive ray tracing (Whitted 1980, "An Improved Illumination Model for Shaded
//! Display"). At each hit, eq. 2 of the paper:
//!
//!   I = ka·Ia + Σj kd·(N·Lj)·Ej + ks·S + kt·T
//!
//! with a Phong highlight for point, spot and directional lights (the paper keeps Phong's model
//! for light sources seen in reflection), a shadow ray per light attenuated by the kt of the
//! transmissive surfaces it passes, S and T traced recursively along the mirror and Snell
//! directions, and a random normal perturbation for glossy and frosted surfaces.
//!
//! Units are physical so that Whitted and the Monte Carlo integrators agree on direct light:
//! Ej is the irradiance from light j (I/r² for a point light), the diffuse term is kd/π·E,
//! and area lights (emissive shapes) are integrated with stratified shadow rays.
//! Deviation from the paper: no linear attenuation with distance along reflected rays
//! (radiance is constant along rays in vacuum).

use crate::bsdf::{Bsdf, Transport};
use crate::error::Result;
pub use crate::math::optics::{fresnel_dielectric, reflect, refract};
use crate::math::spawn::Spot;
use crate::math::{frame, Ray, Rgb, Rng, Vec2, Vec3};
use crate::scene::lights::Illumination;
use crate::scene::{Material, SurfacePoint};
use crate::settings::{Settings, TechniqueKind};
use crate::transport::settings::{at_most, Setting, TechniqueInfo, COMMON};
use crate::transport::technique::{Lifecycle, Tiles};
use crate::transport::{Context, Integrator, PixelSampling, RayStats, Sample, PIXELS};
use std::f32::consts::{FRAC_1_PI, PI};

#[derive(Clone, Debug, PartialEq)]
pub struct WhittedOptions {
    /// Maximum depth of the ray tree (the camera ray is depth 0).
    pub max_depth: u32,
    /// A branch whose weight (product of ks/kt along the path, largest channel) falls below
    /// this is pruned.
    pub cutoff: f32,
    /// Shadow rays per area light at each shading point (rounded up to a square).
    pub area_samples: u32,
    /// Weight ks and kt by Fresnel reflectance on every material, not only those asking for it.
    pub fresnel: bool,
}

impl Default for WhittedOptions {
    fn default() -> Self {
        WhittedOptions {
            max_depth: 8,
            cutoff: 1e-3,
            area_samples: 16,
            fresnel: false,
        }
    }
}

/// Shadow rays give up after passing this many transmissive surfaces.
const MAX_SHADOW_CROSSINGS: u32 = 32;
/// Perturbed directions that fall on the wrong side of the surface are redrawn this often.
const PERTURB_TRIES: u32 = 8;

pub struct Whitted {
    pub options: WhittedOptions,
}

impl Whitted {
    pub fn new(options: WhittedOptions) -> Self {
        Whitted { options }
    }
}

/// One camera sample's ray tree: what every node of it reads (the options, the scene) and
/// updates (the sample's random stream and ray counts), passed down the recursion as one
/// value.
struct RayTree<'a> {
    options: &'a WhittedOptions,
    ctx: &'a Context<'a>,
    rng: &'a mut Rng,
    stats: &'a mut RayStats,
    /// The camera ray's shutter time, which every ray of the tree keeps.
    time: f32,
}

impl RayTree<'_> {
    /// Intensity arriving along `ray`, for a branch of the ray tree with accumulated `weight`.
    fn trace(&mut self, ray: &Ray, depth: u32, weight: f32) -> (Rgb, u32) {
        let ctx = self.ctx;
        let Some(sp) = ctx.intersect_at_depth(ray, depth, self.stats) else {
            return (ctx.scene.background, u32::MAX);
        };
        (
            self.shade(ray, &sp, depth, weight),
            ctx.scene.object_id(&sp),
        )
    }

    fn shade(&mut self, ray: &Ray, sp: &SurfacePoint, depth: u32, weight: f32) -> Rgb {
        let ctx = self.ctx;
        let material = &ctx.scene.materials[sp.material];
        let m = material.approximation();
        let d = ray.dir.normalize();
        // The paper's convention: N points to the side the ray comes from, and the index of
        // refraction is inverted when the ray leaves the medium.
        let entering = d.dot(sp.ng) < 0.0;
        let (ng, n) = if entering {
            (sp.ng, sp.ns)
        } else {
            (-sp.ng, -sp.ns)
        };
        let eta = if entering { 1.0 / m.ior } else { m.ior };
        let view = -d;

        let mut color = Rgb::ZERO;
        if entering || material.two_sided_emission {
            // Emitters face their geometric normal unless two-sided.
            color += material.emission_at(sp.p, sp.uv, sp.ng);
        }
        let kd = m.diffuse.eval(sp.p, sp.uv, sp.ng);
        color += m.ambient.unwrap_or(kd) * ctx.scene.ambient;
        color += self.direct(material, kd, sp, ng, n, view);

        if depth + 1 >= self.options.max_depth {
            return color;
        }
        let fresnel = self.options.fresnel || m.fresnel;
        let cos_i = view.dot(n).clamp(0.0, 1.0);
        // A thin sheet passes light straight on (both sides are outside) and is smooth.
        let transmits = m.thin || refract(d, n, eta).is_some();
        let roughness = if m.thin { 0.0 } else { m.roughness };
        let specular = m.specular_at(sp.p, sp.uv, sp.ng);
        let (ks, kt) = if fresnel {
            // 1 under total internal reflection: everything goes to ks·S.
            let reflectance = if m.thin {
                m.thin_reflectance(cos_i)
            } else {
                fresnel_dielectric(cos_i, eta)
            };
            (specular * reflectance, m.transmission * (1.0 - reflectance))
        } else {
            (specular, m.transmission)
        };
        // A metal's mirror is weighted by its complex Fresnel reflectance at this angle.
        let ks = match m.conductor_at(sp.p, sp.uv, sp.ng) {
            Some(c) => specular * c.reflectance(cos_i),
            None => ks,
        };

        let (ks_weight, kt_weight) = (weight * ks.max_element(), weight * kt.max_element());
        if ks_weight > self.options.cutoff {
            let dir = self.perturbed(n, ng, roughness, |n| reflect(d, n), 1.0);
            let r = sp.spot().spawn(dir).at_time(self.time);
            color += ks * self.trace(&r, depth + 1, ks_weight).0;
        }
        // T is zero under total internal reflection (the paper's imaginary kf).
        if kt_weight > self.options.cutoff && transmits {
            let dir = if m.thin {
                d
            } else {
                self.perturbed(
                    n,
                    ng,
                    m.roughness,
                    |n| refract(d, n, eta).unwrap_or(d),
                    -1.0,
                )
            };
            let r = sp.spot().spawn(dir).at_time(self.time);
            color += kt * self.trace(&r, depth + 1, kt_weight).0;
        }
        color
    }

    /// The diffuse term Σ kd/π·(N·L)·E, the Phong highlight, and a translucent sheet's
    /// kdt/π·|N·L|·E of the lights behind it, with shadow rays.
    fn direct(
        &mut self,
        material: &Material,
        kd: Rgb,
        sp: &SurfacePoint,
        ng: Vec3,
        n: Vec3,
        view: Vec3,
    ) -> Rgb {
        let ctx = self.ctx;
        let m = material.approximation();
        let p = sp.p;
        let at = sp.spot();
        // A tabulated reflectance takes the diffuse term's place: f toward the view.
        let table = material.model().table().map(|t| Bsdf::tabulated(t, n, ng));
        let reflect = |wi: Vec3| match &table {
            Some(b) => b.eval(view, wi, Transport::Radiance) / n.dot(wi),
            None => kd * FRAC_1_PI,
        };
        let diffuse_on = kd.max_element() > 0.0 || table.is_some();
        let highlight_on = m.specular.max_element() > 0.0 && m.phong_exponent > 0.0;
        // A translucent sheet passes kdt/π of the light from behind it.
        let kdt = m.diffuse_transmission.eval(p, sp.uv, sp.ng);
        let translucent = kdt.max_element() > 0.0;
        if !diffuse_on && !highlight_on && !translucent {
            return Rgb::ZERO;
        }
        let mut color = Rgb::ZERO;
        for light in &ctx.scene.lights {
            let Some(Illumination {
                wi,
                irradiance,
                position: target,
            }) = light.model().illuminate(p)
            else {
                continue;
            };
            let cos = n.dot(wi);
            let front = cos > 0.0 && ng.dot(wi) > 0.0;
            let behind = translucent && cos < 0.0 && ng.dot(wi) < 0.0;
            if !front && !behind {
                continue;
            }
            let transmittance = self.transmittance(&at, wi, target.map(Spot::exact));
            if transmittance == Rgb::ZERO {
                continue;
            }
            if behind {
                color += kdt * FRAC_1_PI * (irradiance * -cos * transmittance);
                continue;
            }
            let e = irradiance * cos * transmittance;
            color += reflect(wi) * e;
            if highlight_on {
                // Energy-normalised Blinn-Phong lobe: (n+8)/(8π)·(N·H)^n.
                let h = (wi + view).normalize();
                let spec = (m.phong_exponent + 8.0) / (8.0 * PI)
                    * n.dot(h).max(0.0).powf(m.phong_exponent);
                color += m.specular_at_normal() * spec * e;
            }
        }
        if diffuse_on {
            for light in &ctx.area_lights {
                color += match table {
                    Some(_) => self.area_light(light, &at, ng, n, Some(&reflect)),
                    None => kd * FRAC_1_PI * self.area_light(light, &at, ng, n, None),
                };
            }
        }
        if translucent {
            for light in &ctx.area_lights {
                color += kdt * FRAC_1_PI * self.area_light(light, &at, -ng, -n, None);
            }
        }
        color
    }

    /// Irradiance at `p` from an area light, or with `reflect` (f toward the view, by the
    /// direction to the light) the light reflected, by stratified sampling of its area, each
    /// sample with its own shadow ray.
    fn area_light(
        &mut self,
        light: &crate::scene::lights::AreaLight,
        at: &Spot,
        ng: Vec3,
        n: Vec3,
        reflect: Option<&dyn Fn(Vec3) -> Rgb>,
    ) -> Rgb {
        let side = (self.options.area_samples.max(1) as f32).sqrt().ceil() as u32;
        let count = side * side;
        let p = at.p;
        let mut sum = Rgb::ZERO;
        for i in 0..count {
            let u = Vec2::new(
                ((i % side) as f32 + self.rng.uniform()) / side as f32,
                ((i / side) as f32 + self.rng.uniform()) / side as f32,
            );
            let y = light.sample(u);
            let to = y.p - p;
            let d2 = to.length_squared();
            if d2 <= 0.0 {
                continue;
            }
            let wi = to / d2.sqrt();
            let cos_s = n.dot(wi);
            let cos_l = light.emitting_cos(-y.n.dot(wi));
            if cos_s <= 0.0 || cos_l <= 0.0 || ng.dot(wi) <= 0.0 {
                continue;
            }
            let t = self.transmittance(at, wi, Some(y.spot()));
            let e = light.radiance_at(&y) * t * (cos_s * cos_l / d2);
            sum += reflect.map_or(e, |f| f(wi) * e);
        }
        sum * (light.area / count as f32)
    }

    /// How much light gets from `from` to the light: 1 if nothing is in the way, the product
    /// of the kt of transmissive occluders, 0 behind an opaque one. `target` None is a light
    /// at infinity in direction `wi`.
    fn transmittance(&mut self, from: &Spot, wi: Vec3, target: Option<Spot>) -> Rgb {
        let ctx = self.ctx;
        let time = self.time;
        let towards_light = |from: Spot| {
            match &target {
                Some(end) => from.spawn_to(end),
                None => from.spawn(wi),
            }
            .at_time(time)
        };
        let mut ray = towards_light(*from);
        if !ctx.occluded(&ray, self.stats) {
            return Rgb::ONE;
        }
        // Something is in the way: walk through it, multiplying kt.
        let mut t = Rgb::ONE;
        for _ in 0..MAX_SHADOW_CROSSINGS {
            let Some(hit) = ctx.intersect(&ray, self.stats) else {
                return t;
            };
            let m = &ctx.scene.materials[hit.material];
            if !m.is_transmissive() {
                return Rgb::ZERO;
            }
            t *= m.approximation().transmission;
            if t.max_element() < self.options.cutoff {
                return Rgb::ZERO;
            }
            ray = towards_light(hit.spot());
        }
        Rgb::ZERO
    }

    /// A direction computed from a randomly perturbed normal (Whitted's microfacet jitter),
    /// redrawn until it leaves on the intended side (`side` +1: reflection, −1: transmission)
    /// of the geometric surface; falls back to the unperturbed normal.
    fn perturbed(
        &mut self,
        n: Vec3,
        ng: Vec3,
        roughness: f32,
        direction: impl Fn(Vec3) -> Vec3,
        side: f32,
    ) -> Vec3 {
        if roughness > 0.0 {
            let (t, b) = frame(n);
            for _ in 0..PERTURB_TRIES {
                // A microfacet normal from the GGX distribution D(h) cos θh with α =
                // roughness, the same meaning the Monte Carlo BSDFs give it:
                // tan²θ = α² u / (1 − u).
                let u = self.rng.uniform();
                let tan2 = roughness * roughness * u / (1.0 - u).max(1e-7);
                let cos = 1.0 / (1.0 + tan2).sqrt();
                let sin = (1.0 - cos * cos).max(0.0).sqrt();
                let phi = std::f32::consts::TAU * self.rng.uniform();
                let np = (n * cos + (t * phi.cos() + b * phi.sin()) * sin).normalize();
                let dir = direction(np);
                if dir.dot(ng) * side > 0.0 {
                    return dir;
                }
            }
        }
        direction(n)
    }
}

impl Integrator for Whitted {
    fn radiance(&self, ctx: &Context, ray: &Ray, rng: &mut Rng, stats: &mut RayStats) -> Sample {
        let mut tree = RayTree {
            options: &self.options,
            ctx,
            rng,
            stats,
            time: ray.time,
        };
        let (radiance, object) = tree.trace(ray, 0, 1.0);
        Sample { radiance, object }
    }
}

// The technique: what it says of itself, its settings and its lifecycle.

/// Whitted's integrator, as the technique list shows it.
pub(crate) const TECHNIQUE: TechniqueInfo = TechniqueInfo {
    kind: TechniqueKind::Whitted,
    summary: "Whitted 1980: recursive reflection, refraction and shadows.",
    settings: &[
        COMMON,
        PIXELS,
        &[
            Setting {
                name: "area_samples",
                scene_key: Some(("render.whitted", "area_samples")),
                example: "16",
                doc: "Shadow rays per area light at each shading point (default 16).",
            },
            Setting {
                name: "fresnel",
                scene_key: Some(("render.whitted", "fresnel")),
                example: "true",
                doc: "Weight reflection and transmission by Fresnel's law on every material.",
            },
        ],
    ],
    pbrt: &[],
    progressive: false,
    renders_parts: true,
    follows_time: true,
    media: false,
};

/// Whitted's integrator's settings, checked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WhittedSettings {
    pub max_depth: u32,
    pub area_samples: u32,
    pub fresnel: bool,
    pub sampling: PixelSampling,
}

impl WhittedSettings {
    /// From the parameter set, with the defaults, every value checked.
    pub(crate) fn from_settings(s: &Settings, max_depth: u32) -> Result<WhittedSettings> {
        Ok(WhittedSettings {
            max_depth: max_depth.max(1),
            area_samples: at_most("area_samples", s.area_samples.unwrap_or(16), 1 << 16)?,
            fresnel: s.fresnel.unwrap_or(false),
            sampling: PixelSampling::from_settings(s)?,
        })
    }

    /// What of them changes pixels, for a job's settings key.
    pub(crate) fn key(&self) -> String {
        format!(
            " {} area_samples={} fresnel={}",
            self.sampling.key(),
            self.area_samples,
            self.fresnel
        )
    }

    /// The technique: nothing to prepare, one pass of pixels.
    pub(crate) fn lifecycle(&self) -> Box<dyn Lifecycle> {
        Box::new(WhittedTechnique {
            integrator: Whitted::new(WhittedOptions {
                max_depth: self.max_depth,
                area_samples: self.area_samples,
                fresnel: self.fresnel,
                ..WhittedOptions::default()
            }),
            sampling: self.sampling,
        })
    }
}

struct WhittedTechnique {
    integrator: Whitted,
    sampling: PixelSampling,
}

impl Lifecycle for WhittedTechnique {
    fn tiles(&self) -> Tiles<'_> {
        Tiles::Pixels(&self.integrator, self.sampling)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn snell_law_holds_and_total_internal_reflection_is_detected() {
        let n = Vec3::Y;
        let theta: f32 = 0.5;
        let d = Vec3::new(theta.sin(), -theta.cos(), 0.0);
        let t = refract(d, n, 1.0 / 1.5).unwrap();
        let sin_t = t.x / t.length();
        assert!((theta.sin() - 1.5 * sin_t).abs() < 1e-6);
        assert!(t.y < 0.0);
        // Leaving glass at 60 degrees exceeds the critical angle asin(1/1.5) = 41.8 degrees.
        let steep = Vec3::new(60f32.to_radians().sin(), -60f32.to_radians().cos(), 0.0);
        assert!(refract(steep, n, 1.5).is_none());
        assert!(refract(steep, n, 1.0 / 1.5).is_some());
    }

    #[test]
    fn fresnel_matches_normal_incidence_and_total_reflection() {
        let r0 = ((1.0f32 - 1.5) / (1.0 + 1.5)).powi(2);
        assert!((fresnel_dielectric(1.0, 1.0 / 1.5) - r0).abs() < 1e-6);
        assert_eq!(fresnel_dielectric(0.3, 1.5), 1.0);
        assert!(fresnel_dielectric(0.01, 1.0 / 1.5) > 0.9);
    }
}
