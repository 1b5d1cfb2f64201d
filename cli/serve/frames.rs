//! The studio's frames of a keyframed scene: the frame slider's renders. With the Whitted
//! or path integrator each frame goes through the coherence engine (a [`Sequence`] fed the
//! frames in the order the page asks for them: what changed since the frame shown before is
//! retraced, the rest kept), and the page can lay the map of what was retraced over the
//! image; any other integrator renders each frame in full.

use raylink::coherence::report::retrace_map;
use raylink::coherence::{Coherence, Sequence};
use raylink::image::Image;
use raylink::scene::animation::Animation;
use raylink::scene::Camera;
use raylink::{Control, Job, Renderer, Result};

/// Pixel blocks of the coherence engine's tables, as `raylink animate`'s default.
const BLOCKS: (u32, u32) = (16, 16);

/// A frame rendered for the page.
pub struct Frame {
    pub image: Image,
    /// The retraced-pixel map (coherent renders only).
    pub map: Option<Image>,
    /// The share of pixels retraced (1 for a frame traced in full).
    pub retraced: f64,
    pub rays: u64,
    pub seconds: f64,
}

/// The animation and the engine that renders its frames.
pub struct Frames {
    pub animation: Animation,
    job: Job,
    /// With a job the coherence engine renders: its settings and the sequence so far.
    coherent: Option<(Coherence, Option<Sequence>)>,
}

impl Frames {
    /// The frames of `animation` rendered as `job` says (its camera and scene are replaced
    /// by each frame's).
    pub fn new(animation: Animation, job: &Job) -> Frames {
        // A job the engine cannot follow (a time limit) renders its frames in full.
        let coherence = Coherence {
            blocks: BLOCKS,
            ..Coherence::default()
        };
        let coherent = Sequence::new(job, &coherence)
            .ok()
            .map(|sequence| (coherence, Some(sequence)));
        Frames {
            animation,
            job: job.clone(),
            coherent,
        }
    }

    /// Frame `frame` seen through `camera`: from the frame rendered before it, coherently,
    /// where the integrator allows.
    pub fn render(&mut self, frame: i64, camera: &Camera, control: &Control) -> Result<Frame> {
        let mut scene = self.animation.scene_at(frame)?;
        scene.camera = camera.clone();
        let Some((coherence, sequence)) = &mut self.coherent else {
            let clock = std::time::Instant::now();
            let mut renderer = Renderer::new(scene, self.job.clone(), control)?;
            let rendered = renderer.render(control)?;
            return Ok(Frame {
                image: rendered.image,
                map: None,
                retraced: 1.0,
                rays: rendered.stats.rays.total(),
                seconds: clock.elapsed().as_secs_f64(),
            });
        };
        // A frame cut short leaves the engine to start again (its first frame in full).
        let mut engine = match sequence.take() {
            Some(s) => s,
            None => Sequence::new(&self.job, coherence)?,
        };
        let (image, row) = engine.next(frame, &scene, control, false)?;
        *sequence = Some(engine);
        let stats = &row.coherent;
        let pixels = (self.job.width as u64 * self.job.height as u64).max(1);
        Ok(Frame {
            map: Some(retrace_map(&image, stats, BLOCKS)),
            retraced: stats.pixels_retraced as f64 / pixels as f64,
            rays: stats.rays.total(),
            seconds: row.time.wall,
            image,
        })
    }
}
