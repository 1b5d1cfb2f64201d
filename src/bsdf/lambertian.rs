//! A BSDF with only the Lambertian lobe, evaluated from one outgoing direction towards
//! many: bidirectional techniques evaluate a vertex's BSDF for every connection it makes,
//! and for this lobe only the cosines with the two normals are needed, not the whole
//! shading frame.

use super::{Bsdf, Transport};
use crate::math::warp::cosine_hemisphere_pdf;
use crate::math::{Rgb, Vec3};
use std::f32::consts::FRAC_1_PI;

/// A Lambertian BSDF with its outgoing direction `wo` fixed.
#[derive(Clone, Copy, Debug)]
pub struct LambertianFrom {
    kd: Rgb,
    /// The shading and geometric normals.
    n: Vec3,
    ng: Vec3,
    /// wo·ng and wo·n.
    go: f32,
    so: f32,
}

impl LambertianFrom {
    /// `bsdf` seen from `wo`, if it has only the Lambertian lobe.
    #[inline(always)]
    pub fn of(bsdf: &Bsdf, wo: Vec3) -> Option<LambertianFrom> {
        (bsdf.lambertian && bsdf.coating.is_none()).then(|| LambertianFrom {
            kd: bsdf.kd,
            n: bsdf.n,
            ng: bsdf.ng,
            go: wo.dot(bsdf.ng),
            so: wo.dot(bsdf.n),
        })
    }

    /// wi·ng and wi·n if the lobe connects `wo` to `wi`, as `Bsdf::connectable` decides:
    /// both directions on one side of ng (the lobe does not transmit), and on the same side
    /// of the shading normal as of ng.
    #[inline(always)]
    fn cosines(&self, wi: Vec3) -> Option<(f32, f32)> {
        let (go, so) = (self.go, self.so);
        let (gi, si) = (wi.dot(self.ng), wi.dot(self.n));
        // Written as the refusals, so that a NaN passes as it does there.
        if go * gi <= 0.0 || so * go <= 0.0 || si * gi <= 0.0 {
            return None;
        }
        Some((gi, si))
    }

    /// [`Bsdf::eval_and_pdfs`] towards `wi`: f(wo, wi)·|cos θi|, pdf(wo → wi), pdf(wi → wo),
    /// the same numbers as the general way.
    #[inline(always)]
    pub fn eval_and_pdfs(&self, wi: Vec3, mode: Transport) -> (Rgb, f32, f32) {
        let Some((gi, si)) = self.cosines(wi) else {
            return (Rgb::ZERO, 0.0, 0.0);
        };
        // As `Bsdf::adjoint`, from the same cosines.
        let adjoint = match mode {
            Transport::Radiance => 1.0,
            Transport::Importance => {
                let den = self.go.abs() * si.abs();
                if den == 0.0 {
                    0.0
                } else {
                    self.so.abs() * gi.abs() / den
                }
            }
        };
        (
            self.kd * FRAC_1_PI * si.abs() * adjoint,
            cosine_hemisphere_pdf(si.abs()),
            self.reverse_pdf(),
        )
    }

    /// [`Bsdf::pdf`] of `wi`: pdf(wo → wi).
    #[inline(always)]
    pub fn pdf(&self, wi: Vec3) -> f32 {
        self.cosines(wi)
            .map_or(0.0, |(_, si)| cosine_hemisphere_pdf(si.abs()))
    }

    /// pdf(wi → wo), the same for every `wi` it connects to.
    #[inline(always)]
    pub fn reverse_pdf(&self) -> f32 {
        cosine_hemisphere_pdf(self.so.abs())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::{Lobes, SpectralParts};
    use crate::math::Rng;

    fn bits(c: Rgb) -> [u32; 3] {
        c.to_array().map(f32::to_bits)
    }

    /// The short way gives the general way's numbers, bit for bit, for directions all over
    /// the sphere (below either normal too) with a shading normal tilted off the geometric
    /// one, in both transports.
    #[test]
    fn the_same_numbers_as_the_general_evaluation() {
        let lobes = Lobes {
            kd: Rgb::new(0.8, 0.5, 0.2),
            kdt: Rgb::ZERO,
            ks: Rgb::ZERO,
            kt: Rgb::ZERO,
            ior: 1.5,
            alphas: (0.0, 0.0),
            fresnel: false,
            thin: false,
            conductor: None,
            lambertian: true,
            spectral: SpectralParts::default(),
        };
        let ng = Vec3::Z;
        let n = Vec3::new(0.3, -0.2, 0.9).normalize();
        let bsdf = Bsdf::of_lobes(&lobes, n, ng);
        let mut rng = Rng::for_key(3, &[5]);
        let mut direction = || {
            let z = 2.0 * rng.uniform() - 1.0;
            let phi = std::f32::consts::TAU * rng.uniform();
            let r = (1.0 - z * z).max(0.0).sqrt();
            Vec3::new(r * phi.cos(), r * phi.sin(), z)
        };
        let mut non_zero = 0;
        for _ in 0..2000 {
            let (wo, wi) = (direction(), direction());
            let fast = LambertianFrom::of(&bsdf, wo).expect("a Lambertian BSDF");
            for mode in [Transport::Radiance, Transport::Importance] {
                let general = match bsdf.connectable(wo, wi) {
                    Some((lo, li)) => (
                        bsdf.eval_connected(wo, wi, lo, li, mode),
                        bsdf.pdf_connected(lo, li),
                        bsdf.pdf_connected(li, lo),
                    ),
                    None => (Rgb::ZERO, 0.0, 0.0),
                };
                let short = fast.eval_and_pdfs(wi, mode);
                assert_eq!(fast.pdf(wi).to_bits(), general.1.to_bits());
                assert_eq!(
                    (bits(short.0), short.1.to_bits(), short.2.to_bits()),
                    (bits(general.0), general.1.to_bits(), general.2.to_bits()),
                    "wo {wo}, wi {wi}, {mode:?}"
                );
                non_zero += usize::from(short.1 > 0.0);
            }
        }
        // Both branches were taken: about a quarter of random pairs connect.
        assert!((500..2000).contains(&non_zero), "{non_zero}");
    }

    /// A BSDF with another lobe, or a coat, takes the general way.
    #[test]
    fn only_a_bare_lambertian_lobe() {
        let mut lobes = Lobes {
            kd: Rgb::splat(0.5),
            kdt: Rgb::ZERO,
            ks: Rgb::splat(0.2),
            kt: Rgb::ZERO,
            ior: 1.5,
            alphas: (0.3, 0.3),
            fresnel: false,
            thin: false,
            conductor: None,
            lambertian: false,
            spectral: SpectralParts::default(),
        };
        let bsdf = Bsdf::of_lobes(&lobes, Vec3::Z, Vec3::Z);
        assert!(LambertianFrom::of(&bsdf, Vec3::Z).is_none());
        lobes.ks = Rgb::ZERO;
        lobes.lambertian = true;
        let bsdf = Bsdf::of_lobes(&lobes, Vec3::Z, Vec3::Z);
        assert!(LambertianFrom::of(&bsdf, Vec3::Z).is_some());
    }
}
