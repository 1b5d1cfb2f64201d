//! The render of a technique that takes the whole image at once ([`WholeImage`]: stochastic
//! progressive photon mapping), in passes over every pixel. The film keeps each pixel's
//! state as the technique leaves it after a pass and each pixel's value times the passes
//! taken, so that the film's image is the technique's image, a live view sees it converge
//! after each pass, and a checkpoint saved between passes resumes to the same image an
//! uninterrupted render makes.

use super::{Film, RenderStats, Shown, Watch};
use crate::control::Control;
use crate::error::{Error, Result};
use crate::transport::technique::WholeImage;
use crate::transport::{Context, RayStats, View};
use std::time::Instant;

/// Renders `passes` passes of `technique` over the image of `view` into `film` (an empty
/// one of the view's size with the technique's state, or one a checkpoint restored),
/// each pass on `pool` (if any), `watch` seeing the film after each. A cancel returns
/// the film of the whole passes finished.
pub(crate) fn render_whole(
    ctx: &Context,
    (technique, passes): (&dyn WholeImage, u32),
    view: &View,
    mut film: Film,
    pool: Option<&rayon::ThreadPool>,
    watch: Watch,
    control: &Control,
) -> Result<(Film, RenderStats)> {
    let n = technique.state_len();
    if film.size() != (view.width, view.height) || film.state_len != n || film.max_pass != 1 {
        return Err(Error::Invalid(
            "the film to resume was rendered at another size or by another technique".into(),
        ));
    }
    if film.spp == 0 {
        technique.start(ctx, view, &mut film.state);
    }
    let start = Instant::now();
    let mut stats = RenderStats::default();
    let done = film.spp;
    let phase = control.phase(
        "render",
        Some(passes.saturating_sub(done) as u64),
        &technique.unit(view),
    );
    let mut rays = RayStats::default();
    for index in done..passes {
        let state = &mut film.state;
        let mut work = || technique.pass(ctx, view, index, state, &control.cancel);
        let Some(pass) = (match pool {
            Some(pool) => pool.install(work),
            None => work(),
        }) else {
            stats.cancelled = true;
            break;
        };
        rays.add(&pass.rays);
        stats.samples += pass.samples;
        film.spp += 1;
        // The film's image divides each pixel's sum by the passes taken.
        for (sum, pixel) in film.sums.iter_mut().zip(film.state.chunks_exact(n)) {
            *sum = technique.value(view, pixel);
        }
        stats.rays = rays;
        stats.seconds = start.elapsed().as_secs_f64();
        phase.advance(1);
        (watch.film)(&film, Shown::AfterPass, &stats)?;
    }
    stats.rays = rays;
    stats.seconds = start.elapsed().as_secs_f64();
    phase.end(&format!(
        "{} {}, {} rays",
        film.spp,
        technique.unit(view),
        rays.total()
    ));
    Ok((film, stats))
}
