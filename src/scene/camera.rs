use crate::math::{Ray, Vec3};

/// Largest image width or height accepted, from a scene file or the command line.
pub const MAX_RESOLUTION: u32 = 65536;

/// A pinhole perspective camera. As in pbrt, `fov_deg` spans the shorter image axis.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    pub look_at: Vec3,
    pub up: Vec3,
    pub fov_deg: f32,
    pub width: u32,
    pub height: u32,
}

impl Camera {
    /// The ray through the continuous raster position (x right, y down, pixel (0,0) spans
    /// \[0,1\]x\[0,1\]).
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
        let half = (self.fov_deg.to_radians() * 0.5).tan() / w.min(h);
        CameraBasis {
            origin: self.position,
            forward,
            right: right * half * 2.0,
            down: -up * half * 2.0,
            center: (w * 0.5, h * 0.5),
            margin: 0.5,
        }
    }
}

/// The camera frame scaled so that one raster unit maps to one pixel on the image plane at
/// distance 1.
#[derive(Clone, Copy, Debug)]
pub struct CameraBasis {
    pub origin: Vec3,
    pub forward: Vec3,
    right: Vec3,
    down: Vec3,
    center: (f32, f32),
    /// How far outside the image (in pixels) a point still counts as seen: the radius of
    /// the pixel filter, which the renderer sets.
    pub margin: f32,
}

impl CameraBasis {
    /// Where the world point `p` projects on the film (in pixels, possibly outside the
    /// image) and the cosine between the camera axis and the direction to `p`; `None` behind
    /// the camera.
    pub fn raster(&self, p: Vec3) -> Option<(f32, f32, f32)> {
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

    /// Width and height of the film in pixels.
    pub fn film_size(&self) -> (f32, f32) {
        (2.0 * self.center.0, 2.0 * self.center.1)
    }

    /// Side of one (square) pixel on the image plane at unit distance in front of the pinhole.
    pub fn pixel_size(&self) -> f32 {
        self.right.length()
    }

    /// Area of one pixel on the image plane at unit distance in front of the pinhole.
    pub fn pixel_area(&self) -> f32 {
        self.right.length() * self.down.length()
    }

    pub fn ray(&self, x: f32, y: f32) -> Ray {
        let dir = self.forward + self.right * (x - self.center.0) + self.down * (y - self.center.1);
        Ray::new(self.origin, dir.normalize())
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
