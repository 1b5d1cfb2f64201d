//! Where new rays start: at a surface point moved off the surface by the floating-point error
//! of its own computation, as pbrt-v4 does (`OffsetRayOrigin`, `SpawnRay`, `SpawnRayTo`).
//! The offset scales with the point's error bound, not with a fixed epsilon or the point's
//! distance from the origin, so a scene renders the same wherever it stands, and sheets
//! thinner than a millimetre are crossed face by face.

use super::{Ray, Vec3};

/// Roundings of a surface's distance found from a far origin, in units of the distance
/// (Embree's sphere test: the projection on the ray and the root of the quadratic).
const FAR_TEST_ROUNDINGS: u32 = 4;

/// Half an f32 ulp of 1: the unit roundoff of one correctly rounded operation.
const UNIT_ROUNDOFF: f32 = f32::EPSILON * 0.5;

/// Higham's γn = n·u / (1 − n·u): a bound on the relative error of n chained roundings.
pub const fn gamma(n: u32) -> f32 {
    let nu = n as f32 * UNIT_ROUNDOFF;
    nu / (1.0 - nu)
}

/// Roundings of a flat surface's distance found from a ray origin on it (Embree's Plücker
/// test, which takes the vertices relative to the origin), in units of the distance from the
/// point to the farthest vertex.
const PLANE_TEST_ROUNDINGS: u32 = 4;

/// The error a ray leaving a point of a triangle or quad must clear besides the point's own:
/// the backends find the surface's distance from vertices up to `reach` away (the longest
/// distance from the point to a vertex), rounding to a few ulps of that.
pub(crate) fn plane_test_error(reach: f32) -> Vec3 {
    Vec3::splat(reach * gamma(PLANE_TEST_ROUNDINGS))
}

/// A point where rays start or end on a surface: the computed position, a conservative bound
/// of its error along each axis, and the unit geometric normal (either side). A point in
/// empty space (a point light, a pinhole) has zero error and needs no normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spot {
    pub p: Vec3,
    pub error: Vec3,
    pub n: Vec3,
}

impl Spot {
    /// A point known exactly, off every surface.
    pub fn exact(p: Vec3) -> Spot {
        Spot {
            p,
            error: Vec3::ZERO,
            n: Vec3::ZERO,
        }
    }

    /// The point moved just outside its error box, along the normal on the side `w` points to.
    #[inline]
    pub(crate) fn origin_towards(&self, w: Vec3) -> Vec3 {
        offset_ray_origin(self.p, self.error, self.n, w)
    }

    /// A ray leaving the surface along `dir`.
    #[inline]
    pub fn spawn(&self, dir: Vec3) -> Ray {
        Ray {
            tmin: LEAVING,
            ..Ray::new(self.origin_towards(dir), dir)
        }
    }

    /// The segment from this point to `to` (for shadow rays and connections), both ends off
    /// their surfaces, so that neither end's surface occludes it. The end stops short of
    /// `to`'s surface by `to`'s error bound and by what the backends' tests round to when
    /// they find that surface from the far end: their distances are computed relative to the
    /// ray's origin, so they round to ulps of the segment's length.
    #[inline]
    pub fn spawn_to(&self, to: &Spot) -> Ray {
        let from = self.origin_towards(to.p - self.p);
        let length = (to.p - from).abs().max_element();
        let end = offset_ray_origin(
            to.p,
            to.error + Vec3::splat(length * gamma(FAR_TEST_ROUNDINGS)),
            to.n,
            from - to.p,
        );
        Ray {
            origin: from,
            dir: end - from,
            tmin: LEAVING,
            tmax: 1.0,
            time: 0.0,
        }
    }
}

/// The start of a spawned ray's interval: the smallest positive normal float, so that a hit
/// at exactly t = 0 does not count. A point with no rounding error (on a plane through 0 in
/// the axis of its normal) leaves from the plane itself; pbrt-v4's tests reject t = 0 there,
/// and so does this bound, for backends whose intervals are closed (Embree's is).
const LEAVING: f32 = f32::MIN_POSITIVE;

/// `p` moved along `n` (to the side `w` points to) beyond the box of half-widths `error`
/// around it, then rounded away from `p`, so the moved point is certainly off the surface
/// whose computed point `p` is (pbrt-v4's `OffsetRayOrigin`).
#[inline]
pub(crate) fn offset_ray_origin(p: Vec3, error: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    let d = n.abs().dot(error);
    let offset = if w.dot(n) < 0.0 { -n * d } else { n * d };
    let q = p + offset;
    Vec3::new(
        step_away(q.x, offset.x),
        step_away(q.y, offset.y),
        step_away(q.z, offset.z),
    )
}

/// `q` moved to the next float in the direction of `o`'s sign (left as it is when `o` is
/// zero), without branches: the sign of an offset is a coin toss from ray to ray, which
/// `f32::next_up` and `next_down` pay for in mispredictions.
#[inline(always)]
fn step_away(q: f32, o: f32) -> f32 {
    let bits = q.to_bits();
    let magnitude = bits & 0x7fff_ffff;
    let q_negative = bits >> 31;
    let o_negative = o.to_bits() >> 31;
    // Away from zero (one more in the magnitude) when the signs agree or q is zero, where
    // the result takes o's sign; toward zero otherwise.
    let away = (q_negative == o_negative) | (magnitude == 0);
    let stepped = if away { magnitude + 1 } else { magnitude - 1 };
    let sign = if magnitude == 0 {
        o_negative
    } else {
        q_negative
    };
    let moved = f32::from_bits((sign << 31) | stepped);
    if o == 0.0 || q.is_nan() || magnitude == 0x7f80_0000 {
        q
    } else {
        moved
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stepping_away_is_next_up_or_next_down() {
        let values = [
            0.0f32,
            -0.0,
            1.0,
            -1.0,
            1e-40,
            -1e-40,
            f32::MIN_POSITIVE,
            3.5e4,
            -7.25e-3,
            f32::MAX,
            -f32::MAX,
        ];
        for q in values {
            assert_eq!(step_away(q, 2.0).to_bits(), q.next_up().to_bits(), "{q} up");
            assert_eq!(
                step_away(q, -2.0).to_bits(),
                q.next_down().to_bits(),
                "{q} down"
            );
            assert_eq!(step_away(q, 0.0).to_bits(), q.to_bits(), "{q} still");
        }
        assert_eq!(step_away(f32::INFINITY, -1.0), f32::INFINITY);
        assert!(step_away(f32::NAN, 1.0).is_nan());
    }

    #[test]
    fn gamma_bounds_chained_roundings() {
        // Summing n values each rounded once stays within γn of the exact sum.
        let xs: Vec<f32> = (1..=7).map(|i| 1.0 / (i as f32 * 3.0)).collect();
        let exact: f64 = xs.iter().map(|&x| x as f64).sum();
        let sum: f32 = xs.iter().sum();
        assert!(((sum as f64 - exact) / exact).abs() <= gamma(xs.len() as u32) as f64);
        assert!(gamma(1) > UNIT_ROUNDOFF && gamma(2) > gamma(1));
    }

    /// The moved point lies strictly beyond the error box on the chosen side, for points
    /// near and far from the origin.
    #[test]
    fn offset_points_leave_the_error_box_on_the_chosen_side() {
        for scale in [1e-3f32, 1.0, 1e3, 1e4] {
            let p = Vec3::new(0.3, -1.7, 2.9) * scale;
            let error = p.abs() * gamma(7);
            let n = Vec3::new(0.2, 0.9, -0.3).normalize();
            for w in [n, -n] {
                let q = offset_ray_origin(p, error, n, w);
                let along = (q - p).dot(n) * w.dot(n).signum();
                assert!(along > n.abs().dot(error) * 0.999, "{scale}: {along}");
                for i in 0..3 {
                    let moved = (q[i] - p[i]) * (n[i] * w.dot(n)).signum();
                    assert!(n[i] == 0.0 || moved > 0.0);
                }
            }
        }
        // An exact point does not move.
        assert_eq!(
            offset_ray_origin(Vec3::ONE, Vec3::ZERO, Vec3::Y, Vec3::Y),
            Vec3::ONE
        );
    }
}
