//! Whitted's guard for objects smaller than a pixel. The adaptive sampler looks only at the
//! corners of each square, so an object lying between all four corners is never seen. As in
//! the paper, each object's bounding sphere is kept at a size that the corner lattice cannot
//! miss: here its projection on the film, a disc; a square that such a disc overlaps though
//! none of its corners sees the object is subdivided until a corner finds it (or the deepest
//! level is reached).

use super::Tile;
use crate::scene::camera::CameraBasis;
use crate::scene::instance::object_id;
use crate::scene::{Geometry, Primitives, Scene};
use glam::Vec3;

/// A disc of radius `r` of at least √2/2 pixel holds a point of the pixel-corner lattice
/// wherever it lies, so the corner test alone finds the object; only smaller ones need help.
const SMALL_RADIUS: f32 = std::f32::consts::FRAC_1_SQRT_2;

/// Where an object smaller than a pixel projects on the film, in pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Disc {
    pub x: f32,
    pub y: f32,
    pub r: f32,
    /// The shape's index, as a sample's `object` names it.
    pub object: u32,
}

impl Disc {
    /// Whether the disc overlaps the square [x0, x0 + size] × [y0, y0 + size].
    pub fn overlaps(&self, x0: f32, y0: f32, size: f32) -> bool {
        let dx = self.x - self.x.clamp(x0, x0 + size);
        let dy = self.y - self.y.clamp(y0, y0 + size);
        dx * dx + dy * dy <= self.r * self.r
    }

    /// The pixels whose squares the disc overlaps (or touches), as a block of pixels.
    pub fn pixels(&self) -> Tile {
        // Squares whose edge the disc only touches count too, as in `overlaps`.
        let lo = |v: f32| (v.ceil() - 1.0).max(0.0) as u32;
        let hi = |v: f32| (v.floor() + 1.0).max(0.0) as u32;
        Tile {
            x0: lo(self.x - self.r),
            x1: hi(self.x + self.r),
            y0: lo(self.y - self.r),
            y1: hi(self.y + self.r),
        }
    }

    /// Whether the disc overlaps the rectangle [x0, x1] × [y0, y1].
    fn overlaps_rect(&self, x0: f32, y0: f32, x1: f32, y1: f32) -> bool {
        let dx = self.x - self.x.clamp(x0, x1);
        let dy = self.y - self.y.clamp(y0, y1);
        dx * dx + dy * dy <= self.r * self.r
    }
}

/// The discs of every object in front of the camera whose projection is smaller than a
/// pixel, in shape order.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct SmallObjects {
    discs: Vec<Disc>,
}

impl SmallObjects {
    /// None: for samplers that do not look for small objects.
    pub fn none() -> SmallObjects {
        SmallObjects::default()
    }

    /// The small objects of `scene` seen through `camera`.
    pub fn new(scene: &Scene, camera: &CameraBasis) -> SmallObjects {
        let world = scene
            .shapes
            .iter()
            .enumerate()
            .map(|(i, shape)| (object_id(None, i), bounding_sphere(&shape.geometry)));
        // An instance's shapes, each its own object as its copy would be; each prototype
        // shape's sphere is found once, not once per instance.
        let spheres: Vec<Vec<_>> = scene
            .prototypes
            .iter()
            .map(|p| {
                p.shapes
                    .iter()
                    .map(|s| bounding_sphere(&s.geometry))
                    .collect()
            })
            .collect();
        let placed = scene
            .instances
            .iter()
            .enumerate()
            .flat_map(|(k, instance)| {
                let own = &spheres[instance.prototype as usize];
                own.iter().enumerate().map(move |(j, sphere)| {
                    let sphere = sphere.map(|(c, r)| {
                        let c = instance.to_world().transform_point3(c);
                        (c, r * instance.max_stretch())
                    });
                    (object_id(Some(k as u32), j), sphere)
                })
            });
        let discs = world
            .chain(placed)
            .filter_map(|(object, sphere)| {
                let (center, radius) = sphere?;
                let disc = project(camera, center, radius)?;
                (disc.r < SMALL_RADIUS).then_some(Disc { object, ..disc })
            })
            .collect();
        SmallObjects { discs }
    }

    /// The discs overlapping the pixel rectangle [x0, x1] × [y0, y1].
    pub fn in_rect(&self, x0: f32, y0: f32, x1: f32, y1: f32) -> Vec<Disc> {
        self.discs
            .iter()
            .filter(|d| d.overlaps_rect(x0, y0, x1, y1))
            .copied()
            .collect()
    }

    /// The discs that are in one of `self` and `other` but not in both: where a sampler
    /// guided by one may take other samples than one guided by the other.
    pub fn differences<'a>(&'a self, other: &'a SmallObjects) -> impl Iterator<Item = &'a Disc> {
        let only = |a: &'a SmallObjects, b: &'a SmallObjects| {
            a.discs.iter().filter(move |d| !b.discs.contains(d))
        };
        only(self, other).chain(only(other, self))
    }
}

/// A sphere around the shape: exact for a sphere, around the box of a mesh's vertices.
fn bounding_sphere(geometry: &Geometry) -> Option<(Vec3, f32)> {
    if let Primitives::Sphere { center, radius } = geometry.primitives() {
        return Some((center, radius));
    }
    let (lo, hi) = geometry.bounds();
    (lo.cmple(hi).all()).then(|| ((lo + hi) * 0.5, (hi - lo).length() * 0.5))
}

/// The disc on the film that holds the image of the sphere.
fn project(camera: &CameraBasis, center: Vec3, radius: f32) -> Option<Disc> {
    let (x, y, r) = camera.sphere_image(center, radius)?;
    Some(Disc {
        x,
        y,
        r,
        object: u32::MAX,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::camera::Camera;

    fn camera() -> CameraBasis {
        Camera {
            position: Vec3::ZERO,
            look_at: Vec3::new(0.0, 0.0, -1.0),
            up: Vec3::Y,
            fov_deg: 60.0,
            width: 64,
            height: 64,
            projection: Default::default(),
        }
        .basis()
    }

    #[test]
    fn projected_disc_bounds_the_sphere_image() {
        let cam = camera();
        let (center, radius) = (Vec3::new(0.3, -0.2, -40.0), 0.05);
        let disc = project(&cam, center, radius).unwrap();
        // Points on the sphere's silhouette as seen from the pinhole project inside the disc.
        let axis = center.normalize();
        let u = axis.cross(Vec3::Y).normalize();
        let v = axis.cross(u);
        let d = center.length();
        let along = radius * radius / d;
        let across = radius * (1.0 - (radius / d).powi(2)).sqrt();
        for k in 0..16 {
            let a = k as f32 * std::f32::consts::TAU / 16.0;
            let p = center - axis * along + (u * a.cos() + v * a.sin()) * across;
            let (x, y, _) = cam.raster(p).unwrap();
            let r = ((x - disc.x).powi(2) + (y - disc.y).powi(2)).sqrt();
            assert!(r <= disc.r * 1.0001, "{r} outside {}", disc.r);
            assert!(r >= disc.r * 0.95, "disc {} far larger than {r}", disc.r);
        }
    }

    #[test]
    fn square_overlap_is_exact_at_the_corners() {
        let disc = Disc {
            x: 0.0,
            y: 0.0,
            r: 1.0,
            object: 0,
        };
        assert!(disc.overlaps(0.7, 0.7, 1.0));
        assert!(!disc.overlaps(0.71, 0.71, 1.0));
        assert!(disc.overlaps(-0.5, -0.5, 1.0));
        assert!(disc.overlaps(-3.0, -3.0, 10.0));
    }
}
