//! Stochastic progressive photon mapping (Hachisuka & Jensen 2009), as pbrt-v4's
//! `SPPMIntegrator` renders it. Each iteration traces one camera path per pixel to its
//! first diffuse surface (a visible point; emission and direct light are gathered on the
//! way: `visible`), builds a hash grid over the visible points and their radii (`grid`),
//! and shoots photons from the lights that add their power to the visible points whose
//! radius holds the surfaces they reach after their first bounce (`photons`). Each pixel
//! then keeps its photon count N, radius r and flux τ, with the radius shrinking as photons
//! arrive (α = 2/3): the estimate is biased, and consistent: the bias goes to zero as the
//! iterations go on. The pixel's radiance after k iterations of P photons is
//! Ld / k + τ / (k · P · π r²).
//!
//! In a scene with participating media both passes take the volumetric walks of `media`:
//! camera paths may leave their visible point in a medium, where it gathers the photons
//! scattering within a ball. A pixel keeps separate statistics for its visible points on
//! surfaces and in media; in media the ball's volume shrinks as the disk's area does, so the
//! radius by the cube root, and the pixel adds τ / (k · P · 4/3 π r³). Photons leave only
//! the lights; the light media emit is traced as one more path a pixel from the camera,
//! gathering only that emission (radiance is linear in the emitters: the two parts add).
//!
//! The pixels' statistics live in the render's film between iterations (`WholeImage`): a
//! viewer sees the image after each iteration, and a checkpoint saves them, so that a
//! resumed render ends as the uninterrupted one.
//!
//! The render is a function of (scene, settings, seed): camera paths draw from the stream of
//! (seed, pixel, iteration), photons from that of (seed, iteration, photon), and the
//! photons' deposits are summed in a fixed order (see `photons`).

mod grid;
mod media;
mod photons;
mod visible;

pub use grid::HashGrid;

use crate::control::CancelToken;
use crate::error::{Error, Result};
use crate::image::filter::{Filter, Reconstruction};
use crate::scene::Scene;
use crate::settings::{Settings, TechniqueKind, MAX_SPP};
use crate::transport::camera_sample::PixelJitter;
use crate::transport::settings::{Setting, TechniqueInfo, COMMON, FILTER};
use crate::transport::technique::{Lifecycle, Tiles, WholeImage, WholePass};
use crate::transport::{Context, View};
use media::Targets;
use photons::PhotonPass;
use visible::CameraPass;

/// The settings of stochastic progressive photon mapping besides the common ones.
pub const SPPM: &[Setting] = &[
    Setting {
        name: "photons_per_iteration",
        scene_key: Some(("render.sppm", "photons_per_iteration")),
        example: "100000",
        doc: "SPPM: photons shot per iteration (pbrt-v4's photonsperiteration; default: the \
              image's pixel count).",
    },
    Setting {
        name: "sppm_radius",
        scene_key: Some(("render.sppm", "radius")),
        example: "0.05",
        doc: "SPPM: initial photon search radius in scene units (pbrt-v4's radius; default: \
              1/200 of the scene's bounding-box diagonal).",
    },
];

/// Stochastic progressive photon mapping, as the technique list shows it.
pub(crate) const TECHNIQUE: TechniqueInfo = TechniqueInfo {
    kind: TechniqueKind::Sppm,
    summary: "Stochastic progressive photon mapping: caustics seen directly or through \
              mirrors and glass (iterations = spp).",
    settings: &[COMMON, &[FILTER], SPPM],
    pbrt: &["sppm"],
    progressive: true,
    renders_parts: false,
    follows_time: false,
    media: true,
};

/// The most photons one iteration shoots.
pub const MAX_PHOTONS_PER_ITERATION: u32 = 1 << 30;

/// The initial radius where none is given: this fraction of the scene's bounding-box
/// diagonal (pbrt-v4's default is 1 scene unit, which depends on the scene's scale).
pub const DEFAULT_RADIUS_FRACTION: f32 = 1.0 / 200.0;

/// The radius exponent α of Hachisuka & Jensen's update: the fraction of new photons kept.
const ALPHA: f32 = 2.0 / 3.0;

/// Bytes per pixel an iteration holds besides the film: the pixel's state while it is
/// updated, its camera path and its visible point.
const PASS_BYTES_PER_PIXEL: u64 = std::mem::size_of::<PixelState>() as u64 + 256;

/// SPPM's settings, checked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SppmSettings {
    pub max_depth: u32,
    /// Iterations (the spp setting, as pbrt-v4 takes its sampler's pixel samples).
    pub iterations: u32,
    /// Photons per iteration; `None`: the image's pixel count.
    pub photons_per_iteration: Option<u32>,
    /// Initial search radius; `None`: 1/200 of the scene's bounding-box diagonal.
    pub radius: Option<f32>,
    /// The pixel filter camera samples are drawn from.
    pub filter: Filter,
}

impl SppmSettings {
    /// From the parameter set, with the defaults, every value checked.
    pub(crate) fn from_settings(s: &Settings, max_depth: u32) -> Result<SppmSettings> {
        let iterations = s.spp.unwrap_or(16);
        if iterations == 0 || iterations > MAX_SPP {
            return Err(Error::setting(
                "spp",
                format!("must be between 1 and {MAX_SPP} (SPPM's iterations), got {iterations}"),
            ));
        }
        check_photon_settings(s)?;
        let filter = s.filter.unwrap_or_default();
        filter
            .validate()
            .map_err(|e| Error::setting("filter", format!("is invalid: {e}")))?;
        Ok(SppmSettings {
            max_depth,
            iterations,
            photons_per_iteration: s.photons_per_iteration,
            radius: s.sppm_radius,
            filter,
        })
    }

    /// What of them changes pixels, for a job's settings key.
    pub(crate) fn key(&self) -> String {
        let opt = |v: Option<String>| v.unwrap_or_else(|| "default".into());
        format!(
            " spp={} photons_per_iteration={} sppm_radius={} filter={}",
            self.iterations,
            opt(self.photons_per_iteration.map(|p| p.to_string())),
            opt(self.radius.map(|r| r.to_string())),
            self.filter
        )
    }

    /// The technique for `scene`, ready to render.
    pub(crate) fn lifecycle(&self, _scene: &Scene) -> Result<Box<dyn Lifecycle>> {
        Ok(Box::new(Sppm { settings: *self }))
    }
}

/// Checks the photon settings SPPM and VCM share: photons (light subpaths) per iteration
/// and the initial radius.
pub(crate) fn check_photon_settings(s: &Settings) -> Result<()> {
    if let Some(p) = s.photons_per_iteration {
        if p == 0 || p > MAX_PHOTONS_PER_ITERATION {
            return Err(Error::setting(
                "photons_per_iteration",
                format!("must be between 1 and {MAX_PHOTONS_PER_ITERATION}, got {p}"),
            ));
        }
    }
    if let Some(r) = s.sppm_radius {
        if !(r.is_finite() && r > 0.0) {
            return Err(Error::setting(
                "sppm_radius",
                format!("must be a positive number, got {r}"),
            ));
        }
    }
    Ok(())
}

/// The initial radius in `scene` where none is given.
pub fn default_radius(scene: &Scene) -> f32 {
    match scene.bounds() {
        Some((lo, hi)) if (hi - lo).length() > 0.0 && (hi - lo).is_finite() => {
            (hi - lo).length() * DEFAULT_RADIUS_FRACTION
        }
        _ => 1.0,
    }
}

/// What a pixel keeps from iteration to iteration.
#[derive(Clone, Copy, Debug)]
struct PixelState {
    /// Σ over iterations of the emission and direct light its camera paths gathered.
    ld: [f64; 3],
    /// The photons gathered at its visible points on surfaces (a disk of radius r).
    surface: Gathered,
    /// The photons gathered at its visible points in media (a ball of radius r).
    medium: Gathered,
}

/// Values a pixel's state takes in the film: Ld, then τ, N and r on surfaces and in media.
pub(crate) const STATE_LEN: usize = 13;

impl PixelState {
    fn load(v: &[f64]) -> PixelState {
        let gathered = |g: &[f64]| Gathered {
            tau: [g[0], g[1], g[2]],
            // Stored from f32s: exact.
            n: g[3] as f32,
            r: g[4] as f32,
        };
        PixelState {
            ld: [v[0], v[1], v[2]],
            surface: gathered(&v[3..8]),
            medium: gathered(&v[8..13]),
        }
    }

    fn store(&self, v: &mut [f64]) {
        v[..3].copy_from_slice(&self.ld);
        let (surface, medium) = v[3..STATE_LEN].split_at_mut(5);
        for (g, out) in [(&self.surface, surface), (&self.medium, medium)] {
            out[..3].copy_from_slice(&g.tau);
            out[3] = g.n as f64;
            out[4] = g.r as f64;
        }
    }
}

/// A pixel's photon statistics for one kind of visible point.
#[derive(Clone, Copy, Debug)]
struct Gathered {
    /// Flux τ gathered within the current radius.
    tau: [f64; 3],
    /// Photon count N.
    n: f32,
    /// Search radius r.
    r: f32,
}

impl Gathered {
    /// Takes an iteration's `m` photons of flux `phi` in a density estimate of dimension
    /// `dim` (2: a disk, 3: a ball): the radius shrinks so that the disk's area or the
    /// ball's volume falls by (N + αM)/(N + M), and τ with it.
    fn take(&mut self, m: u32, phi: &[f64; 3], dim: i32) {
        if m == 0 {
            return;
        }
        let m = m as f32;
        let n_new = self.n + ALPHA * m;
        let ratio = n_new / (self.n + m);
        let r_new = if dim == 2 {
            self.r * ratio.sqrt()
        } else {
            self.r * ratio.cbrt()
        };
        let shrink = (r_new as f64 / self.r as f64).powi(dim);
        for (tau, phi) in self.tau.iter_mut().zip(phi) {
            *tau = (*tau + phi) * shrink;
        }
        self.n = n_new;
        self.r = r_new;
    }
}

struct Sppm {
    settings: SppmSettings,
}

impl Lifecycle for Sppm {
    fn tiles(&self) -> Tiles<'_> {
        Tiles::Whole(self)
    }

    fn memory(&self, width: u32, height: u32) -> Option<(String, u64)> {
        Some((
            format!("SPPM's camera paths and visible points for a {width}x{height} image"),
            width as u64 * height as u64 * PASS_BYTES_PER_PIXEL,
        ))
    }
}

impl Sppm {
    /// Photons an iteration of a `pixels`-pixel image shoots.
    fn photons(&self, pixels: u64) -> u64 {
        self.settings
            .photons_per_iteration
            .map_or(pixels, u64::from)
    }
}

impl WholeImage for Sppm {
    fn state_len(&self) -> usize {
        STATE_LEN
    }

    fn start(&self, ctx: &Context, _view: &View, state: &mut [f64]) {
        let r0 = self
            .settings
            .radius
            .unwrap_or_else(|| default_radius(ctx.scene));
        let fresh = Gathered {
            tau: [0.0; 3],
            n: 0.0,
            r: r0,
        };
        let pixel = PixelState {
            ld: [0.0; 3],
            surface: fresh,
            medium: fresh,
        };
        for v in state.chunks_exact_mut(STATE_LEN) {
            pixel.store(v);
        }
    }

    fn pass(
        &self,
        ctx: &Context,
        view: &View,
        iteration: u32,
        saved: &mut [f64],
        cancel: &CancelToken,
    ) -> Option<WholePass> {
        let s = &self.settings;
        let (width, height) = (view.width, view.height);
        let mut camera = ctx.scene.camera.clone();
        camera.width = width;
        camera.height = height;
        let camera = camera.basis();
        let jitter = PixelJitter::new(s.filter, Reconstruction::Importance);
        let camera_pass = CameraPass {
            camera: &camera,
            jitter: &jitter,
            seed: view.seed,
            max_depth: s.max_depth,
            size: (width, height),
            media_glow: ctx.scene.media.iter().any(|m| m.model().emits()),
        };
        let mut state: Vec<PixelState> = saved
            .chunks_exact(STATE_LEN)
            .map(PixelState::load)
            .collect();
        let (paths, camera_rays) = camera_pass.run(ctx, iteration, cancel)?;
        let mut owners = Vec::new();
        let mut points = Vec::new();
        let mut balls = Vec::new();
        let mut medium_owners = Vec::new();
        let mut medium_points = Vec::new();
        let mut spheres = Vec::new();
        for (k, path) in paths.iter().enumerate() {
            if let Some(v) = path.visible {
                owners.push(k);
                points.push(v);
                balls.push((v.p, state[k].surface.r));
            }
            if let Some(v) = path.in_medium {
                medium_owners.push(k);
                medium_points.push(v);
                spheres.push((v.p, state[k].medium.r));
            }
        }
        let grid = HashGrid::build(&balls);
        let medium_grid = HashGrid::build(&spheres);
        let pass = PhotonPass {
            targets: Targets {
                surface_grid: &grid,
                surface: &points,
                medium_grid: &medium_grid,
                medium: &medium_points,
            },
            seed: view.seed,
            max_depth: s.max_depth,
        };
        let photons = self.photons(width as u64 * height as u64);
        let arrivals = pass.run(ctx, iteration, photons, cancel)?;
        // The iteration is whole: the pixels take it.
        let mut rays = camera_rays;
        rays.add(&arrivals.rays);
        for (st, path) in state.iter_mut().zip(&paths) {
            for c in 0..3 {
                st.ld[c] += path.ld[c] as f64;
            }
        }
        for (j, &k) in owners.iter().enumerate() {
            state[k].surface.take(arrivals.m[j], &arrivals.phi[j], 2);
        }
        let first = owners.len();
        for (j, &k) in medium_owners.iter().enumerate() {
            let j = first + j;
            state[k].medium.take(arrivals.m[j], &arrivals.phi[j], 3);
        }
        for (st, v) in state.iter().zip(saved.chunks_exact_mut(STATE_LEN)) {
            st.store(v);
        }
        Some(WholePass {
            rays,
            samples: paths.len() as u64,
        })
    }

    fn value(&self, view: &View, pixel: &[f64]) -> [f64; 3] {
        // Ld / k + τ / (k · P · π r²) (+ τ / (k · P · 4/3 π r³) in media), times k.
        let st = PixelState::load(pixel);
        let photons = self.photons(view.width as u64 * view.height as u64) as f64;
        let area = std::f64::consts::PI * (st.surface.r as f64).powi(2);
        let volume = 4.0 / 3.0 * std::f64::consts::PI * (st.medium.r as f64).powi(3);
        std::array::from_fn(|c| {
            let l = st.ld[c] + st.surface.tau[c] / (photons * area);
            if st.medium.n > 0.0 {
                l + st.medium.tau[c] / (photons * volume)
            } else {
                l
            }
        })
    }

    fn unit(&self, view: &View) -> String {
        let photons = self.photons(view.width as u64 * view.height as u64);
        format!("iterations of {photons} photons")
    }
}
