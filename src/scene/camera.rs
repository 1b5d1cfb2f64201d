use crate::math::warp::concentric_disk;
use crate::math::{Ray, Vec2, Vec3};

/// Largest image width or height accepted, from a scene file or the command line.
pub const MAX_RESOLUTION: u32 = 65536;

/// The farthest from the origin any ray may start or any shape may reach, in scene units:
/// Embree refuses (it aborts on) ray origins and directions past 1.844e18 (its
/// `FLT_LARGE`), so raylink refuses cameras and scenes that reach past this, with a message,
/// before any ray is traced.
pub const MAX_COORDINATE: f32 = 1e18;

/// `v` for a message: plain numbers, or in exponent form past ten million.
pub(crate) fn show(v: Vec3) -> String {
    let n = |x: f32| {
        if x.abs() >= 1e7 {
            format!("{x:e}")
        } else {
            format!("{x}")
        }
    };
    format!("[{}, {}, {}]", n(v.x), n(v.y), n(v.z))
}

/// Why a camera cannot be rendered: the field to blame and the reason.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraProblem {
    /// The field as the native format names it (`position`, `look_at`, `up`, `fov`,
    /// `lens_radius`, `focal_distance`, `size`, `width`, `height`).
    pub field: &'static str,
    pub message: String,
}

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

    /// Checks every quantity the camera's rays are made of, not only the values given: the
    /// direction `look_at - position` and the lengths that normalise it, the frame, the film
    /// and lens corners' rays (finite, and within [`MAX_COORDINATE`]). Every reader and front
    /// end that makes a camera calls it, so no ray can abort a backend.
    pub fn check(&self) -> Result<(), CameraProblem> {
        let bad = |field: &'static str, message: String| Err(CameraProblem { field, message });
        for (field, v) in [
            ("position", self.position),
            ("look_at", self.look_at),
            ("up", self.up),
        ] {
            if !v.is_finite() {
                return bad(field, format!("must be finite, got {}", show(v)));
            }
        }
        let far = |v: Vec3| v.abs().max_element() > MAX_COORDINATE;
        if far(self.position) {
            return bad(
                "position",
                format!(
                    "must lie within {MAX_COORDINATE:e} units of the origin (what the \
                     intersection backends trace), got {}",
                    show(self.position)
                ),
            );
        }
        for (field, v) in [("width", self.width), ("height", self.height)] {
            if !(1..=MAX_RESOLUTION).contains(&v) {
                return bad(
                    field,
                    format!("must be between 1 and {MAX_RESOLUTION}, got {v}"),
                );
            }
        }
        let forward = self.look_at - self.position;
        let distance = forward.length();
        if !distance.is_finite() {
            return bad(
                "look_at",
                format!(
                    "is too far from the position {}: the distance between them overflows",
                    show(self.position)
                ),
            );
        }
        if distance <= 1e-6 * (1.0 + self.position.abs().max_element()) {
            return bad(
                "look_at",
                format!(
                    "must differ from the camera position {}",
                    show(self.position)
                ),
            );
        }
        let up = self.up.length();
        if !(up.is_finite() && up > 0.0) {
            return bad(
                "up",
                format!(
                    "must be a direction of finite, non-zero length, got {}",
                    show(self.up)
                ),
            );
        }
        if (forward / distance).cross(self.up / up).length() < 1e-4 {
            return bad(
                "up",
                format!(
                    "must not be parallel to the viewing direction, got {}",
                    show(self.up)
                ),
            );
        }
        // Checked for every projection, as the scene format always has: an orthographic
        // camera does not use it, but a value out of range is still a mistake.
        if !(self.fov_deg > 0.0 && self.fov_deg < 180.0) {
            return bad(
                "fov",
                format!("must be in (0, 180) degrees, got {}", self.fov_deg),
            );
        }
        if let Projection::Orthographic { size } = self.projection {
            if !(size.is_finite() && size > 0.0 && size <= MAX_COORDINATE) {
                return bad(
                    "size",
                    format!("must be positive and at most {MAX_COORDINATE:e}, got {size}"),
                );
            }
        }
        if let Projection::ThinLens {
            radius,
            focal_distance,
        } = self.projection
        {
            if !(0.0..=MAX_COORDINATE).contains(&radius) {
                return bad(
                    "lens_radius",
                    format!("must be at least 0 and at most {MAX_COORDINATE:e}, got {radius}"),
                );
            }
            if !(focal_distance.is_finite() && focal_distance > 0.0) {
                return bad(
                    "focal_distance",
                    format!("must be positive and finite, got {focal_distance}"),
                );
            }
        }
        // The rays through the film's corners, through the lens's edge: what the backends get.
        let basis = self.basis();
        let (w, h) = (self.width as f32, self.height as f32);
        let lens = [
            Vec2::new(0.5, 0.5),
            Vec2::new(0.0, 0.5),
            Vec2::new(1.0, 0.5),
            Vec2::new(0.5, 0.0),
            Vec2::new(0.5, 1.0),
        ];
        for (x, y) in [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)] {
            for u in lens {
                let ray = basis.ray_through_lens(x, y, u);
                if !(ray.origin.is_finite() && ray.dir.is_finite()) || far(ray.origin) {
                    let field = match self.projection {
                        Projection::Pinhole => "fov",
                        Projection::ThinLens { .. } => "lens_radius",
                        Projection::Orthographic { .. } => "size",
                    };
                    return bad(
                        field,
                        format!(
                            "gives rays that leave the range the intersection backends trace \
                             (the values overflow, or reach past {MAX_COORDINATE:e})"
                        ),
                    );
                }
            }
        }
        Ok(())
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

    /// Each value that overflows, or reaches past what the backends trace, is refused with
    /// the field to blame; a camera that passes gives finite rays within the range at every
    /// film corner and lens edge.
    #[test]
    fn the_check_names_what_overflows_and_what_it_passes_traces() {
        let good = Camera {
            position: Vec3::new(0.0, 1.0, 5.0),
            look_at: Vec3::new(0.0, 1.0, 0.0),
            up: Vec3::Y,
            fov_deg: 40.0,
            width: 64,
            height: 48,
            projection: Projection::Pinhole,
        };
        assert_eq!(good.check(), Ok(()));
        let big = 3e38;
        let cases = [
            (
                "position",
                Camera {
                    position: Vec3::new(-big, 0.0, 0.0),
                    look_at: Vec3::new(big, 0.0, 0.0),
                    ..good.clone()
                },
            ),
            (
                "position",
                Camera {
                    position: Vec3::new(2e18, 1.0, 5.0),
                    ..good.clone()
                },
            ),
            (
                "look_at",
                Camera {
                    look_at: Vec3::new(big, big, 0.0),
                    ..good.clone()
                },
            ),
            (
                "look_at",
                Camera {
                    look_at: good.position,
                    ..good.clone()
                },
            ),
            (
                "up",
                Camera {
                    up: Vec3::new(big, big, 0.0),
                    ..good.clone()
                },
            ),
            (
                "up",
                Camera {
                    up: Vec3::Z,
                    ..good.clone()
                },
            ),
            (
                "up",
                Camera {
                    up: Vec3::new(f32::NAN, 1.0, 0.0),
                    ..good.clone()
                },
            ),
            (
                "fov",
                Camera {
                    fov_deg: 180.0,
                    ..good.clone()
                },
            ),
            (
                "fov",
                Camera {
                    fov_deg: 500.0,
                    projection: Projection::Orthographic { size: 2.0 },
                    ..good.clone()
                },
            ),
            (
                "lens_radius",
                Camera {
                    projection: Projection::ThinLens {
                        radius: big,
                        focal_distance: 5.0,
                    },
                    ..good.clone()
                },
            ),
            (
                "focal_distance",
                Camera {
                    projection: Projection::ThinLens {
                        radius: 0.1,
                        focal_distance: big * 10.0,
                    },
                    ..good.clone()
                },
            ),
            (
                "size",
                Camera {
                    projection: Projection::Orthographic { size: big },
                    ..good.clone()
                },
            ),
            // Each value in range, the lens edge past it.
            (
                "lens_radius",
                Camera {
                    position: Vec3::new(9e17, 1.0, 5.0),
                    look_at: Vec3::new(9e17, 1.0, -1e13),
                    projection: Projection::ThinLens {
                        radius: 5e17,
                        focal_distance: 5.0,
                    },
                    ..good.clone()
                },
            ),
        ];
        for (field, camera) in cases {
            let problem = camera.check().expect_err(field);
            assert_eq!(problem.field, field, "{}", problem.message);
        }
        let lens = Camera {
            projection: Projection::ThinLens {
                radius: 1e3,
                focal_distance: 1e3,
            },
            ..good.clone()
        };
        assert_eq!(lens.check(), Ok(()));
        let basis = lens.basis();
        for (x, y) in [(0.0, 0.0), (64.0, 48.0)] {
            let ray = basis.ray_through_lens(x, y, Vec2::new(1.0, 1.0));
            assert!(ray.origin.is_finite() && ray.dir.is_finite());
        }
    }
}
