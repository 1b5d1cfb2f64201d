//! The studio's render session: one worker thread owns the library's [`Renderer`] and runs
//! one job at a time; the HTTP threads read what it published ([`State`]) and leave it
//! commands ([`Inbox`]): a new camera or a relight cancels the job in hand through its
//! [`CancelToken`] and starts the next one. Progressive renders publish the film after
//! every pass and in between; the network renders each view from the network it prepared
//! once; a keyframed scene's frames go through [`Frames`].

use super::frames::Frames;
use raylink::job::Technique;
use raylink::math::Rgb;
use raylink::scene::Camera;
use raylink::scene::Texture;
use raylink::{
    CancelToken, Control, Error, Film, Image, Job, MemoryBudget, Progress, Relight, RenderStats,
    Renderer, Scene, Shown, Watch,
};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// A relight: a factor per light (emissive material) and per diffuse material, by name.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RelightRequest {
    /// Factors on each light's emission and each material's colour, channel by channel (a
    /// strength times a colour).
    pub lights: Vec<(String, Rgb)>,
    pub materials: Vec<(String, Rgb)>,
}

/// Commands from the page to the worker, and the cancel token of the job in hand (kept
/// here so that a command and the cancel of the job it replaces are one step).
pub struct Inbox {
    camera: Option<(Camera, Instant)>,
    /// The camera last asked for, and the one each step of the view's history left (the
    /// latest last): what "back" returns to.
    asked: Camera,
    back: Vec<Camera>,
    relight: Option<(RelightRequest, Instant)>,
    /// A frame of a keyframed scene to show.
    frame: Option<(i64, Instant)>,
    /// The page shows an auxiliary image: compute them for every view.
    aovs_wanted: bool,
    cancel: CancelToken,
}

/// Steps of the view's history kept for "back".
const MAX_BACK: usize = 64;

/// Where a camera command takes the view.
pub enum Move {
    /// To this camera: a step of the history of its own, or (`true`) part of the step
    /// before it, as the later moves of one drag are, so that one "back" undoes the drag.
    To(Camera, bool),
    /// Back to the camera the last step left.
    Back,
    /// To the scene file's camera: a step of its own, which "back" undoes.
    Reset,
}

/// Where the worker stands.
#[derive(Clone, Debug, PartialEq)]
pub enum Status {
    Preparing,
    Rendering,
    Done,
    Failed(String),
}

/// What the worker published: the page's state and the latest images.
pub struct State {
    /// Bumped whenever anything here changes; the events stream announces it.
    pub version: u64,
    /// The latest beauty image, and its own version (a new one for every image).
    pub image: Option<Arc<Image>>,
    pub image_version: u64,
    /// The view `image` shows.
    pub image_view: u64,
    /// Samples per pixel in `image`, on average over the pixels (in the middle of a pass,
    /// some tiles have one more pass than others): for the pixel techniques 0 in a preview
    /// (one sample at each pixel's centre), 1 in the finished image.
    pub spp: f64,
    /// The camera of the view being rendered, and a count of the views.
    pub camera: Camera,
    pub view: u64,
    pub status: Status,
    /// When the job in hand started, and how long the last one took.
    pub started: Instant,
    pub elapsed: f64,
    /// The render's rays and Mrays/s so far (a progressive render's as it goes, the others'
    /// when they finish).
    pub rays: Option<u64>,
    pub mrays: Option<f64>,
    /// The last camera move's time to its first image, and the last relight's time to its
    /// image (its preparation alone in `relight_prepare_ms`).
    pub view_ms: Option<f64>,
    pub relight_ms: Option<f64>,
    pub relight_prepare_ms: Option<f64>,
    /// The factors of the last relight.
    pub relight: RelightRequest,
    /// Albedo, normal and depth of `aov_view`.
    pub aovs: Option<(u64, Arc<[Image; 3]>)>,
    /// Whether they are computed for every view (the page asked for them).
    pub aovs_wanted: bool,
    /// Steps of the view's history that "back" can undo.
    pub back_steps: usize,
    /// RMSE of `image` against the reference.
    pub rmse: Option<f64>,
    /// The frame of a keyframed scene shown (`None`: the scene as loaded), the map of the
    /// pixels its render retraced, and their share.
    pub frame: Option<i64>,
    pub retrace_map: Option<Arc<Image>>,
    pub retraced: Option<f64>,
    pub notes: Vec<String>,
}

/// What the session shares between the worker and the HTTP threads.
pub struct Session {
    pub state: Mutex<State>,
    pub changed: Condvar,
    inbox: Mutex<Inbox>,
    wake: Condvar,
    /// Set once, by [`Session::quit`].
    quit: AtomicBool,
    pub progress: Arc<Counter>,
    /// What does not change while serving.
    pub base: Base,
}

/// The session's fixed facts.
pub struct Base {
    pub scene: Arc<Scene>,
    pub job: Job,
    pub budget: MemoryBudget,
    pub reference: Option<Image>,
    /// The lights (emissive materials) and the diffuse materials with one colour that a
    /// relight can change, for the network integrator.
    pub lights: Vec<String>,
    pub materials: Vec<String>,
    /// A keyframed scene's first and last frame numbers.
    pub frames: Option<(i64, i64)>,
}

impl Base {
    /// The scene file's camera, at the render's size: the first view, and "reset"'s.
    pub fn scene_camera(&self) -> Camera {
        let mut camera = self.scene.camera.clone();
        camera.width = self.job.width;
        camera.height = self.job.height;
        camera
    }
}

/// The progress sink of the jobs: the phase and its units done, for the ETA.
#[derive(Default)]
pub struct Counter {
    pub phase: Mutex<String>,
    pub total: AtomicU64,
    pub done: AtomicU64,
    pub started: Mutex<Option<Instant>>,
    notes: Mutex<Vec<String>>,
}

impl Progress for Counter {
    fn begin(&self, phase: &str, total: Option<u64>, _unit: &str) {
        *lock(&self.phase) = phase.to_string();
        self.total.store(total.unwrap_or(0), Ordering::Relaxed);
        self.done.store(0, Ordering::Relaxed);
        *lock(&self.started) = Some(Instant::now());
    }
    fn advance(&self, units: u64) {
        self.done.fetch_add(units, Ordering::Relaxed);
    }
    fn note(&self, line: &str) {
        let mut notes = lock(&self.notes);
        notes.push(line.to_string());
        let excess = notes.len().saturating_sub(8);
        notes.drain(..excess);
    }
    fn warn(&self, line: &str) {
        self.note(&format!("warning: {line}"));
    }
}

impl Counter {
    /// Seconds left in the phase in hand at its pace so far, if it has a known size.
    pub fn eta(&self) -> Option<f64> {
        let (total, done) = (
            self.total.load(Ordering::Relaxed),
            self.done.load(Ordering::Relaxed),
        );
        let started = (*lock(&self.started))?;
        if total == 0 || done == 0 || done >= total {
            return None;
        }
        let elapsed = started.elapsed().as_secs_f64();
        Some(elapsed / done as f64 * (total - done) as f64)
    }

    pub fn notes(&self) -> Vec<String> {
        lock(&self.notes).clone()
    }
}

/// A lock that survives a panicked holder (the data are plain values).
pub fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl Session {
    pub fn new(base: Base) -> Session {
        let camera = base.scene_camera();
        Session {
            state: Mutex::new(State {
                version: 1,
                image: None,
                image_version: 0,
                image_view: 0,
                spp: 0.0,
                camera: camera.clone(),
                view: 1,
                status: Status::Preparing,
                started: Instant::now(),
                elapsed: 0.0,
                rays: None,
                mrays: None,
                view_ms: None,
                relight_ms: None,
                relight_prepare_ms: None,
                relight: RelightRequest {
                    lights: base.lights.iter().map(|n| (n.clone(), Rgb::ONE)).collect(),
                    materials: base
                        .materials
                        .iter()
                        .map(|n| (n.clone(), Rgb::ONE))
                        .collect(),
                },
                aovs: None,
                aovs_wanted: false,
                back_steps: 0,
                rmse: None,
                frame: None,
                retrace_map: None,
                retraced: None,
                notes: Vec::new(),
            }),
            changed: Condvar::new(),
            inbox: Mutex::new(Inbox {
                camera: None,
                asked: camera,
                back: Vec::new(),
                relight: None,
                frame: None,
                aovs_wanted: false,
                cancel: CancelToken::new(),
            }),
            wake: Condvar::new(),
            quit: AtomicBool::new(false),
            progress: Arc::new(Counter::default()),
            base,
        }
    }

    /// Moves the view as `to` says, cancelling the job in hand; `false` (and nothing done)
    /// if there is no step to go back to.
    pub fn move_camera(&self, to: Move) -> bool {
        let mut inbox = lock(&self.inbox);
        let left = inbox.asked.clone();
        let camera = match to {
            Move::To(camera, true) => camera,
            Move::To(camera, false) => {
                if camera != left {
                    inbox.back.push(left);
                }
                camera
            }
            Move::Reset => {
                let camera = self.base.scene_camera();
                if camera == left {
                    return true;
                }
                inbox.back.push(left);
                camera
            }
            Move::Back => match inbox.back.pop() {
                Some(camera) => camera,
                None => return false,
            },
        };
        let excess = inbox.back.len().saturating_sub(MAX_BACK);
        inbox.back.drain(..excess);
        inbox.asked = camera.clone();
        inbox.camera = Some((camera, Instant::now()));
        inbox.cancel.cancel();
        self.wake.notify_all();
        // Published under the inbox's lock (the worker's order too), so that the counts
        // the page sees follow the commands' order.
        let steps = inbox.back.len();
        self.publish(|s| s.back_steps = steps);
        true
    }

    /// Relights next, cancelling the job in hand.
    pub fn relight(&self, request: RelightRequest) {
        let mut inbox = lock(&self.inbox);
        inbox.relight = Some((request, Instant::now()));
        inbox.cancel.cancel();
        self.wake.notify_all();
    }

    /// Shows frame `frame` of the keyframed scene next, cancelling the job in hand.
    pub fn set_frame(&self, frame: i64) {
        let mut inbox = lock(&self.inbox);
        inbox.frame = Some((frame, Instant::now()));
        inbox.cancel.cancel();
        self.wake.notify_all();
    }

    /// Whether to compute the auxiliary images (now, and for every view).
    pub fn want_aovs(&self, wanted: bool) {
        let mut inbox = lock(&self.inbox);
        if inbox.aovs_wanted != wanted {
            inbox.aovs_wanted = wanted;
            self.wake.notify_all();
            self.publish(|s| s.aovs_wanted = wanted);
        }
    }

    /// Stops the worker (after the job in hand is cancelled) and every event stream.
    pub fn quit(&self) {
        // Set before the inbox is locked and the worker woken, so that the worker (which
        // reads it under the inbox's lock) either sees it or is waiting for that wake.
        self.quit.store(true, Ordering::SeqCst);
        let inbox = lock(&self.inbox);
        inbox.cancel.cancel();
        self.wake.notify_all();
        drop(inbox);
        self.publish(|_| {});
    }

    /// Takes no lock: the event streams ask while holding the state's, and the worker takes
    /// the inbox's then the state's; reading the inbox here would invert that order.
    pub fn quitting(&self) -> bool {
        self.quit.load(Ordering::SeqCst)
    }

    /// Changes the state and tells the event streams.
    fn publish(&self, change: impl FnOnce(&mut State)) {
        let mut s = lock(&self.state);
        change(&mut s);
        s.version += 1;
        self.changed.notify_all();
    }

    /// A new beauty image (after a pass, or the finished render).
    fn publish_image(&self, image: Image, spp: f64) {
        self.publish_image_with(image, spp, |_| {});
    }

    /// A new beauty image and what goes with it, published together.
    fn publish_image_with(&self, image: Image, spp: f64, with: impl FnOnce(&mut State)) {
        let rmse = self
            .base
            .reference
            .as_ref()
            .filter(|r| (r.width, r.height) == (image.width, image.height))
            .map(|r| image.rmse(r) as f64);
        self.publish(|s| {
            s.image = Some(Arc::new(image));
            s.image_version += 1;
            s.image_view = s.view;
            s.spp = spp;
            s.rmse = rmse;
            s.elapsed = s.started.elapsed().as_secs_f64();
            with(s);
        });
    }

    fn control(&self, cancel: CancelToken) -> Control {
        Control {
            cancel,
            budget: self.base.budget,
            progress: self.progress.clone(),
        }
    }
}

/// What the worker was asked to do next.
struct Next {
    camera: Option<(Camera, Instant)>,
    relight: Option<(RelightRequest, Instant)>,
    frame: Option<(i64, Instant)>,
    aovs: bool,
    cancel: CancelToken,
}

/// The worker: renders the first view, then whatever the page asks for, until [`Session::quit`].
pub fn work(session: &Session, mut renderer: Renderer, mut frames: Option<Frames>) {
    let mut pending_first = true;
    let mut aovs_done_for = 0;
    loop {
        let next = {
            let mut inbox = lock(&session.inbox);
            loop {
                let view = lock(&session.state).view;
                let aovs_missing = inbox.aovs_wanted && aovs_done_for != view;
                if session.quitting() {
                    return;
                }
                if pending_first
                    || inbox.camera.is_some()
                    || inbox.relight.is_some()
                    || inbox.frame.is_some()
                    || aovs_missing
                {
                    break;
                }
                inbox = session.wake.wait(inbox).unwrap_or_else(|e| e.into_inner());
            }
            inbox.cancel = CancelToken::new();
            Next {
                camera: inbox.camera.take(),
                relight: inbox.relight.take(),
                frame: inbox.frame.take(),
                aovs: inbox.aovs_wanted,
                cancel: inbox.cancel.clone(),
            }
        };
        let control = session.control(next.cancel.clone());
        let fresh = pending_first
            || next.camera.is_some()
            || next.relight.is_some()
            || next.frame.is_some();
        pending_first = false;
        if fresh {
            // What is shown is no longer the finished image of what was asked for.
            session.publish(|s| s.status = Status::Preparing);
        }
        let asked = next
            .camera
            .as_ref()
            .map(|c| c.1)
            .or(next.frame.map(|f| f.1));
        if let Some((frame, _)) = next.frame {
            session.publish(|s| s.frame = Some(frame));
        }
        if let Some((camera, _)) = next.camera {
            // The page's commands are checked when they arrive; this cannot fail.
            if let Err(e) = renderer.set_camera(camera.clone()) {
                fail(session, &e);
                continue;
            }
            session.publish(|s| {
                s.camera = camera;
                s.view += 1;
            });
        }
        let relit = match next.relight {
            Some((request, at)) => match rebuild(session, &request, &control) {
                Ok(r) => {
                    renderer = r;
                    let ms = at.elapsed().as_secs_f64() * 1e3;
                    session.publish(|s| {
                        s.relight = request;
                        s.relight_prepare_ms = Some(ms);
                    });
                    Some(at)
                }
                Err(Error::Cancelled { .. }) => {
                    // Interrupted by a camera move: still to do, unless a newer one came.
                    let mut inbox = lock(&session.inbox);
                    inbox.relight.get_or_insert((request, at));
                    continue;
                }
                Err(e) => {
                    fail(session, &e);
                    continue;
                }
            },
            None => None,
        };
        let view = lock(&session.state).view;
        if next.aovs && aovs_done_for != view {
            match renderer.render_aovs(&control) {
                Ok(Some(images)) => {
                    aovs_done_for = view;
                    session.publish(|s| s.aovs = Some((view, Arc::new(images))));
                }
                Ok(None) | Err(Error::Cancelled { .. }) => continue,
                Err(e) => fail(session, &e),
            }
        }
        let frame = lock(&session.state).frame;
        match (&mut frames, frame) {
            (Some(frames), Some(frame)) if fresh => {
                render_frame(session, frames, frame, &control, asked)
            }
            _ if fresh => render(session, &mut renderer, &control, asked, relit),
            _ => {}
        }
    }
}

/// Renders frame `frame` of the keyframed scene through the current camera.
fn render_frame(
    session: &Session,
    frames: &mut Frames,
    frame: i64,
    control: &Control,
    asked: Option<Instant>,
) {
    let camera = {
        let mut s = lock(&session.state);
        s.status = Status::Rendering;
        s.started = Instant::now();
        s.camera.clone()
    };
    match frames.render(frame, &camera, control) {
        Ok(f) => {
            let spp = session.base.job.technique.passes().unwrap_or(1);
            session.publish_image_with(f.image, spp as f64, |s| {
                if let Some(t) = asked {
                    s.view_ms = Some(t.elapsed().as_secs_f64() * 1e3);
                }
                s.retrace_map = f.map.map(Arc::new);
                s.retraced = Some(f.retraced);
                s.status = Status::Done;
                s.rays = Some(f.rays);
                s.mrays = Some(f.rays as f64 / f.seconds.max(1e-9) / 1e6);
                s.elapsed = f.seconds;
            });
        }
        Err(Error::Cancelled { .. }) => {}
        Err(e) => fail(session, &e),
    }
}

/// A renderer for the relit scene: the lights' factors through the library's relight of the
/// network file, the materials' by the scene's diffuse colours.
fn rebuild(
    session: &Session,
    request: &RelightRequest,
    control: &Control,
) -> raylink::Result<Renderer> {
    let base = &session.base;
    let mut scene = (*base.scene).clone();
    scene.camera = lock(&session.state).camera.clone();
    for (name, k) in &request.materials {
        let original = base.scene.materials.iter().find(|m| &m.name == name);
        let target = scene.materials.iter_mut().find(|m| &m.name == name);
        if let (Some(o), Some(m)) = (original, target) {
            if let (Texture::Constant(c), Some(d)) = (&o.approximation().diffuse, m.diffuse_mut()) {
                *d = Texture::Constant(*c * *k);
            }
        }
    }
    let mut job = base.job.clone();
    match &mut job.technique {
        // The network relights its saved file (its light basis) once it has been saved.
        Technique::Network(n) if n.file.as_ref().is_some_and(|f| f.exists()) => {
            n.relight = Some(Relight {
                lights: request.lights.clone(),
                ..Relight::default()
            });
        }
        // Any other technique renders the scene with the lights changed.
        _ => {
            for (name, k) in &request.lights {
                if let Some(m) = scene.materials.iter_mut().find(|m| &m.name == name) {
                    m.emission *= *k;
                }
            }
        }
    }
    let mut renderer = Renderer::new(scene, job, control)?;
    renderer.prepare(control)?;
    Ok(renderer)
}

fn fail(session: &Session, e: &Error) {
    let text = raylink::error::one_line(&e.to_string());
    session.publish(|s| s.status = Status::Failed(text));
}

/// How often a progressive render's image is published in the middle of a pass, early in
/// the render: later passes take seconds, and a live view wants several images a second.
const MID_PASS_UPDATES: Duration = Duration::from_millis(90);

/// Later, the gap between images grows with the render's time (this share of it): each
/// image costs the render (the page fetches megabytes of floats on the same cores), and
/// a long render changes slowly.
const LATER_GAP: f64 = 1.0 / 20.0;

/// Renders the view: a progressive render publishes every pass and, between, its film
/// every [`MID_PASS_UPDATES`] early on ([`LATER_GAP`] later); the others publish their
/// image.
fn render(
    session: &Session,
    renderer: &mut Renderer,
    control: &Control,
    asked: Option<Instant>,
    relit: Option<Instant>,
) {
    session.publish(|s| {
        s.status = Status::Rendering;
        s.started = Instant::now();
        s.rays = None;
        s.mrays = None;
    });
    let first_image = |session: &Session| {
        let now = Instant::now();
        session.publish(|s| {
            if let Some(t) = asked {
                s.view_ms = Some((now - t).as_secs_f64() * 1e3);
            }
            if let Some(t) = relit {
                s.relight_ms = Some((now - t).as_secs_f64() * 1e3);
            }
        });
    };
    let mut first = true;
    let progressive = renderer.job().technique.passes().is_some();
    if !progressive {
        // One sample a pixel first: what a camera being dragged needs to follow it.
        match renderer.render_preview(control) {
            Ok(Some(r)) if !r.is_partial() => {
                session.publish_image(r.image, 0.0);
                first_image(session);
                first = false;
            }
            Ok(_) | Err(Error::Cancelled { .. }) => return,
            Err(e) => return fail(session, &e),
        }
    }
    // The samples per pixel of the image last published if it was a whole pass's: the
    // finished render's image is that film's, and is not published twice.
    let mut shown_whole: Option<u32> = None;
    let result = if progressive {
        let mut last = Instant::now();
        let mut show = |film: &Film, shown: Shown, stats: &RenderStats| {
            let gap = MID_PASS_UPDATES.max(Duration::from_secs_f64(stats.seconds * LATER_GAP));
            if shown == Shown::MidPass && last.elapsed() < gap {
                return Ok(());
            }
            last = Instant::now();
            shown_whole = (shown == Shown::AfterPass).then_some(film.spp);
            session.publish_image_with(film.image()?, film.mean_spp(), |s| {
                s.rays = Some(stats.rays.total());
                s.mrays = Some(stats.mrays_per_second());
            });
            if std::mem::take(&mut first) {
                first_image(session);
            }
            Ok(())
        };
        let watch = Watch {
            film: &mut show,
            mid_pass: Some(MID_PASS_UPDATES),
        };
        renderer.render_progressive(control, None, watch)
    } else {
        renderer.render(control)
    };
    match result {
        Ok(r) if r.is_partial() => {}
        Ok(r) => {
            let film_spp = r.film.as_ref().map(|f| f.spp);
            if film_spp.is_none() || film_spp != shown_whole {
                session.publish_image(r.image, film_spp.map_or(1.0, f64::from));
            }
            if first {
                first_image(session);
            }
            session.publish(|s| {
                s.status = Status::Done;
                s.rays = Some(r.stats.rays.total());
                s.mrays = Some(r.stats.mrays_per_second());
                s.elapsed = r.stats.seconds;
                s.notes = session.progress.notes();
            });
        }
        Err(Error::Cancelled { .. }) => {}
        Err(e) => fail(session, &e),
    }
}
