use crate::math::warp::concentric_disk;
use crate::math::{Ray, Vec2, Vec3};

/// Largest image width or height accepted, from a scene file or the command line.
pub const MAX_RESOLUTION: u32 = 65536;

/// How the camera maps the film to rays.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Projection {
    /// A perspective pinhole: every ray leaves `position`.
    #[default]
    Pinhole,
    /// A perspective thin lens (pbrt-v4's `PerspectiveCamera` with `lensradius`): rays leave
    /// a disk of `radius` around `position`, perpendicular to the view, and meet again on the
    /// plane at `focal_distance` in front of it, which is in focus.
    ThinLens { radius: f32, focal_distance: f32 },
    /// Parallel rays along the view; the film spans `size` world units across its width.
    Orthographic { size: f32 },
}

/// A perspective (pinhole or thin lens) or orthographic camera. As in pbrt, `fov_deg` spans
/// the shorter image axis (perspective only).
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    pub look_at: Vec3,
    pub up: Vec3,
    pub fov_deg: f32,
    pub width: u32,
    pub height: u32,
    pub projection: Projection,
}

impl Camera {
    /// The ray through the continuous raster position (x right, y down, pixel (0,0) spans
    /// \[0,1\]x\[0,1\]), through the lens centre for a thin lens.
    pub fn ray(&self, x: f32, y: f32) -> Ray {
        let basis = self.basis();
        basis.ray(x, y)
    }

    /// Precomputes the camera frame; use it when generating many rays.
    pub fn basis(&self) -> CameraBasis {
        let forward = (self.look_at - self.position).normalize();
        let right = forward.cross(self.up).normalize();
        let up = right.cross(forward);
        let (w, h) = (self.width as f32, self.height as f32);
        let half = match self.projection {
            // World units per pixel on the film.
            Projection::Orthographic { size } => 0.5 * size / w,
            _ => (self.fov_deg.to_radians() * 0.5).tan() / w.min(h),
        };
        let (lens_radius, focal_distance) = match self.projection {
            Projection::ThinLens {
                radius,
                focal_distance,
            } => (radius, focal_distance),
            _ => (0.0, 1.0),
        };
        CameraBasis {
            origin: self.position,
            forward,
            right: right * half * 2.0,
            down: -up * half * 2.0,
            center: (w * 0.5, h * 0.5),
            margin: 0.5,
            lens_radius,
            focal_distance,
            orthographic: matches!(self.projection, Projection::Orthographic { .. }),
        }
    }
}

/// The camera frame scaled so that one raster unit maps to one pixel on the image plane at
/// distance 1 (perspective) or on the film itself (orthographic).
#[derive(Clone, Copy, Debug)]
pub struct CameraBasis {
    /// The pinhole, the lens centre, or the orthographic film's centre.
    pub origin: Vec3,
    pub forward: Vec3,
    right: Vec3,
    down: Vec3,
    center: (f32, f32),
    /// How far outside the image (in pixels) a point still counts as seen: the radius of
    /// the pixel filter, which the renderer sets.
    pub margin: f32,
    /// 0 for a pinhole.
    lens_radius: f32,
    focal_distance: f32,
    orthographic: bool,
}

impl CameraBasis {
    /// Where the world point `p` projects on the film (in pixels, possibly outside the
    /// image) and the cosine between the camera axis and the direction to `p`; `None` behind
    /// the camera, and for an orthographic camera (whose importance is a delta in
    /// direction: no point can be connected to it).
    pub fn raster(&self, p: Vec3) -> Option<(f32, f32, f32)> {
        if self.orthographic {
            return None;
        }
        let d = p - self.origin;
        let z = d.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let q = d / z;
        let x = self.center.0 + q.dot(self.right) / self.right.length_squared();
        let y = self.center.1 + q.dot(self.down) / self.down.length_squared();
        Some((x, y, z / d.length()))
    }

    /// The disc on the film (centre and radius in pixels) that holds the image of the sphere
    /// of `radius` around `center`; `None` when the sphere reaches behind the camera.
    pub fn sphere_image(&self, center: Vec3, radius: f32) -> Option<(f32, f32, f32)> {
        let d = center - self.origin;
        if self.orthographic {
            let x = self.center.0 + d.dot(self.right) / self.right.length_squared();
            let y = self.center.1 + d.dot(self.down) / self.down.length_squared();
            return Some((x, y, radius / self.right.length()));
        }
        let (z, distance) = (d.dot(self.forward), d.length());
        if z <= radius || distance <= radius {
            return None;
        }
        let (x, y, cos) = self.raster(center)?;
        // The silhouette subtends a half-angle asin(r/d) around the centre; off the axis
        // the film stretches it by up to 1/cos². Overestimating is harmless.
        let tan = radius / (distance * distance - radius * radius).sqrt();
        Some((x, y, tan / (self.right.length() * cos * cos)))
    }

    /// [`raster`](Self::raster) for the ray from the lens point `lens` to `p`: the film
    /// position of the focal-plane point that ray passes through (pbrt-v4's
    /// `PerspectiveCamera::We`), and the cosine between the camera axis and the ray.
    pub(crate) fn raster_from(&self, lens: Vec3, p: Vec3) -> Option<(f32, f32, f32)> {
        if self.lens_radius == 0.0 {
            return self.raster(p);
        }
        let w = p - lens;
        let z = w.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        // The focal-plane point on the ray, seen from the lens centre.
        let focus = lens + w * (self.focal_distance / z);
        let (x, y, _) = self.raster(focus)?;
        Some((x, y, z / w.length()))
    }

    /// Width and height of the film in pixels.
    pub(crate) fn film_size(&self) -> (f32, f32) {
        (2.0 * self.center.0, 2.0 * self.center.1)
    }

    /// Area of one pixel on the image plane at unit distance in front of the pinhole.
    pub(crate) fn pixel_area(&self) -> f32 {
        self.right.length() * self.down.length()
    }

    /// Whether rays need a lens sample ([`ray_through_lens`](Self::ray_through_lens)).
    pub(crate) fn has_lens(&self) -> bool {
        self.lens_radius > 0.0
    }

    /// The point of the lens for the sample `u` (uniform over the lens disk, by the
    /// concentric map as pbrt does); the origin for a pinhole.
    pub(crate) fn lens_point(&self, u: Vec2) -> Vec3 {
        if self.lens_radius == 0.0 {
            return self.origin;
        }
        let d = concentric_disk(u) * self.lens_radius;
        self.origin + self.right.normalize() * d.x - self.down.normalize() * d.y
    }

    pub fn ray(&self, x: f32, y: f32) -> Ray {
        if self.orthographic {
            let offset = self.right * (x - self.center.0) + self.down * (y - self.center.1);
            return Ray::new(self.origin + offset, self.forward);
        }
        let dir = self.forward + self.right * (x - self.center.0) + self.down * (y - self.center.1);
        Ray::new(self.origin, dir.normalize())
    }

    /// The ray through raster (x, y) leaving the lens at the sample `u`: aimed at the point
    /// the pinhole ray meets on the focal plane (pbrt-v4's `GenerateRay`).
    pub(crate) fn ray_through_lens(&self, x: f32, y: f32, u: Vec2) -> Ray {
        if self.lens_radius == 0.0 {
            return self.ray(x, y);
        }
        let dir = self.forward + self.right * (x - self.center.0) + self.down * (y - self.center.1);
        let focus = self.origin + dir * self.focal_distance;
        let lens = self.lens_point(u);
        Ray::new(lens, (focus - lens).normalize())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_ray_looks_at_target_and_fov_spans_short_axis() {
        let cam = Camera {
            position: Vec3::new(0.0, 1.0, 5.0),
            look_at: Vec3::new(0.0, 1.0, 0.0),
            up: Vec3::Y,
            fov_deg: 90.0,
            width: 200,
            height: 100,
            projection: Projection::Pinhole,
        };
        let centre = cam.ray(100.0, 50.0);
        assert!((centre.dir - Vec3::NEG_Z).length() < 1e-6);
        // Top edge of the shorter (vertical) axis is 45 degrees up.
        let top = cam.ray(100.0, 0.0);
        assert!((top.dir.angle_between(Vec3::NEG_Z).to_degrees() - 45.0).abs() < 1e-3);
        assert!(top.dir.y > 0.0);
        // Raster x grows to the right (+x when looking down -z with y up).
        assert!(cam.ray(150.0, 50.0).dir.x > 0.0);
    }
}
