//! How a progressive render shows its film to the caller while it runs: after every whole
//! pass (to write the image or a checkpoint), and, for a live view, in the middle of a pass
//! as often as the caller asks. The render's result does not depend on either.

use super::{Film, RenderStats};
use crate::error::Result;
use std::time::Duration;

/// When the film is shown.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shown {
    /// A whole pass has been added: every pixel has [`Film::spp`] samples.
    AfterPass,
    /// Part of a pass has been added: the tiles before [`Film::mean_spp`]'s share have one
    /// more pass of samples than the rest ([`Film::image`] divides each pixel by its own).
    MidPass,
}

/// The caller's view of a progressive render: `film` sees the film, when it is shown and
/// the statistics so far (rays, samples, seconds: a live Mrays/s). An error from it stops
/// the render with that error.
pub struct Watch<'a> {
    pub film: &'a mut dyn FnMut(&Film, Shown, &RenderStats) -> Result<()>,
    /// Also show the film in the middle of a pass, at most this often (`None`: only after
    /// whole passes). Later passes take long: a live view asks for a few times a second.
    pub mid_pass: Option<Duration>,
}

impl Watch<'static> {
    /// Shows the film to no one (a render whose caller needs only its result).
    pub fn nobody() -> Watch<'static> {
        // The closure captures nothing: leaking its box allocates nothing.
        Watch::after_passes(Box::leak(Box::new(
            |_: &Film, _: Shown, _: &RenderStats| Ok(()),
        )))
    }
}

impl<'a> Watch<'a> {
    /// Shows the film after whole passes only.
    pub fn after_passes(
        film: &'a mut dyn FnMut(&Film, Shown, &RenderStats) -> Result<()>,
    ) -> Watch<'a> {
        Watch {
            film,
            mid_pass: None,
        }
    }
}
