//! Connecting a point to the camera, as light tracing and bidirectional tracing do: where it
//! lands on the film and the camera's importance there.

use crate::math::sobol::Sampler;
use crate::math::spawn::Spot;
use crate::math::Vec3;
use crate::scene::camera::CameraBasis;
use crate::transport::{Context, RayStats};

/// A point seen by the camera: where it lands on the film and the factor that turns
/// "radiance leaving the point towards the camera, times |cos| at the point" into a splat:
/// W_e·cos θ_c / d² = 1 / (A_pixel cos³θ_c d²) for a pinhole with an image plane at unit
/// distance (pbrt's We = 1/(A cos⁴θ) times the camera-side cosine).
pub(crate) struct CameraConnection {
    pub x: f32,
    pub y: f32,
    /// Unit direction from the point to the camera.
    pub dir: Vec3,
    pub importance: f32,
}

/// Connects point `at` (with its error and geometric normal) to the camera at the lens point
/// `lens` (the pinhole, or a point of a thin lens drawn uniformly over it): `None` if it is
/// outside the film (widened by the filter radius) or hidden. For a thin lens, the
/// importance keeps the pinhole's form with θ and d measured from the lens point: pbrt-v4's
/// We = 1/(A cos⁴θ · lens area) times cos θ over the lens-area density d²/(cos θ · lens area).
pub(crate) fn connect_to_camera(
    ctx: &Context,
    camera: &CameraBasis,
    lens: Vec3,
    at: &Spot,
    time: f32,
    stats: &mut RayStats,
) -> Option<CameraConnection> {
    let c = project_to_camera(camera, lens, at.p)?;
    let shadow = at.spawn_to(&Spot::exact(lens)).at_time(time);
    if ctx.occluded(&shadow, stats) {
        return None;
    }
    Some(c)
}

/// Where point `p` lands on the film seen from lens point `lens`, and its importance, as
/// [`connect_to_camera`] gives them, whatever lies between.
pub(crate) fn project_to_camera(
    camera: &CameraBasis,
    lens: Vec3,
    p: Vec3,
) -> Option<CameraConnection> {
    let (x, y, cos_c) = camera.raster_from(lens, p)?;
    let (w, h) = camera.film_size();
    let margin = camera.margin;
    if x < -margin || y < -margin || x >= w + margin || y >= h + margin {
        return None;
    }
    let to_cam = lens - p;
    let dist2 = to_cam.length_squared();
    let dir = to_cam / dist2.sqrt();
    let importance = 1.0 / (camera.pixel_area() * cos_c * cos_c * cos_c * dist2);
    Some(CameraConnection {
        x,
        y,
        dir,
        importance,
    })
}

/// The lens point of a connection to the camera: a uniform point of a thin lens (drawing
/// two numbers), the pinhole otherwise (drawing none, so pinhole images keep their samples).
pub(crate) fn lens_sample(camera: &CameraBasis, sampler: &mut Sampler) -> Vec3 {
    if camera.has_lens() {
        camera.lens_point(sampler.next_2d())
    } else {
        camera.origin
    }
}

/// Density in solid angle of the camera generating a ray along `w` from the lens point
/// `lens`: uniform over the film at unit distance, 1 / (A_film cos³θ) (pbrt-v4's `PDF_We`;
/// the lens point's own density is the same for every strategy and cancels). Zero outside
/// the film.
pub(crate) fn camera_pdf_dir(camera: &CameraBasis, lens: Vec3, w: Vec3) -> f32 {
    match camera.raster_from(lens, lens + w) {
        Some((x, y, cos)) => {
            let (fw, fh) = camera.film_size();
            let m = camera.margin;
            if x < -m || y < -m || x >= fw + m || y >= fh + m {
                return 0.0;
            }
            1.0 / (camera.pixel_area() * fw * fh * cos * cos * cos)
        }
        None => 0.0,
    }
}
