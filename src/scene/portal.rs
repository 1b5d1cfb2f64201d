//! Portals: the rectangle (a window, a door) through which an environment map lights an
//! interior. Seen from a point inside, the environment is visible only through it, so
//! next-event estimation samples only directions through it (pbrt-v4's
//! `PortalImageInfiniteLight`, after Bitterli, Novák & Jarosz 2015).
//!
//! Directions are parameterised by their two angles in the portal's frame ("rectified"
//! coordinates): u = ½ + atan(x/z)/π, v = ½ + atan(y/z)/π for a direction (x, y, z) with
//! z > 0 towards the outside. In these coordinates the directions from a point through a
//! rectangle form an axis-aligned rectangle, whose corners are the directions to two
//! opposite corners of the portal.

use crate::math::{Vec2, Vec3};
use std::f32::consts::PI;

/// A rectangle through which the environment lights the scene, and its frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Portal {
    /// The corners in order around the rectangle, in world space.
    pub corners: [Vec3; 4],
    /// Along corner 3 − corner 0, corner 1 − corner 0, and their cross product (pbrt-v4's
    /// frame): `z` points out of the portal, towards the environment it lets in.
    x: Vec3,
    y: Vec3,
    z: Vec3,
}

impl Portal {
    /// The portal with these corners: a rectangle, listed in order around it (pbrt-v4's
    /// order: (corner 3 − corner 0) × (corner 1 − corner 0) points out, towards the
    /// environment).
    pub fn new(corners: [Vec3; 4]) -> Result<Portal, String> {
        if corners.iter().any(|c| !c.is_finite()) {
            return Err("the portal's corners must be finite".into());
        }
        let [c0, c1, c2, c3] = corners;
        let size = corners
            .iter()
            .map(|c| (*c - c0).length())
            .fold(0.0f32, f32::max);
        let edges = [c1 - c0, c2 - c1, c2 - c3, c3 - c0];
        if edges.iter().any(|e| e.length() <= 1e-6 * size.max(1e-30)) || size == 0.0 {
            return Err("the portal has no area: two of its corners coincide".into());
        }
        let [e01, e12, e32, e03] = edges.map(|e| e.normalize());
        // Pbrt-v4's tolerances: opposite edges parallel, adjacent edges perpendicular.
        let parallel = (e01.dot(e32) - 1.0).abs() < 1e-3 && (e12.dot(e03) - 1.0).abs() < 1e-3;
        let square = [e01.dot(e12), e12.dot(e32), e32.dot(e03), e03.dot(e01)]
            .iter()
            .all(|d| d.abs() < 1e-3);
        if !(parallel && square) {
            return Err(
                "the portal must be a rectangle, its four corners listed in order around it".into(),
            );
        }
        let (x, y) = (e03, e01);
        Ok(Portal {
            corners,
            x,
            y,
            z: x.cross(y).normalize(),
        })
    }

    /// The direction's rectified coordinates and the solid angle per unit of them
    /// (dω/d(u,v)); `None` for a direction that does not point out through the portal's
    /// plane.
    pub fn uv_of(&self, dir: Vec3) -> Option<(Vec2, f32)> {
        let w = Vec3::new(dir.dot(self.x), dir.dot(self.y), dir.dot(self.z)).normalize_or_zero();
        if w.z <= 0.0 {
            return None;
        }
        let uv = Vec2::new(
            (w.x.atan2(w.z) / PI + 0.5).clamp(0.0, 1.0),
            (w.y.atan2(w.z) / PI + 0.5).clamp(0.0, 1.0),
        );
        Some((uv, solid_angle_per_uv(w)))
    }

    /// The unit world direction of rectified coordinates `uv` and dω/d(u,v) there (0 on
    /// the edges of the square, where the direction grazes the portal's plane).
    pub fn direction_of(&self, uv: Vec2) -> (Vec3, f32) {
        let (a, b) = (PI * (uv.x - 0.5), PI * (uv.y - 0.5));
        let w = Vec3::new(a.tan(), b.tan(), 1.0).normalize_or_zero();
        if !w.is_finite() || w.z <= 0.0 {
            return (self.z, 0.0);
        }
        let dir = (self.x * w.x + self.y * w.y + self.z * w.z).normalize();
        (dir, solid_angle_per_uv(w))
    }

    /// The rectangle of rectified coordinates through which `p` sees the portal; `None`
    /// when `p` is not behind it (on its outer side or in its plane).
    pub fn window(&self, p: Vec3) -> Option<(Vec2, Vec2)> {
        if (p - self.corners[0]).dot(self.z) >= 0.0 {
            return None;
        }
        // The angles need no unit vector: atan2 takes the components as they are.
        let uv = |d: Vec3| {
            let (x, y, z) = (d.dot(self.x), d.dot(self.y), d.dot(self.z));
            Vec2::new(x.atan2(z) / PI + 0.5, y.atan2(z) / PI + 0.5)
        };
        let (a, b) = (uv(self.corners[0] - p), uv(self.corners[2] - p));
        let (lo, hi) = (a.min(b), a.max(b));
        (hi.x > lo.x && hi.y > lo.y).then_some((lo, hi))
    }

    /// The portal's outward normal.
    pub fn normal(&self) -> Vec3 {
        self.z
    }
}

/// dω/d(u,v) at the unit direction `w` of the portal's frame: π² (1 − x²)(1 − y²) / z.
fn solid_angle_per_uv(w: Vec3) -> f32 {
    if w.z <= 0.0 {
        return 0.0;
    }
    PI * PI * (1.0 - w.x * w.x).max(0.0) * (1.0 - w.y * w.y).max(0.0) / w.z
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

    fn window_portal() -> Portal {
        // A 1.2 × 1.6 window in the plane x = -2.5, looking out towards -x.
        Portal::new([
            Vec3::new(-2.5, 0.9, -2.9),
            Vec3::new(-2.5, 2.1, -2.9),
            Vec3::new(-2.5, 2.1, -1.3),
            Vec3::new(-2.5, 0.9, -1.3),
        ])
        .unwrap()
    }

    #[test]
    fn coordinates_round_trip_and_cover_the_hemisphere() {
        let portal = window_portal();
        assert!(
            (portal.normal() - Vec3::NEG_X).length() < 1e-6,
            "{}",
            portal.normal()
        );
        let mut rng = Rng::for_key(4, &[]);
        for _ in 0..1000 {
            let uv = Vec2::new(rng.uniform(), rng.uniform()) * 0.98 + 0.01;
            let (dir, _) = portal.direction_of(uv);
            assert!(dir.dot(portal.normal()) > 0.0);
            let (back, _) = portal.uv_of(dir).unwrap();
            assert!((back - uv).length() < 1e-4, "{uv} -> {dir} -> {back}");
        }
        // dω/d(u,v) over the square is the hemisphere's 2π (midpoint rule).
        let n = 1000;
        let mut sum = 0.0f64;
        for j in 0..n {
            for i in 0..n {
                let uv = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                sum += portal.direction_of(uv).1 as f64;
            }
        }
        let hemisphere = sum / (n * n) as f64;
        assert!(
            (hemisphere - 2.0 * std::f64::consts::PI).abs() < 1e-2,
            "{hemisphere}"
        );
        // The Jacobian agrees with finite differences of the mapping.
        let uv = Vec2::new(0.3, 0.62);
        let h = 1e-3;
        let (d, jac) = portal.direction_of(uv);
        let du = portal.direction_of(uv + Vec2::new(h, 0.0)).0 - d;
        let dv = portal.direction_of(uv + Vec2::new(0.0, h)).0 - d;
        let area = du.cross(dv).length() / (h * h);
        assert!((area - jac).abs() < 0.01 * jac, "{area} vs {jac}");
    }

    #[test]
    fn the_window_holds_exactly_the_directions_through_the_portal() {
        let portal = window_portal();
        let p = Vec3::new(0.5, 0.7, -2.0);
        let (lo, hi) = portal.window(p).unwrap();
        let mut rng = Rng::for_key(5, &[]);
        for _ in 0..2000 {
            let dir = crate::math::warp::uniform_sphere(Vec2::new(rng.uniform(), rng.uniform()));
            // Where the ray from p meets the portal's plane, and whether that is inside.
            let t = (-2.5 - p.x) / dir.x;
            let q = p + dir * t;
            let through = t > 0.0 && (0.9..=2.1).contains(&q.y) && (-2.9..=-1.3).contains(&q.z);
            let inside = portal.uv_of(dir).is_some_and(|(uv, _)| {
                uv.x >= lo.x && uv.x <= hi.x && uv.y >= lo.y && uv.y <= hi.y
            });
            assert_eq!(through, inside, "{dir}: {q}");
        }
        // Outside the room, or in the portal's plane, there is no window.
        assert!(portal.window(Vec3::new(-3.0, 1.5, -2.0)).is_none());
        assert!(portal.window(Vec3::new(-2.5, 1.5, -2.0)).is_none());
    }

    #[test]
    fn shapes_other_than_rectangles_are_refused() {
        let square = [Vec3::ZERO, Vec3::Y, Vec3::new(1.0, 1.0, 0.0), Vec3::X];
        assert!(Portal::new(square).is_ok());
        let kite = [Vec3::ZERO, Vec3::Y, Vec3::new(1.3, 1.0, 0.0), Vec3::X];
        assert!(Portal::new(kite).unwrap_err().contains("rectangle"));
        let crossed = [Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), Vec3::Y, Vec3::X];
        assert!(Portal::new(crossed).is_err());
        let flat = [Vec3::ZERO, Vec3::ZERO, Vec3::X, Vec3::X];
        assert!(Portal::new(flat).unwrap_err().contains("no area"));
        let inf = [
            Vec3::ZERO,
            Vec3::Y,
            Vec3::new(f32::INFINITY, 1.0, 0.0),
            Vec3::X,
        ];
        assert!(Portal::new(inf).unwrap_err().contains("finite"));
    }
}
