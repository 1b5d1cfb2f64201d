//! Reflection, refraction and the Fresnel equations for dielectrics.

use super::Vec3;

/// Mirror reflection of the incident direction `d` (pointing at the surface) about `n`.
pub fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    d - 2.0 * d.dot(n) * n
}

/// Refraction of the incident direction `d` through a surface with normal `n` facing the
/// incident side, with `eta` = n_incident / n_transmitted; `None` under total internal
/// reflection.
pub fn refract(d: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = -d.dot(n);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t > 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((eta * d + (eta * cos_i - cos_t) * n).normalize())
}

/// Unpolarised Fresnel reflectance of a dielectric interface for the cosine `cos_i` of the
/// incident angle and `eta` = n_incident / n_transmitted; 1 under total internal reflection.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (rs * rs + rp * rp)
}

/// Reflectance of a thin dielectric sheet of index `ior` in vacuum (pbrt-v4's
/// `ThinDielectricBxDF`) for the cosine `cos_i` of the incident angle on either side: the
/// first interface reflects F, and of the light that enters, the share bouncing between the
/// two parallel interfaces and leaving back is summed as a geometric series,
/// R = F + (1 − F)²F / (1 − F²). The sheet transmits 1 − R, undeviated.
pub(crate) fn fresnel_thin_dielectric(cos_i: f32, ior: f32) -> f32 {
    let r = fresnel_dielectric(cos_i.abs(), 1.0 / ior);
    if r < 1.0 {
        let t = 1.0 - r;
        r + t * t * r / (1.0 - r * r)
    } else {
        r
    }
}

/// The cosine-weighted mean of a dielectric's Fresnel reflectance over the hemisphere,
/// 2∫₀¹ F(μ) μ dμ (what the interface reflects of light arriving evenly from every
/// direction), for `eta` = n_incident / n_transmitted, by the midpoint rule at 1024 points
/// (within 1e-4 of the integral). The last value of each thread is kept: a scene asks for
/// few etas.
pub(crate) fn fresnel_dielectric_mean(eta: f32) -> f32 {
    thread_local! {
        static LAST: std::cell::Cell<(u32, f32)> = const { std::cell::Cell::new((u32::MAX, 0.0)) };
    }
    let (key, value) = LAST.get();
    if key == eta.to_bits() {
        return value;
    }
    const N: u32 = 1024;
    let sum: f64 = (0..N)
        .map(|i| {
            let mu = (i as f32 + 0.5) / N as f32;
            2.0 * (fresnel_dielectric(mu, eta) * mu) as f64
        })
        .sum();
    let mean = (sum / N as f64) as f32;
    LAST.set((eta.to_bits(), mean));
    mean
}

/// Unpolarised Fresnel reflectance of a conductor (pbrt-v4's `FrComplex`) for the cosine
/// `cos_i` of the incident angle and the complex index η + ik of the metal relative to the
/// outside medium.
pub(crate) fn fresnel_complex(cos_i: f32, eta: f32, k: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_i = 1.0 - cos_i * cos_i;
    let n = Complex(eta, k);
    // sin²θt = sin²θi / η², cos θt = √(1 − sin²θt), both complex.
    let sin2_t = Complex(sin2_i, 0.0).div(n.mul(n));
    let cos_t = Complex(1.0 - sin2_t.0, -sin2_t.1).sqrt();
    let ci = Complex(cos_i, 0.0);
    let n_ci = n.mul(ci);
    let r_parl = n_ci.sub(cos_t).div(n_ci.add(cos_t));
    let n_ct = n.mul(cos_t);
    let r_perp = ci.sub(n_ct).div(ci.add(n_ct));
    0.5 * (r_parl.norm() + r_perp.norm())
}

/// [`fresnel_complex`] per colour channel.
pub(crate) fn fresnel_conductor(cos_i: f32, eta: Vec3, k: Vec3) -> Vec3 {
    Vec3::new(
        fresnel_complex(cos_i, eta.x, k.x),
        fresnel_complex(cos_i, eta.y, k.y),
        fresnel_complex(cos_i, eta.z, k.z),
    )
}

/// Just enough complex arithmetic for [`fresnel_complex`]: (re, im).
#[derive(Clone, Copy)]
struct Complex(f32, f32);

impl Complex {
    fn add(self, o: Complex) -> Complex {
        Complex(self.0 + o.0, self.1 + o.1)
    }
    fn sub(self, o: Complex) -> Complex {
        Complex(self.0 - o.0, self.1 - o.1)
    }
    fn mul(self, o: Complex) -> Complex {
        Complex(self.0 * o.0 - self.1 * o.1, self.0 * o.1 + self.1 * o.0)
    }
    fn div(self, o: Complex) -> Complex {
        let d = o.norm();
        Complex(
            (self.0 * o.0 + self.1 * o.1) / d,
            (self.1 * o.0 - self.0 * o.1) / d,
        )
    }
    /// |z|².
    fn norm(self) -> f32 {
        self.0 * self.0 + self.1 * self.1
    }
    /// The principal square root (non-negative real part), as pbrt's `pstd::sqrt`.
    fn sqrt(self) -> Complex {
        let n = self.norm().sqrt();
        if n == 0.0 {
            return Complex(0.0, 0.0);
        }
        let t1 = (0.5 * (n + self.0.abs())).sqrt();
        let t2 = 0.5 * self.1 / t1;
        if self.0 >= 0.0 {
            Complex(t1, t2)
        } else {
            Complex(t2.abs(), t1.copysign(self.1))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With k = 0 the complex equations are the dielectric ones; at normal incidence they
    /// give ((η−1)² + k²) / ((η+1)² + k²); at grazing incidence every conductor reflects all.
    #[test]
    fn complex_fresnel_matches_closed_forms() {
        for cos in [0.05f32, 0.3, 0.7, 1.0] {
            let a = fresnel_complex(cos, 1.5, 0.0);
            let b = fresnel_dielectric(cos, 1.0 / 1.5);
            assert!((a - b).abs() < 1e-5, "cos {cos}: {a} vs {b}");
        }
        let (n, k) = (0.200438f32, 3.91295f32);
        let f0 = ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k);
        assert!((fresnel_complex(1.0, n, k) - f0).abs() < 1e-5);
        assert!((fresnel_complex(0.0, n, k) - 1.0).abs() < 1e-5);
    }

    /// The mean Fresnel reflectance against a fine integration, and against physics: an
    /// interface lets through from inside what it lets through from outside divided by η²
    /// (1 − F̄(η) = (1 − F̄(1/η)) / η²), and none of it at η = 1. Glass (1.5) from outside
    /// reflects about 9.2% of even light.
    #[test]
    fn mean_fresnel_reflectance() {
        for eta in [1.0f32 / 2.4, 1.0 / 1.5, 1.0 / 1.33, 1.33, 1.5, 2.4] {
            let n = 1_000_000;
            let fine: f64 = (0..n)
                .map(|i| {
                    let mu = (i as f64 + 0.5) / n as f64;
                    2.0 * fresnel_dielectric(mu as f32, eta) as f64 * mu
                })
                .sum::<f64>()
                / n as f64;
            let mean = fresnel_dielectric_mean(eta) as f64;
            assert!((mean - fine).abs() < 1e-4, "eta {eta}: {mean} vs {fine}");
            if eta > 1.0 {
                let outside = fresnel_dielectric_mean(1.0 / eta) as f64;
                let through = (1.0 - outside) / (eta as f64 * eta as f64);
                assert!(
                    (1.0 - mean - through).abs() < 1e-3,
                    "eta {eta}: {mean} vs {through}"
                );
            }
        }
        assert!(fresnel_dielectric_mean(1.0) < 1e-6);
        let glass = fresnel_dielectric_mean(1.0 / 1.5);
        assert!((glass - 0.092).abs() < 0.002, "{glass}");
    }
}
