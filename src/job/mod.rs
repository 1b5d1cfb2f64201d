//! A render described as a value, and the engine that runs it. A [`Job`] names the
//! technique with its settings ([`Technique`], made from [`Settings`] by
//! [`Technique::create`]), the view (size, and optionally a part of the image), the seed, the
//! threads and the intersection backend. A [`Renderer`] builds what the job renders from
//! (the intersection structure; the technique's preparation) and renders it; the caller
//! passes a [`Control`] with its own cancel token, memory budget and progress sink, and gets
//! the image and its statistics back. Every front end (the command line, a farm job, an
//! animation, a benchmark, an embedding program) renders through it.

pub use crate::control::{
    human_size, parse_size, CancelToken, Control, MemoryBudget, Phase, Progress, Silent,
};
pub use crate::integrators::technique::{
    info as technique_info, CacheSettings, MonteCarloSettings, NetworkSettings, Setting,
    SppmSettings, Technique, TechniqueInfo, WhittedSettings, TECHNIQUES,
};
pub use crate::settings::{
    AntiAliasing, NetworkBuilder, NetworkOrder, Relight, Settings, TechniqueKind,
};

use crate::accel::{self, Accel, Backend};
use crate::error::{Error, Result};
use crate::image::filter::Reconstruction;
use crate::image::Image;
use crate::render::aov::render_aovs;
use crate::render::pixels::{render_pixels, PixelView};
use crate::render::progressive::{render_passes, render_region};
use crate::render::whole::render_whole;
use crate::render::PixelSampling;
use crate::render::{Film, RenderStats, Tile, Watch};
use crate::scene::{Scene, MAX_RESOLUTION};
use crate::transport::technique::{Lifecycle, Tiles};
use crate::transport::Context;
use crate::transport::View;
use std::sync::Arc;
use std::time::Instant;

/// A render: what to render with, at what size, which pixels, with which random streams.
#[derive(Clone, Debug, PartialEq)]
pub struct Job {
    pub technique: Technique,
    pub width: u32,
    pub height: u32,
    /// Only these pixels of the image (a render job's part of it); `None`: all of them.
    /// Every pixel has the value the whole render gives it.
    pub region: Option<Tile>,
    /// Seed of the random streams: the image is a function of (scene, settings, seed).
    pub seed: u64,
    /// Worker threads; `None` uses every core. The image does not depend on it.
    pub threads: Option<usize>,
    pub accel: Backend,
    /// Keep each pixel's sample statistics for the variance, error and sample-count images
    /// ([`Film::statistics_images`]) though adaptive sampling is off (it keeps them
    /// anyway). Only the techniques whose samples belong to a pixel keep them (the path
    /// tracer), over the whole image: see [`Job::keeps_statistics`]. The image does not
    /// depend on it.
    pub statistics: bool,
}

impl Job {
    /// A job rendering `scene`'s camera view at its own size with `technique`, seed 0, on
    /// every core, with Embree.
    pub fn new(scene: &Scene, technique: Technique) -> Job {
        Job {
            technique,
            width: scene.camera.width,
            height: scene.camera.height,
            region: None,
            seed: 0,
            threads: None,
            accel: Backend::default(),
            statistics: false,
        }
    }

    /// Whether the render keeps each pixel's sample statistics ([`Job::statistics`]): a
    /// progressive render of the whole image whose samples belong to their pixels. Light
    /// and bidirectional tracing splat light paths onto every pixel, so a pixel has no
    /// samples of its own; a part of an image keeps none.
    pub fn keeps_statistics(&self) -> bool {
        let per_pixel = self.technique.renders_parts() && self.technique.monte_carlo().is_some();
        let adaptive = self
            .technique
            .monte_carlo()
            .is_some_and(|m| m.adaptive.is_some());
        self.region.is_none() && ((self.statistics && per_pixel) || adaptive)
    }

    /// Checks what can be checked before any work.
    pub fn validate(&self) -> Result<()> {
        for (name, v) in [("width", self.width), ("height", self.height)] {
            if !(1..=MAX_RESOLUTION).contains(&v) {
                return Err(Error::setting(
                    name,
                    format!("must be between 1 and {MAX_RESOLUTION}, got {v}"),
                ));
            }
        }
        if let Some(threads) = self.threads {
            crate::platform::check_threads("threads", threads)?;
        }
        let Some(r) = self.region else {
            return Ok(());
        };
        if r.x0 >= r.x1 || r.y0 >= r.y1 || r.x1 > self.width || r.y1 > self.height {
            return Err(Error::setting(
                "region",
                format!(
                    "{},{},{},{} is empty or outside the {}x{} image",
                    r.x0, r.y0, r.x1, r.y1, self.width, self.height
                ),
            ));
        }
        let kind = self.technique.kind();
        if !self.technique.renders_parts() {
            return Err(Error::setting(
                "region",
                format!(
                    "does not apply to the {kind} integrator: its light paths splat onto every \
                     pixel of the image, so a part cannot be rendered alone"
                ),
            ));
        }
        self.technique.check_part()?;
        if let Some(m) = self.technique.monte_carlo() {
            crate::transport::settings::refuse_for_parts(m.time_limit, m.adaptive, m.guiding)?;
        }
        Ok(())
    }

    /// An empty film of the job's whole image, as its progressive render fills it (what a
    /// checkpoint is restored into; [`Technique::passes`] says how many passes it takes);
    /// `None` for the techniques that render in one pass.
    pub fn blank_film(&self) -> Result<Option<Film>> {
        let (width, height) = (self.width, self.height);
        if let Technique::Sppm(s) = &self.technique {
            let film = Film::new(width, height, s.filter, Reconstruction::Importance)?
                .with_one_sample_passes(true)
                .with_state(crate::integrators::sppm::STATE_LEN)?;
            return Ok(Some(film));
        }
        let Some(mc) = self.technique.monte_carlo() else {
            return Ok(None);
        };
        let film = Film::new(width, height, mc.filter, mc.reconstruction)?
            .with_adaptive(mc.adaptive)?
            .with_statistics(self.keeps_statistics())?
            .with_one_sample_passes(self.technique.one_sample_passes());
        Ok(Some(film))
    }

    /// The pixels the job renders.
    pub fn pixels(&self) -> Tile {
        self.region.unwrap_or(Tile::whole(self.width, self.height))
    }

    /// Every setting that changes pixels, as one line: parts of an image merge, and a
    /// checkpoint resumes, only where theirs are equal.
    pub fn settings_key(&self) -> String {
        let t = &self.technique;
        let mut s = format!(
            "integrator={} size={}x{} max_depth={} accel={} seed={}",
            t.kind(),
            self.width,
            self.height,
            t.max_depth(),
            self.accel,
            self.seed
        );
        s += &t.key();
        s
    }

    /// What a technique's preparation needs of the job.
    pub(crate) fn view(&self) -> View {
        View {
            width: self.width,
            height: self.height,
            region: self.region,
            seed: self.seed,
            threads: self.threads,
            accel: self.accel,
        }
    }

    /// What the film and image of the job take: what [`Renderer::new`] checks against the
    /// memory budget.
    pub fn image_bytes(&self) -> u64 {
        self.width as u64 * self.height as u64 * self.bytes_per_pixel()
    }

    /// Bytes per pixel of the film, the finished tiles, the image, an output's conversion
    /// buffer and its encoded file (held in memory before it is written; at most about the
    /// float pixels).
    fn bytes_per_pixel(&self) -> u64 {
        // Monte Carlo: sums, weights and light-path splats, and tile results (the
        // splatted ones reach past their tiles).
        let film = if self.technique.monte_carlo().is_some() {
            56 + 32
        } else if let Technique::Sppm(_) = self.technique {
            // Its film with each pixel's photon statistics; an iteration's camera paths
            // and visible points are checked when the render starts.
            56 + 8 * crate::integrators::sppm::STATE_LEN as u64 + 32
        } else {
            24
        };
        // Sample counts, sums of squares, which pixels go on, and own sums.
        let statistics = if self.keeps_statistics() { 53 } else { 0 };
        film + statistics + 12 + 16 + 16
    }
}

/// The technique a front end's settings (`given`: only those the user gave) and the scene
/// file's own (its `[render]` table, pbrt's `Integrator`) describe, the front end's winning.
/// With a time limit, an adaptive threshold or adaptive anti-aliasing given, only a given
/// `spp` caps the samples. A given setting the chosen technique does not read is an
/// [`Error::Setting`] "does not apply to the ... integrator"; a bad value the scene file
/// gives is reported at its line there. The command line and the Python package both make
/// their jobs' techniques here, so a scene renders the same through either.
pub fn technique_for(scene: &Scene, given: &Settings) -> Result<Technique> {
    let mut from_scene = scene.settings.clone();
    if given.time_limit.is_some()
        || given.adaptive_threshold.is_some()
        || given.aa == Some(AntiAliasing::Adaptive)
    {
        from_scene.spp = None;
    }
    let settings = from_scene.overlaid(given);
    let kind = settings.integrator.unwrap_or(TechniqueKind::Whitted);
    let names = given.given();
    if let Some(setting) = names.iter().find(|s| !technique_info(kind).reads(s)) {
        return Err(Error::setting(
            setting,
            format!("does not apply to the {kind} integrator"),
        ));
    }
    Technique::create(&settings).map_err(|e| match &e {
        Error::Setting { name, .. } if !names.contains(&name.as_str()) => scene.locate(e),
        _ => e,
    })
}

/// What a render gives back.
#[derive(Debug)]
pub struct Rendered {
    /// The image of the job's pixels (its region's size for a part).
    pub image: Image,
    pub stats: RenderStats,
    /// A progressive render's film (what a checkpoint saves), for the whole image.
    pub film: Option<Film>,
}

impl Rendered {
    /// Whether the render stopped before every sample was taken (cancelled).
    pub fn is_partial(&self) -> bool {
        self.stats.cancelled
    }
}

/// The scene at shutter open, for a moving scene and a technique that cannot follow time
/// (the irradiance cache and the illumination network keep values per point or patch):
/// warned once.
fn still_scene(scene: &Scene, technique: &Technique, control: &Control) -> Option<Scene> {
    if technique.info().follows_time {
        return None;
    }
    match scene.at_shutter_open() {
        std::borrow::Cow::Owned(still) => {
            let name = format!("{} integrator", technique.kind());
            control.warn(&crate::scene::motion::still_warning(&name));
            Some(still)
        }
        std::borrow::Cow::Borrowed(_) => None,
    }
}

/// Renders a [`Job`]: holds the scene, its intersection structure and the prepared
/// technique, so that a network or cache prepared once serves every render after it.
pub struct Renderer {
    scene: Arc<Scene>,
    job: Job,
    accel: Box<dyn Accel>,
    technique: Box<dyn Lifecycle>,
    prepared: bool,
    /// The job's worker threads for the parallel phases besides rendering (the
    /// intersection structure's build, a technique's preparation); `None`: every core.
    pool: Option<Arc<rayon::ThreadPool>>,
}

/// A pool of `threads` workers for the phases that run on rayon (`None`: rayon's global
/// pool, every core). A pool the system refuses (no threads to be had) leaves the global
/// pool, with a warning: the image does not depend on it.
fn worker_pool(threads: Option<usize>, control: &Control) -> Option<Arc<rayon::ThreadPool>> {
    let n = threads?;
    match rayon::ThreadPoolBuilder::new().num_threads(n).build() {
        Ok(pool) => Some(Arc::new(pool)),
        Err(e) => {
            control.warn(&format!("{n} worker threads: {e}; using every core"));
            None
        }
    }
}

/// Runs `work` on `pool` (or where it is called, without one).
fn on_pool<T: Send>(pool: &Option<Arc<rayon::ThreadPool>>, work: impl FnOnce() -> T + Send) -> T {
    match pool {
        Some(pool) => pool.install(work),
        None => work(),
    }
}

impl std::fmt::Debug for Renderer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Renderer")
            .field("job", &self.job)
            .field("prepared", &self.prepared)
            .finish_non_exhaustive()
    }
}

impl Renderer {
    /// Checks the job and builds the scene's intersection structure; the technique's own
    /// preparation runs on the first render (or [`prepare`](Self::prepare)).
    pub fn new(scene: impl Into<Arc<Scene>>, job: Job, control: &Control) -> Result<Renderer> {
        let mut scene = scene.into();
        job.validate()?;
        // The readers check their cameras; a scene made by a program is checked here.
        scene.camera.check().map_err(|p| {
            Error::input(&scene.source, format!("camera.{} {}", p.field, p.message))
        })?;
        control.budget.check(
            &format!("a {}x{} image", job.width, job.height),
            job.image_bytes(),
        )?;
        if let Some(still) = still_scene(&scene, &job.technique, control) {
            scene = Arc::new(still);
        }
        // Created for the scene as given: a relight keeps its emissions as the file's.
        let technique = job.technique.lifecycle(&scene)?;
        if let Some((what, bytes)) = technique.memory(job.width, job.height) {
            control
                .budget
                .check(&what, bytes.saturating_add(job.image_bytes()))?;
        }
        if let Technique::Network(n) = &job.technique {
            // The network's patches are world-space shapes.
            if scene.has_instances() {
                scene = Arc::new(scene.flattened());
            }
            if let Some(relit) =
                crate::integrators::illumination_network::technique::relit_scene(&scene, n)?
            {
                scene = Arc::new(relit);
            }
        }
        control.cancel.check("loading")?;
        let pool = worker_pool(job.threads, control);
        let accel = on_pool(&pool, || {
            let phase = control.phase("building", None, "");
            let accel = accel::build(&scene, job.accel, control)?;
            phase.end(&format!(
                "{} intersection structure over {} primitives",
                job.accel,
                scene.primitive_count()
            ));
            Ok::<_, Error>(accel)
        })?;
        Ok(Renderer {
            scene,
            job,
            accel,
            technique,
            prepared: false,
            pool,
        })
    }

    pub fn job(&self) -> &Job {
        &self.job
    }

    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// Renders with another seed from now on (for a Monte Carlo technique, an independent
    /// image); a technique prepares again, as its preparation may draw on the seed.
    pub(crate) fn set_seed(&mut self, seed: u64) {
        if seed != self.job.seed {
            self.job.seed = seed;
            self.prepared = false;
        }
    }

    /// Looks through another camera (its size is the job's). A view-independent technique
    /// (the network, and those with nothing to prepare) renders the new view from what it
    /// prepared; the irradiance cache runs its overture for the new view on the next render,
    /// starting from the values it has. A camera that [`Camera::check`] refuses is an
    /// [`Error::Invalid`] naming the field, and the view stays as it was.
    ///
    /// [`Camera::check`]: crate::scene::Camera::check
    pub fn set_camera(&mut self, camera: crate::scene::Camera) -> Result<()> {
        camera
            .check()
            .map_err(|p| Error::Invalid(format!("camera {} {}", p.field, p.message)))?;
        Arc::make_mut(&mut self.scene).camera = camera;
        if self.technique.view_dependent() {
            self.prepared = false;
        }
        Ok(())
    }

    /// The technique's preparation (the irradiance cache's overture, the network's
    /// preprocess and distribution); done once.
    pub fn prepare(&mut self, control: &Control) -> Result<()> {
        if !self.prepared {
            let ctx = Context::new(&self.scene, self.accel.as_ref());
            let (technique, view) = (&mut self.technique, self.job.view());
            on_pool(&self.pool, || technique.prepare(&ctx, &view, control))?;
            self.prepared = true;
        }
        Ok(())
    }

    /// The preparation alone, saved to the technique's file for render jobs to read: an
    /// irradiance cache's overture for this view, or a network's structure.
    pub fn precompute(&mut self, control: &Control) -> Result<()> {
        let ctx = Context::new(&self.scene, self.accel.as_ref());
        let (technique, view) = (&mut self.technique, self.job.view());
        on_pool(&self.pool, || technique.precompute(&ctx, &view, control)).map_err(|e| match e {
            Error::Invalid(why) => Error::Invalid(format!(
                "the {} integrator: {why}",
                self.job.technique.kind()
            )),
            e => e,
        })
    }

    /// Statistics of the technique's preparation, one line each.
    pub fn report(&self) -> Vec<String> {
        self.technique.report()
    }

    /// Renders the job. A cancel returns what was finished, marked partial.
    pub fn render(&mut self, control: &Control) -> Result<Rendered> {
        self.render_progressive(control, None, Watch::nobody())
    }

    /// Renders the job, continuing a progressive render from `resume` (a film saved by an
    /// earlier, cancelled render of the same job), with `watch` seeing the film after every
    /// whole pass of samples (to write it, or a checkpoint) and, if it asks, in the middle
    /// of passes (a live view).
    pub fn render_progressive(
        &mut self,
        control: &Control,
        resume: Option<Film>,
        watch: Watch,
    ) -> Result<Rendered> {
        let preparing = (!self.prepared && self.technique.prepares()).then(Instant::now);
        self.prepare(control)?;
        let prepare_seconds = preparing.map_or(0.0, |t| t.elapsed().as_secs_f64());
        let ctx = Context::new(&self.scene, self.accel.as_ref());
        let job = &self.job;
        let region = job.pixels();
        let mut rendered = match self.technique.tiles() {
            Tiles::Pixels(integrator, sampling) => {
                if resume.is_some() {
                    return Err(Error::setting(
                        "resume",
                        format!(
                            "applies to progressive renders, not the {} integrator",
                            job.technique.kind()
                        ),
                    ));
                }
                let view = PixelView {
                    view: job.view(),
                    sampling,
                };
                let (image, stats) = render_pixels(&ctx, integrator, &view, &region, control)?;
                Rendered {
                    image,
                    stats,
                    film: None,
                }
            }
            Tiles::Samples(integrator, mc) => {
                let mut options = job.view().progressive(&mc);
                options.statistics = job.keeps_statistics();
                if job.region.is_some() {
                    let (image, stats) =
                        render_region(&ctx, integrator, &options, &region, control)?;
                    Rendered {
                        image,
                        stats,
                        film: None,
                    }
                } else {
                    let (film, mut stats) =
                        render_passes(&ctx, integrator, &options, resume, watch, control)?;
                    stats.invalid = film.invalid;
                    Rendered {
                        image: film.image()?,
                        stats,
                        film: Some(film),
                    }
                }
            }
            Tiles::Whole(technique) => {
                let passes = job.technique.passes().unwrap_or(1);
                let film = match resume {
                    Some(film) => film,
                    None => job.blank_film()?.ok_or_else(|| {
                        Error::Invalid("a whole-image technique without a film".into())
                    })?,
                };
                let (film, stats) = render_whole(
                    &ctx,
                    (technique, passes),
                    &job.view(),
                    film,
                    self.pool.as_deref(),
                    watch,
                    control,
                )?;
                Rendered {
                    image: film.image()?,
                    stats,
                    film: Some(film),
                }
            }
        };
        if !rendered.stats.cancelled {
            self.technique.annotate(&ctx, &mut rendered.image, control);
        }
        rendered.stats.prepare_seconds = prepare_seconds;
        Ok(rendered)
    }

    /// A quick first image of the view, for interactive front ends (a camera being moved):
    /// the pixel techniques (Whitted, the network, the irradiance cache) take one sample at
    /// each pixel's centre instead of the job's anti-aliasing or supersampling; the same
    /// image as a job with `aa = uniform, spp = 1`. `None` for the progressive techniques,
    /// whose first pass already is such an image. [`render`](Self::render) is unchanged.
    pub fn render_preview(&mut self, control: &Control) -> Result<Option<Rendered>> {
        self.prepare(control)?;
        let ctx = Context::new(&self.scene, self.accel.as_ref());
        let Tiles::Pixels(integrator, _) = self.technique.tiles() else {
            return Ok(None);
        };
        let job = &self.job;
        let view = PixelView {
            view: job.view(),
            sampling: PixelSampling::Uniform { n: 1 },
        };
        let (image, stats) = render_pixels(&ctx, integrator, &view, &job.pixels(), control)?;
        Ok(Some(Rendered {
            image,
            stats,
            film: None,
        }))
    }

    /// The auxiliary images of the job's pixels (albedo, normal, depth: what the camera
    /// sees first, filtered as the image is), or `None` if cancelled;
    /// [`Error::OutOfMemory`] if they cannot be allocated.
    pub fn render_aovs(&self, control: &Control) -> Result<Option<[Image; 3]>> {
        Ok(self
            .render_aov_layers(control)?
            .map(|[albedo, normal, depth, ..]| [albedo, normal, depth]))
    }

    /// Every auxiliary image of the job's pixels, in the order of [`Aov::LAYERS`]: albedo,
    /// normal, depth and position filtered as the image is, and the object and material
    /// indices seen through each pixel's centre. `None` if cancelled; [`Error::OutOfMemory`]
    /// if they cannot be allocated.
    pub fn render_aov_layers(&self, control: &Control) -> Result<Option<[Image; 6]>> {
        let ctx = Context::new(&self.scene, self.accel.as_ref());
        // The image's filter; the scene's for the techniques that have none.
        let filter = match self.job.technique.monte_carlo() {
            Some(m) => m.filter,
            None => self.scene.settings.filter.unwrap_or_default(),
        };
        render_aovs(
            &ctx,
            (self.job.width, self.job.height),
            &self.job.pixels(),
            (filter, self.job.seed, self.job.threads),
            control,
        )
    }
}

/// Light groups a render keeps at most ([`Renderer::check_light_passes`]).
pub const MAX_LIGHT_GROUPS: usize = 64;

/// The light passes of a render ([`Renderer::render_light_passes`]): each layer's name and
/// image, the lobe passes ([`LOBE_PASSES`]) first, then the light groups.
#[derive(Debug)]
pub struct LightPasses {
    pub layers: Vec<(String, Image)>,
}

pub use crate::transport::light_passes::LOBE_PASSES;

impl Renderer {
    /// Whether the job can render its light passes (with a layer for each light if
    /// `groups`): [`Error::Setting`] `light_passes` (or `light_groups`) naming why not, to be
    /// asked before the render. They are the path tracer's (as Cycles' are its path
    /// tracer's), on surfaces, with every pixel taking the same samples.
    pub fn check_light_passes(&self, groups: bool) -> Result<()> {
        let refuse = |why: String| Err(Error::setting("light_passes", why));
        let t = &self.job.technique;
        let Technique::Path(mc) = t else {
            return refuse(format!(
                "does not apply to the {} integrator: the light passes are the path tracer's",
                t.kind()
            ));
        };
        if mc.spectral {
            return refuse("does not apply in spectral mode: the passes are RGB".into());
        }
        if mc.guiding {
            return refuse(
                "does not apply with path guiding: its samples follow a guide \
                           learned during the render"
                    .into(),
            );
        }
        if mc.time_limit.is_some() || mc.adaptive.is_some() {
            return refuse(
                "needs a fixed number of samples per pixel (no time limit, no \
                           adaptive sampling)"
                    .into(),
            );
        }
        if !self.scene.media.is_empty() {
            return refuse("does not apply to a scene with participating media".into());
        }
        if groups {
            let ctx = Context::new(&self.scene, self.accel.as_ref());
            let n = ctx.lights.emitters.len();
            if n > MAX_LIGHT_GROUPS {
                return Err(Error::setting(
                    "light_groups",
                    format!(
                        "the scene has {n} lights (emitting shapes, lights and the \
                         background); at most {MAX_LIGHT_GROUPS} get layers of their own"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The light passes of the job's pixels, from the image's own camera samples taken
    /// again (as [`check_light_passes`](Self::check_light_passes) allows): Cycles' lobe
    /// passes, and with `groups` the light of each light alone (`Combined_light0`, ...: the
    /// emitting shapes in the scene's order, then the scene's lights, then the background;
    /// `Combined_unlisted` for emitting instances). `None` if cancelled.
    pub fn render_light_passes(
        &mut self,
        groups: bool,
        control: &Control,
    ) -> Result<Option<LightPasses>> {
        self.check_light_passes(groups)?;
        self.prepare(control)?;
        let ctx = Context::new(&self.scene, self.accel.as_ref());
        let Tiles::Samples(integrator, mc) = self.technique.tiles() else {
            return Err(Error::Invalid(
                "the light passes are the path tracer's".into(),
            ));
        };
        let options = self.job.view().progressive(&mc);
        let emitters = ctx.lights.emitters.len();
        let count = if groups { emitters + 1 } else { 0 };
        let Some(images) = crate::render::light_passes::render_light_passes(
            &ctx,
            integrator,
            &options,
            &self.job.pixels(),
            count,
            control,
        )?
        else {
            return Ok(None);
        };
        let unlisted = !self.scene.instances.is_empty();
        let layers = images
            .into_iter()
            .enumerate()
            .filter_map(|(k, image)| {
                let name = match k.checked_sub(LOBE_PASSES.len()) {
                    None => LOBE_PASSES[k].to_string(),
                    Some(g) if g < emitters => format!("Combined_light{g}"),
                    Some(_) if unlisted => "Combined_unlisted".to_string(),
                    Some(_) => return None,
                };
                Some((name, image))
            })
            .collect();
        Ok(Some(LightPasses { layers }))
    }
}

/// The auxiliary images: what each of [`Renderer::render_aovs`]' images holds.
pub use crate::render::aov::Aov;
