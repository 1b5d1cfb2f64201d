//! Pixel reconstruction filters, used in one of two ways ([`Reconstruction`]): each camera
//! sample is splatted into every pixel the filter reaches, weighted (as Mitsuba 3 does), or
//! its offset from its pixel centre is drawn from the filter's own distribution so that it
//! counts in its own pixel alone (filter importance sampling, as pbrt-v4 does).

use crate::math::{erfc, Vec2};

/// How a Monte Carlo film turns camera samples into pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reconstruction {
    /// Samples spread uniformly over their pixel, each added to every pixel within the
    /// filter's radius with the filter's weight; a pixel is its weighted mean. Neighbours
    /// share samples, so the noise per sample is lower (about half the variance with the
    /// default Gaussian).
    Splat,
    /// Sample offsets drawn from the filter, each sample counted in its own pixel alone: a
    /// pixel depends on its own samples only, which the animation renderer needs to copy
    /// unchanged blocks.
    Importance,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Filter {
    /// Constant over a square of half-width `radius` (0.5 is one pixel).
    Box { radius: f32 },
    /// Tent, falling linearly to zero at `radius`.
    Triangle { radius: f32 },
    /// Gaussian of standard deviation `sigma`, truncated at `radius`.
    Gaussian { radius: f32, sigma: f32 },
}

impl Default for Filter {
    /// pbrt-v4's default: a Gaussian of radius 1.5 pixels and sigma 0.5.
    fn default() -> Self {
        Filter::Gaussian {
            radius: 1.5,
            sigma: 0.5,
        }
    }
}

/// As scene files name it: `gaussian radius=1.5 sigma=0.5`.
impl std::fmt::Display for Filter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Filter::Box { radius } => write!(f, "box radius={radius}"),
            Filter::Triangle { radius } => write!(f, "triangle radius={radius}"),
            Filter::Gaussian { radius, sigma } => {
                write!(f, "gaussian radius={radius} sigma={sigma}")
            }
        }
    }
}

impl Filter {
    /// The filter `name`d as scene files name it ("box", "triangle", "gaussian") with
    /// `radius`, or its default one (0.5, 2 and 1.5 pixels; a Gaussian's sigma is 0.5): what
    /// a scene file, the command line and the Python package give for a name alone.
    pub fn named(name: &str, radius: Option<f32>) -> Option<Filter> {
        Some(match name {
            "box" => Filter::Box {
                radius: radius.unwrap_or(0.5),
            },
            "triangle" => Filter::Triangle {
                radius: radius.unwrap_or(2.0),
            },
            "gaussian" => Filter::Gaussian {
                radius: radius.unwrap_or(1.5),
                sigma: 0.5,
            },
            _ => return None,
        })
    }

    /// The same filter with another radius (a Gaussian keeps its sigma).
    /// The filter a front end's options give over the scene's (`scene`, default Gaussian):
    /// a named filter with `radius` or its default radius, or `radius` alone for the
    /// scene's filter; `None` if neither is given, `Err` naming an unknown name.
    pub fn given(
        scene: Option<Filter>,
        name: Option<&str>,
        radius: Option<f32>,
    ) -> Result<Option<Filter>, String> {
        match (name, radius) {
            (None, None) => Ok(None),
            (None, Some(r)) => Ok(Some(scene.unwrap_or_default().with_radius(r))),
            (Some(name), r) => Filter::named(&name.to_ascii_lowercase(), r)
                .map(Some)
                .ok_or_else(|| {
                    format!("must be one of \"box\", \"triangle\", \"gaussian\", got \"{name}\"")
                }),
        }
    }

    pub fn with_radius(self, radius: f32) -> Filter {
        match self {
            Filter::Box { .. } => Filter::Box { radius },
            Filter::Triangle { .. } => Filter::Triangle { radius },
            Filter::Gaussian { sigma, .. } => Filter::Gaussian { radius, sigma },
        }
    }

    pub fn radius(&self) -> f32 {
        match *self {
            Filter::Box { radius }
            | Filter::Triangle { radius }
            | Filter::Gaussian { radius, .. } => radius,
        }
    }

    /// Checks the parameters; the message names the problem.
    pub fn validate(&self) -> Result<(), String> {
        let r = self.radius();
        if !(r.is_finite() && r > 0.0 && r <= 16.0) {
            return Err(format!("filter radius must be in (0, 16] pixels, got {r}"));
        }
        if let Filter::Gaussian { sigma, .. } = *self {
            if !(sigma.is_finite() && sigma > 0.0) {
                return Err(format!(
                    "Gaussian filter sigma must be positive, got {sigma}"
                ));
            }
        }
        Ok(())
    }

    /// The filter's value at offset `d` from the pixel centre (not normalised).
    pub fn eval(&self, d: Vec2) -> f32 {
        let r = self.radius();
        if d.x.abs() > r || d.y.abs() > r {
            return 0.0;
        }
        match *self {
            Filter::Box { .. } => 1.0,
            Filter::Triangle { radius } => (radius - d.x.abs()) * (radius - d.y.abs()),
            Filter::Gaussian { radius, sigma } => {
                gaussian_1d(d.x, radius, sigma) * gaussian_1d(d.y, radius, sigma)
            }
        }
    }

    /// The 1-D profile at offset `d` along one axis (`eval` is the product of two).
    fn profile(&self, d: f32) -> f32 {
        if d.abs() > self.radius() {
            return 0.0;
        }
        match *self {
            Filter::Box { .. } => 1.0,
            Filter::Triangle { radius } => radius - d.abs(),
            Filter::Gaussian { radius, sigma } => gaussian_1d(d, radius, sigma),
        }
    }

    /// An offset from the pixel centre distributed like the filter, for `u` uniform in
    /// [0,1)². The filters are separable, so each axis is sampled on its own.
    pub fn sample(&self, u: Vec2) -> Vec2 {
        Vec2::new(self.sample_1d(u.x), self.sample_1d(u.y))
    }

    fn sample_1d(&self, u: f32) -> f32 {
        match *self {
            Filter::Box { radius } => (2.0 * u - 1.0) * radius,
            Filter::Triangle { radius } => {
                // Inverse CDF of the tent on [-r, r].
                if u < 0.5 {
                    radius * ((2.0 * u).sqrt() - 1.0)
                } else {
                    radius * (1.0 - (2.0 - 2.0 * u).sqrt())
                }
            }
            Filter::Gaussian { radius, sigma } => {
                // Inverse CDF of the normal restricted to [-r, r].
                let lo = normal_cdf(-radius / sigma);
                let hi = normal_cdf(radius / sigma);
                let p = (lo + u as f64 * (hi - lo)).clamp(1e-12, 1.0 - 1e-12);
                ((sigma as f64 * normal_quantile(p)) as f32).clamp(-radius, radius)
            }
        }
    }
}

/// The filter's weights through a table of its 1-D profile (every filter here is the
/// product of one profile per axis), so that splatting a sample costs a few lookups.
#[derive(Clone, Debug)]
pub(crate) struct FilterWeights {
    radius: f32,
    /// Profile at |d| = i · radius / (len − 1).
    table: Vec<f32>,
}

impl FilterWeights {
    const SIZE: usize = 1025;

    pub fn new(filter: Filter) -> FilterWeights {
        let r = filter.radius();
        let table = (0..Self::SIZE)
            .map(|i| filter.profile(i as f32 * r / (Self::SIZE - 1) as f32))
            .collect();
        FilterWeights { radius: r, table }
    }

    pub fn radius(&self) -> f32 {
        self.radius
    }

    /// The weight along one axis at offset `d` from a pixel centre: zero beyond the radius.
    pub(crate) fn weight_1d(&self, d: f32) -> f32 {
        let x = d.abs() / self.radius * (Self::SIZE - 1) as f32;
        if x.is_nan() || x > (Self::SIZE - 1) as f32 {
            return 0.0;
        }
        let i = (x as usize).min(Self::SIZE - 2);
        let f = x - i as f32;
        self.table[i] * (1.0 - f) + self.table[i + 1] * f
    }
}

/// Draws filter offsets through a tabulated inverse CDF per axis, so that sampling costs a
/// table lookup whatever the filter (the Gaussian's exact inverse takes several
/// transcendental functions).
#[derive(Clone, Debug)]
pub(crate) struct FilterSampler {
    radius: f32,
    /// Inverse CDF at u = i / (len − 1).
    table: Vec<f32>,
}

impl FilterSampler {
    const SIZE: usize = 1025;

    pub fn new(filter: Filter) -> FilterSampler {
        let table = (0..Self::SIZE)
            .map(|i| filter.sample_1d(i as f32 / (Self::SIZE - 1) as f32))
            .collect();
        FilterSampler {
            radius: filter.radius(),
            table,
        }
    }

    pub fn sample(&self, u: Vec2) -> Vec2 {
        Vec2::new(self.lookup(u.x), self.lookup(u.y))
    }

    fn lookup(&self, u: f32) -> f32 {
        let x = u.clamp(0.0, 1.0) * (Self::SIZE - 1) as f32;
        let i = (x as usize).min(Self::SIZE - 2);
        let f = x - i as f32;
        (self.table[i] * (1.0 - f) + self.table[i + 1] * f).clamp(-self.radius, self.radius)
    }
}

/// A Gaussian shifted down so that it reaches zero at the radius (pbrt's form).
fn gaussian_1d(x: f32, radius: f32, sigma: f32) -> f32 {
    let g = |x: f32| (-x * x / (2.0 * sigma * sigma)).exp();
    (g(x) - g(radius)).max(0.0)
}

fn normal_cdf(x: f32) -> f64 {
    0.5 * erfc(-(x as f64) / std::f64::consts::SQRT_2)
}

/// Quantile of the standard normal: Acklam's rational approximation refined by one Halley
/// step on the CDF above.
fn normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969683028665376e1,
        2.209460984245205e2,
        -2.759285104469687e2,
        1.383_577_518_672_69e2,
        -3.066479806614716e1,
        2.506628277459239,
    ];
    const B: [f64; 5] = [
        -5.447609879822406e1,
        1.615858368580409e2,
        -1.556989798598866e2,
        6.680131188771972e1,
        -1.328068155288572e1,
    ];
    const C: [f64; 6] = [
        -7.784894002430293e-3,
        -3.223964580411365e-1,
        -2.400758277161838,
        -2.549732539343734,
        4.374664141464968,
        2.938163982698783,
    ];
    const D: [f64; 4] = [
        7.784695709041462e-3,
        3.224671290700398e-1,
        2.445134137142996,
        3.754408661907416,
    ];
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    let x = if p < 0.02425 {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - 0.02425 {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    };
    let e = 0.5 * erfc(-x / std::f64::consts::SQRT_2) - p;
    let u = e * (2.0 * std::f64::consts::PI).sqrt() * (x * x / 2.0).exp();
    x - u / (1.0 + x * u / 2.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Histogram of sampled offsets against the filter's normalised profile, per axis.
    fn check_sampling(f: Filter) {
        let table = FilterSampler::new(f);
        let r = f.radius();
        let bins = 20;
        let n = 200_000;
        let mut hist = vec![0f64; bins];
        let mut rng = crate::math::Rng::for_key(1, &[]);
        for _ in 0..n {
            // The tabulated sampler is the one renders use.
            let d = table.sample(Vec2::new(rng.uniform(), rng.uniform()));
            assert!(d.x.abs() <= r && d.y.abs() <= r);
            let b = (((d.x + r) / (2.0 * r)) * bins as f32) as usize;
            hist[b.min(bins - 1)] += 1.0 / n as f64;
        }
        // Expected mass per bin from the 1-D profile, integrated numerically.
        let profile = |x: f32| f.eval(Vec2::new(x, 0.0)) as f64;
        let steps = 200;
        let mut expected: Vec<f64> = (0..bins)
            .map(|b| {
                let x0 = -r + 2.0 * r * b as f32 / bins as f32;
                let h = 2.0 * r / bins as f32 / steps as f32;
                (0..steps)
                    .map(|k| profile(x0 + (k as f32 + 0.5) * h))
                    .sum::<f64>()
            })
            .collect();
        let total: f64 = expected.iter().sum();
        expected.iter_mut().for_each(|e| *e /= total);
        for (h, e) in hist.iter().zip(&expected) {
            assert!((h - e).abs() < 0.004, "{f:?}: bin {h} vs {e}");
        }
    }

    #[test]
    fn samples_follow_each_filter() {
        check_sampling(Filter::Box { radius: 0.5 });
        check_sampling(Filter::Triangle { radius: 2.0 });
        check_sampling(Filter::default());
    }

    /// The tabulated weights are the filter's own: products of the 1-D table match `eval`
    /// everywhere within a small tolerance, and are zero beyond the radius.
    #[test]
    fn tabulated_weights_match_the_filter() {
        for f in [
            Filter::Box { radius: 0.5 },
            Filter::Triangle { radius: 2.0 },
            Filter::default(),
            Filter::Gaussian {
                radius: 2.0,
                sigma: 0.5,
            },
        ] {
            let w = FilterWeights::new(f);
            let r = f.radius();
            let peak = f.eval(Vec2::ZERO);
            for i in -60..=60 {
                for j in -60..=60 {
                    // Steps that avoid the box's discontinuity exactly at the radius.
                    let d = Vec2::new(i as f32 * r / 50.3, j as f32 * r / 50.7);
                    let tabulated = w.weight_1d(d.x) * w.weight_1d(d.y);
                    let exact = f.eval(d);
                    assert!(
                        (tabulated - exact).abs() <= 1e-5 * peak,
                        "{f:?} at {d:?}: {tabulated} vs {exact}"
                    );
                }
            }
            assert_eq!(w.weight_1d(r * 1.01), 0.0);
            assert_eq!(w.weight_1d(f32::NAN), 0.0);
        }
    }

    #[test]
    fn bad_parameters_are_rejected() {
        assert!(Filter::Box { radius: 0.0 }.validate().is_err());
        assert!(Filter::Gaussian {
            radius: 1.0,
            sigma: -1.0
        }
        .validate()
        .is_err());
        assert!(Filter::default().validate().is_ok());
    }
}
