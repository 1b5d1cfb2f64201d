//! One cached indirect irradiance value and the secondary method's rules for using it (Ward,
//! Rubinstein & Clear 1988, section 3.2).

use super::gradients::Gradients;
use crate::math::{Rgb, Vec3};

/// A primary value: indirect irradiance `e` at `p` with unit normal `n`, `r`, the harmonic
/// mean distance to the surfaces seen by its sample rays, and the gradients of `e` (zero
/// when not computed).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Record {
    pub p: Vec3,
    pub n: Vec3,
    pub e: Rgb,
    pub r: f32,
    pub grad: Gradients,
}

impl Record {
    /// The value extrapolated to (`p`, `n`) by its gradients (Ward & Heckbert 1992), never
    /// negative; `e` itself without gradients.
    pub fn extrapolated(&self, p: Vec3, n: Vec3) -> Rgb {
        if self.grad == Gradients::default() {
            return self.e;
        }
        (self.e + self.grad.change(self.p, self.n, p, n)).max(Rgb::ZERO)
    }

    /// The weight of eq. 5, w_i(P) = 1 / (|P − Pi| / Ri + sqrt(1 − N(P)·N(Pi))). Infinite when
    /// P = Pi and the normals agree.
    pub fn weight(&self, p: Vec3, n: Vec3) -> f32 {
        let err = (p - self.p).length() / self.r + (1.0 - n.dot(self.n)).max(0.0).sqrt();
        1.0 / err
    }

    /// Eq. 6: d_i(P) = (P − Pi)·(N(P) + N(Pi)) / 2. Negative means Pi is in front of P.
    pub fn front_distance(&self, p: Vec3, n: Vec3) -> f32 {
        (p - self.p).dot(n + self.n) * 0.5
    }

    /// Whether the value belongs to S at P for accuracy `a`: w_i > 1/a and d_i(P) ≥ 0 (the
    /// search of section 3.3). Returns the weight when it does.
    pub fn accept(&self, p: Vec3, n: Vec3, a: f32) -> Option<f32> {
        // w_i > 1/a implies |P − Pi| < a·Ri: most values in the nodes a search visits fail
        // this, without the square roots of the weight.
        let domain = a * self.r;
        if (p - self.p).length_squared() >= domain * domain {
            return None;
        }
        let w = self.weight(p, n);
        (w > 1.0 / a && self.front_distance(p, n) >= 0.0).then_some(w)
    }
}

#[cfg(test)]
/// Eq. 5: Σ w_i E_i / Σ w_i over the accepted values, in the order given. A value at P itself
/// (infinite weight) is returned as is. None when nothing was accepted (S is empty).
pub fn weighted_average(accepted: &[(f32, Rgb)]) -> Option<Rgb> {
    let mut sum = WeightedSum::default();
    for &(w, e) in accepted {
        sum.add(w, e);
    }
    sum.average()
}

/// Eq. 5 accumulated one accepted value at a time, so that a search need not collect S.
#[derive(Clone, Copy, Debug, Default)]
pub struct WeightedSum {
    sw: f32,
    se: Rgb,
    /// The first value at P itself (infinite weight), which is the answer when present.
    exact: Option<Rgb>,
}

impl WeightedSum {
    pub fn add(&mut self, w: f32, e: Rgb) {
        if w.is_infinite() {
            self.exact.get_or_insert(e);
        } else {
            self.sw += w;
            self.se += e * w;
        }
    }

    /// The weighted average, or None when nothing was added (S is empty).
    pub fn average(&self) -> Option<Rgb> {
        self.exact.or((self.sw > 0.0).then(|| self.se / self.sw))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec(p: [f32; 3], n: [f32; 3], e: f32, r: f32) -> Record {
        Record {
            p: Vec3::from(p),
            n: Vec3::from(n).normalize(),
            e: Rgb::splat(e),
            r,
            grad: Gradients::default(),
        }
    }

    #[test]
    fn weight_by_hand() {
        let r = rec([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 1.0, 2.0);
        let up = Vec3::Z;
        // |P − Pi| = 1, R = 2, same normal: w = 1 / 0.5 = 2.
        assert!((r.weight(Vec3::new(1.0, 0.0, 0.0), up) - 2.0).abs() < 1e-6);
        // Same point, normal at 60°: N·Ni = 0.5, w = 1 / sqrt(0.5) = √2.
        let n60 = Vec3::new(3f32.sqrt() / 2.0, 0.0, 0.5);
        assert!((r.weight(Vec3::ZERO, n60) - 2f32.sqrt()).abs() < 1e-6);
        // Both: |P − Pi| = 0.5 → 0.25, N·Ni = 0.96 → 0.2; w = 1 / 0.45.
        let n = Vec3::new(0.28, 0.0, 0.96);
        assert!((r.weight(Vec3::new(0.0, 0.5, 0.0), n) - 1.0 / 0.45).abs() < 1e-5);
        assert!(r.weight(Vec3::ZERO, up).is_infinite());
    }

    #[test]
    fn set_s_and_in_front_test() {
        let a = 0.5; // accept w > 2, i.e. error < 0.5
        let r = rec([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 1.0, 1.0);
        // Error 0.4: in S.
        assert!(r.accept(Vec3::new(0.4, 0.0, 0.0), Vec3::Z, a).is_some());
        // Error exactly 0.5: w = 2 is not > 2.
        assert!(r.accept(Vec3::new(0.5, 0.0, 0.0), Vec3::Z, a).is_none());
        // Error 0.6: out.
        assert!(r.accept(Vec3::new(0.6, 0.0, 0.0), Vec3::Z, a).is_none());
        // P below the record's plane (Pi in front of P): d = -0.1 < 0, excluded although
        // the weight (error 0.1) passes.
        let below = Vec3::new(0.0, 0.0, -0.1);
        assert!((r.front_distance(below, Vec3::Z) + 0.1).abs() < 1e-6);
        assert!(r.weight(below, Vec3::Z) > 1.0 / a);
        assert!(r.accept(below, Vec3::Z, a).is_none());
        // Above it: d = 0.1 ≥ 0, kept.
        assert!(r.accept(Vec3::new(0.0, 0.0, 0.1), Vec3::Z, a).is_some());
        // Opposite normals: error sqrt(2) > 0.5, out.
        assert!(r.accept(Vec3::ZERO, -Vec3::Z, a).is_none());
    }

    #[test]
    fn average_by_hand() {
        // Weights 1 and 3 on values 2 and 6: (2 + 18) / 4 = 5.
        let e = weighted_average(&[(1.0, Rgb::splat(2.0)), (3.0, Rgb::splat(6.0))]).unwrap();
        assert!((e.x - 5.0).abs() < 1e-6);
        assert_eq!(weighted_average(&[]), None);
        let e = weighted_average(&[(1.0, Rgb::ONE), (f32::INFINITY, Rgb::splat(7.0))]).unwrap();
        assert_eq!(e, Rgb::splat(7.0));
    }
}
