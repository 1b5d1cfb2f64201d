//! What a light hierarchy knows of a group of lights (pbrt-v4's `LightBounds`, after Conty
//! Estevez & Kulla 2018): the box they lie in, their power, the cone of their normals and
//! how far beyond it they emit; and from these an importance at a point, an upper bound of
//! the light it may receive from them, which sampling follows.

use crate::math::Vec3;
use glam::Quat;
use std::f32::consts::PI;

/// A cone of directions: its unit axis and the cosine of its half-angle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionCone {
    pub w: Vec3,
    pub cos_theta: f32,
}

impl DirectionCone {
    /// Every direction.
    pub const SPHERE: DirectionCone = DirectionCone {
        w: Vec3::Z,
        cos_theta: -1.0,
    };

    /// The one direction `w` (unit).
    pub fn of(w: Vec3) -> DirectionCone {
        DirectionCone { w, cos_theta: 1.0 }
    }

    /// The smallest cone holding both (pbrt-v4's `Union`).
    pub fn union(self, b: DirectionCone) -> DirectionCone {
        let a = self;
        let theta_a = a.cos_theta.clamp(-1.0, 1.0).acos();
        let theta_b = b.cos_theta.clamp(-1.0, 1.0).acos();
        let theta_d = a.w.angle_between(b.w);
        if (theta_d + theta_b).min(PI) <= theta_a {
            return a;
        }
        if (theta_d + theta_a).min(PI) <= theta_b {
            return b;
        }
        let theta_o = 0.5 * (theta_a + theta_d + theta_b);
        if theta_o >= PI {
            return DirectionCone::SPHERE;
        }
        let wr = a.w.cross(b.w);
        if wr.length_squared() == 0.0 {
            return DirectionCone::SPHERE;
        }
        let w = Quat::from_axis_angle(wr.normalize(), theta_o - theta_a) * a.w;
        DirectionCone {
            w: w.normalize(),
            cos_theta: theta_o.cos(),
        }
    }
}

/// A light's (or a group's) bounds for the light hierarchy.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightBounds {
    pub lo: Vec3,
    pub hi: Vec3,
    /// Power, as light selection weighs it.
    pub phi: f32,
    /// The normals (or axes) of emission.
    pub normals: DirectionCone,
    /// Cosine of how far beyond the normals' cone light leaves (π/2 for surfaces).
    pub cos_theta_e: f32,
    pub two_sided: bool,
}

impl LightBounds {
    pub fn union(&self, b: &LightBounds) -> LightBounds {
        LightBounds {
            lo: self.lo.min(b.lo),
            hi: self.hi.max(b.hi),
            phi: self.phi + b.phi,
            normals: self.normals.union(b.normals),
            cos_theta_e: self.cos_theta_e.min(b.cos_theta_e),
            two_sided: self.two_sided || b.two_sided,
        }
    }

    pub fn centroid(&self) -> Vec3 {
        0.5 * (self.lo + self.hi)
    }

    /// An upper bound, up to a common factor, of the light reaching `p` from these lights:
    /// power over the squared distance (clamped inside the box), times the largest cosine
    /// of emission towards any point of the box (pbrt-v4's `Importance`, without the
    /// receiver's normal).
    pub fn importance(&self, p: Vec3) -> f32 {
        let pc = self.centroid();
        let diagonal = (self.hi - self.lo).length();
        let d2 = p.distance_squared(pc).max(0.5 * diagonal);
        let wi = (p - pc).try_normalize().unwrap_or(self.normals.w);
        let mut cos_w = self.normals.w.dot(wi);
        if self.two_sided {
            cos_w = cos_w.abs();
        }
        let sin_w = (1.0 - cos_w * cos_w).max(0.0).sqrt();
        // The cone of directions from the box towards p.
        let cos_b = subtended_cos(self.lo, self.hi, p);
        let sin_b = (1.0 - cos_b * cos_b).max(0.0).sqrt();
        let cos_o = self.normals.cos_theta;
        let sin_o = (1.0 - cos_o * cos_o).max(0.0).sqrt();
        let cos_x = cos_sub_clamped(sin_w, cos_w, sin_o, cos_o);
        let sin_x = sin_sub_clamped(sin_w, cos_w, sin_o, cos_o);
        let cos_p = cos_sub_clamped(sin_x, cos_x, sin_b, cos_b);
        if cos_p <= self.cos_theta_e {
            return 0.0;
        }
        (self.phi * cos_p / d2).max(0.0)
    }
}

/// cos(max(0, a − b)) from the sines and cosines of a and b.
fn cos_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b {
        1.0
    } else {
        cos_a * cos_b + sin_a * sin_b
    }
}

/// sin(max(0, a − b)) from the sines and cosines of a and b.
fn sin_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b {
        0.0
    } else {
        sin_a * cos_b - cos_a * sin_b
    }
}

/// The cosine of the half-angle of the cone from `p` that holds the box's bounding sphere
/// (-1, every direction, from inside it).
fn subtended_cos(lo: Vec3, hi: Vec3, p: Vec3) -> f32 {
    let center = 0.5 * (lo + hi);
    let r2 = center.distance_squared(hi);
    let d2 = p.distance_squared(center);
    if d2 < r2 {
        return -1.0;
    }
    (1.0 - r2 / d2).max(0.0).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_union_of_cones_holds_both() {
        let dirs = [
            Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.4, 0.5).normalize(),
            Vec3::new(-1.0, 0.2, 0.1).normalize(),
        ];
        let mut cone = DirectionCone::of(dirs[0]);
        for (i, &d) in dirs.iter().enumerate() {
            cone = cone.union(DirectionCone::of(d));
            for &e in &dirs[..=i] {
                assert!(
                    cone.w.dot(e) >= cone.cos_theta - 1e-5,
                    "{cone:?} misses {e}"
                );
            }
        }
        // Two opposite directions need the whole sphere.
        let both = DirectionCone::of(Vec3::Z).union(DirectionCone::of(-Vec3::Z));
        assert_eq!(both.cos_theta, -1.0);
    }

    /// A one-sided quad facing +z gives nothing behind it, and more to nearer points.
    #[test]
    fn importance_follows_distance_and_facing() {
        let b = LightBounds {
            lo: Vec3::new(-0.5, -0.5, 0.0),
            hi: Vec3::new(0.5, 0.5, 0.0),
            phi: 1.0,
            normals: DirectionCone::of(Vec3::Z),
            cos_theta_e: 0.0,
            two_sided: false,
        };
        assert_eq!(b.importance(Vec3::new(0.0, 0.0, -3.0)), 0.0);
        let near = b.importance(Vec3::new(0.0, 0.0, 2.0));
        let far = b.importance(Vec3::new(0.0, 0.0, 4.0));
        assert!(near > 3.9 * far && near < 4.1 * far, "{near} {far}");
        let two = LightBounds {
            two_sided: true,
            ..b
        };
        assert!(two.importance(Vec3::new(0.0, 0.0, -2.0)) > 0.0);
    }
}
