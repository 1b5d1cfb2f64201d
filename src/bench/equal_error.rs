//! The path tracer bench's error part: the Bitterli Cornell box (scenes/cornell-box.toml) at
//! 256x256 with the scene's own filter and settings but 7 bounces, as in the comparison with
//! Mitsuba (`benches/mitsuba_compare.py`), against Tungsten's converged render with the
//! light's pixels excluded, as `examples/compare.rs` measures it. An unbiased estimator's
//! error falls as 1/√samples, so a render of t seconds with error e reaches the target error
//! E in t·(e/E)², with spp·(e/E)² samples per pixel.

use crate::error::{Error, Result};
use crate::image::compare::{box_downsample, bright_mask, rmse};
use crate::image::output::read_image;
use crate::image::Image;
use crate::job::Technique;
use crate::scene::Scene;
use crate::settings::TechniqueKind;
use std::path::{Path, PathBuf};

/// Samples per pixel of each timed render.
pub const SPP: u32 = 64;
/// Samples per pixel with `--quick` (a check that everything runs, not a measurement).
pub const QUICK_SPP: u32 = 4;
/// Width and height of the renders and of the comparison.
pub const SIZE: u32 = 256;
/// Bounces (the command line's `--max-depth 7`; Mitsuba's max_depth 8).
pub const MAX_DEPTH: u32 = 7;
/// The error whose time and samples are reported (Mitsuba 3's at 64 spp).
pub const TARGET_RMSE: f64 = 0.0056;
/// Reference pixels brighter than this in any channel, and their neighbours, are the
/// light's and left out (as in `examples/compare.rs`).
pub(crate) const LIGHT_THRESHOLD: f32 = 1.0;
/// Tungsten's converged render, relative to the working directory or the source tree.
pub const REFERENCE: &str = "scenes/cornell-box-bitterli/TungstenRender-256.exr";

/// The reference file: relative to the working directory, else to the source tree; `None`
/// if it is in neither.
pub(crate) fn reference_path() -> Option<PathBuf> {
    super::scenes::repository_file(REFERENCE)
}

/// The reference at [`SIZE`]×[`SIZE`] and the mask of its light's pixels.
pub(crate) struct Reference {
    pub path: PathBuf,
    image: Image,
    mask: Vec<bool>,
}

impl Reference {
    /// Reads the reference and box-downsamples it to [`SIZE`]×[`SIZE`].
    pub fn load(path: &Path) -> Result<Reference> {
        let (image, _) = read_image(path)?;
        let image = box_downsample(&image, SIZE, SIZE).ok_or_else(|| {
            Error::input(
                path,
                format!(
                    "{}x{} does not divide into {SIZE}x{SIZE}",
                    image.width, image.height
                ),
            )
        })?;
        let mask = bright_mask(&image, LIGHT_THRESHOLD);
        Ok(Reference {
            path: path.to_path_buf(),
            image,
            mask,
        })
    }

    /// The RMSE of `image` (box-downsampled to [`SIZE`]×[`SIZE`]) against the reference,
    /// the light's pixels excluded; `None` if its size does not divide into that.
    pub fn rmse(&self, image: &Image) -> Option<f64> {
        let image = box_downsample(image, SIZE, SIZE)?;
        Some(rmse(&image, &self.image, Some(&self.mask)))
    }
}

/// The technique of the error renders: the scene's own settings (its filter) with the path
/// tracer, [`MAX_DEPTH`] bounces and `spp` samples per pixel.
pub fn technique(scene: &Scene, spp: u32) -> Result<Technique> {
    let mut settings = scene.settings.clone();
    settings.integrator = Some(TechniqueKind::Path);
    settings.max_depth = Some(MAX_DEPTH);
    settings.spp = Some(spp);
    settings.time_limit = None;
    Technique::create(&settings)
}

/// How much longer (in time or samples) a render with error `rmse` must run to reach
/// `target`: (rmse/target)².
pub(crate) fn scale_to(rmse: f64, target: f64) -> f64 {
    (rmse / target).powi(2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::Backend;
    use crate::control::Control;
    use crate::job::{Job, Renderer};

    #[test]
    fn error_falls_as_one_over_root_samples() {
        // Twice the target error needs four times the time and samples.
        assert!((scale_to(2.0 * TARGET_RMSE, TARGET_RMSE) - 4.0).abs() < 1e-12);
        // 3 s at RMSE 0.0084 (1.5× the target): 3 · 2.25 = 6.75 s, 64 · 2.25 = 144 spp.
        let s = scale_to(0.0084, 0.0056);
        assert!((3.0 * s - 6.75).abs() < 1e-9, "{}", 3.0 * s);
        assert!((64.0 * s - 144.0).abs() < 1e-9, "{}", 64.0 * s);
        // Below the target, less time.
        assert!((scale_to(0.0028, 0.0056) - 0.25).abs() < 1e-12);
    }

    #[test]
    fn reference_against_itself_is_exact_and_16_spp_is_close() {
        let path = reference_path().expect("the reference is in the source tree");
        let reference = Reference::load(&path).unwrap();
        assert_eq!(reference.rmse(&reference.image), Some(0.0));
        // The mask leaves out the light and its edge, and little else.
        let masked = reference.mask.iter().filter(|m| **m).count();
        assert!(masked > 0 && masked < 2000, "{masked} masked pixels");
        // Another size does not compare.
        assert_eq!(reference.rmse(&Image::new(100, 100)), None);

        let scene = std::sync::Arc::new(super::super::scenes::resolve("cornell").unwrap());
        let technique = technique(&scene, 16).unwrap();
        assert_eq!(technique.max_depth(), MAX_DEPTH);
        let job = Job {
            width: SIZE,
            height: SIZE,
            seed: 3,
            accel: Backend::Bvh,
            ..Job::new(&scene, technique)
        };
        let control = Control::default();
        let mut renderer = Renderer::new(scene.clone(), job, &control).unwrap();
        let a = renderer.render(&control).unwrap().image;
        let e = reference.rmse(&a).unwrap();
        // About 0.012 (0.006 at 64 spp, twice that at a quarter of the samples).
        assert!(e > 0.0 && e < 0.02, "RMSE {e} at 16 spp");
        // Another seed gives another, independent image with a similar error.
        renderer.set_seed(4);
        let b = renderer.render(&control).unwrap().image;
        assert!(a.pixels != b.pixels, "the seed did not change the image");
        let f = reference.rmse(&b).unwrap();
        assert!(f < 0.02 && (f / e - 1.0).abs() < 0.3, "RMSE {f} and {e}");
    }
}
