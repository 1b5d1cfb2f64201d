//! The set of every emitter of a scene for the Monte Carlo integrators (area lights, the
//! scene's lights, the background as an infinite light). Two kinds of sampling: towards a
//! point being shaded (`sample_li`, next-event estimation, with `pdf_li` for multiple
//! importance sampling), where a light hierarchy chooses by the light each emitter may send
//! to the point; and emission of a light path (`sample_le`), chosen in proportion to power.

use super::{
    AreaLight, Background, EmissionSample, Light, LightModel, LightSample, LightTree, World,
};
use crate::math::{Rgb, Vec2, Vec3};
use crate::scene::Scene;
use crate::spectrum::BlackbodyEmission;

/// One emitter: an emissive shape, a light the scene names, or the background.
#[derive(Clone, Debug)]
pub enum Emitter {
    Area(AreaLight),
    Scene(Light),
    Background(Background),
}

impl Emitter {
    /// The emitter's implementation of the light interface.
    pub fn model(&self) -> &dyn LightModel {
        match self {
            Emitter::Area(a) => a,
            Emitter::Scene(l) => l.model(),
            Emitter::Background(b) => b,
        }
    }
}

#[derive(Clone)]
pub struct LightSet {
    pub emitters: Vec<Emitter>,
    /// Probability of choosing each emitter, and their cumulative sums.
    pmf: Vec<f32>,
    cdf: Vec<f32>,
    /// For each scene shape, its emitter index if it is an area light.
    shape_light: Vec<Option<u32>>,
    /// Whether some emitter's light is a blackbody's (spectral renders then ask which).
    any_blackbody: bool,
    background: Option<usize>,
    /// A sphere bounding the scene: infinite and directional lights emit from its disk.
    pub world: World,
    /// How next-event estimation chooses a light at a point.
    selection: Selection,
}

/// How next-event estimation chooses among the lights.
#[derive(Clone, Debug)]
pub enum Selection {
    /// In proportion to power, wherever the point is.
    Power,
    /// By a light hierarchy, in proportion to what each light may send to the point.
    Tree(Box<LightTree>),
}

/// Which [`Selection`] a light set is made with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SelectionKind {
    Power,
    Tree,
}

impl LightSet {
    /// The lights of `scene`, next-event estimation choosing by a light hierarchy.
    pub fn new(scene: &Scene, area_lights: &[AreaLight]) -> LightSet {
        LightSet::with_selection(scene, area_lights, SelectionKind::Tree)
    }

    /// The lights of `scene`, next-event estimation choosing by `kind`.
    pub fn with_selection(
        scene: &Scene,
        area_lights: &[AreaLight],
        kind: SelectionKind,
    ) -> LightSet {
        let (center, radius) = bounding_sphere(scene);
        let world = World { center, radius };
        let mut emitters: Vec<Emitter> = area_lights.iter().cloned().map(Emitter::Area).collect();
        emitters.extend(scene.lights.iter().cloned().map(Emitter::Scene));
        let mut background = None;
        if let Some(env) = &scene.environment {
            background = Some(emitters.len());
            emitters.push(Emitter::Background(Background::of_environment(env.clone())));
        } else if scene.background.max_element() > 0.0 {
            background = Some(emitters.len());
            emitters.push(Emitter::Background(Background {
                radiance: scene.background,
                map: None,
            }));
        }
        let power: Vec<f32> = emitters
            .iter()
            .map(|e| e.model().power(&world).max(0.0))
            .collect();
        let total: f32 = power.iter().sum();
        let pmf: Vec<f32> = if total > 0.0 {
            power.iter().map(|p| p / total).collect()
        } else {
            vec![0.0; power.len()]
        };
        let mut acc = 0.0;
        let cdf = pmf
            .iter()
            .map(|p| {
                acc += p;
                acc
            })
            .collect();
        let mut shape_light = vec![None; scene.shapes.len()];
        for (i, e) in emitters.iter().enumerate() {
            if let Emitter::Area(a) = e {
                shape_light[a.shape] = Some(i as u32);
            }
        }
        let any_blackbody = emitters.iter().any(|e| e.model().spectrum().is_some());
        let selection = match kind {
            SelectionKind::Power => Selection::Power,
            SelectionKind::Tree => {
                let mut bounded = Vec::new();
                let mut infinite = Vec::new();
                for (i, e) in emitters.iter().enumerate() {
                    if pmf[i] <= 0.0 {
                        continue;
                    }
                    match e.model().bounds(&world) {
                        Some(b) if b.phi > 0.0 && b.phi.is_finite() => bounded.push((i, b)),
                        Some(_) => {}
                        None => infinite.push(i),
                    }
                }
                Selection::Tree(Box::new(LightTree::new(bounded, infinite, emitters.len())))
            }
        };
        LightSet {
            emitters,
            pmf,
            cdf,
            shape_light,
            any_blackbody,
            background,
            world,
            selection,
        }
    }

    /// Chooses a light for next-event estimation at `p`: its index and probability there.
    pub fn choose_at(&self, p: Vec3, u: f32) -> Option<(usize, f32)> {
        match &self.selection {
            Selection::Power => self.choose(u).map(|(i, _)| (i, self.pmf[i])),
            Selection::Tree(tree) => tree.choose(p, u),
        }
    }

    /// The probability with which [`LightSet::choose_at`] picks emitter `i` at `p`.
    pub fn pmf_at(&self, p: Vec3, i: usize) -> f32 {
        match &self.selection {
            Selection::Power => self.pmf[i],
            Selection::Tree(tree) => tree.pmf(p, i),
        }
    }

    pub fn is_empty(&self) -> bool {
        !self.cdf.last().is_some_and(|&c| c > 0.0)
    }

    /// Probability of choosing emitter `i`.
    pub fn pmf(&self, i: usize) -> f32 {
        self.pmf[i]
    }

    /// The emitter index of an emissive shape.
    pub fn light_of_shape(&self, shape: usize) -> Option<usize> {
        self.shape_light[shape].map(|i| i as usize)
    }

    /// Whether emitter `i` is infinitely far away (directional or background).
    pub fn is_infinite(&self, i: usize) -> bool {
        self.emitters[i].model().is_infinite()
    }

    /// The blackbody spectrum of emitter `i`'s light, if it has one (spectral renders).
    #[inline]
    pub fn spectrum(&self, i: usize) -> Option<BlackbodyEmission> {
        self.emitters[i].model().spectrum()
    }

    /// The blackbody spectrum of the emitter [`sample_li`](Self::sample_li) picks at `p`
    /// with `u_choose`, if it has one.
    pub fn spectrum_chosen_at(&self, p: Vec3, u_choose: f32) -> Option<BlackbodyEmission> {
        if !self.any_blackbody {
            return None;
        }
        self.choose_at(p, u_choose)
            .and_then(|(i, _)| self.spectrum(i))
    }

    pub fn background_light(&self) -> Option<usize> {
        self.background
    }

    /// Radiance of the background seen along a ray that leaves the scene in direction `dir`.
    pub fn background_radiance(&self, dir: Vec3) -> Rgb {
        match self.background.map(|i| &self.emitters[i]) {
            Some(Emitter::Background(b)) => b.radiance_towards(dir),
            _ => Rgb::ZERO,
        }
    }

    /// Chooses an emitter by power; returns it and the leftover of `u`, rescaled to [0,1).
    pub fn choose(&self, u: f32) -> Option<(usize, f32)> {
        if self.is_empty() {
            return None;
        }
        let total = *self.cdf.last().unwrap();
        let target = u * total;
        let i = self
            .cdf
            .partition_point(|&c| c <= target)
            .min(self.cdf.len() - 1);
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        let rest = ((target - lo) / self.pmf[i].max(f32::MIN_POSITIVE)).clamp(0.0, 0.999_999_9);
        (self.pmf[i] > 0.0).then_some((i, rest))
    }

    /// Samples light arriving at `p` (next-event estimation).
    pub fn sample_li(&self, p: Vec3, u_choose: f32, u: Vec2) -> Option<LightSample> {
        self.sample_li_facing(p, None, u_choose, u)
    }

    /// [`sample_li`](Self::sample_li) for a receiver at `p` that only reflects, into the
    /// hemisphere `facing` points to (`Bsdf::reflecting_side`): the background then weighs
    /// its directions by their cosine with it. `None`: any receiver.
    pub fn sample_li_facing(
        &self,
        p: Vec3,
        facing: Option<Vec3>,
        u_choose: f32,
        u: Vec2,
    ) -> Option<LightSample> {
        let (i, choice) = self.choose_at(p, u_choose)?;
        match (&self.emitters[i], facing) {
            (Emitter::Background(b), Some(_)) => {
                b.sample_li_facing(p, facing, u, choice, &self.world)
            }
            (e, _) => e.model().sample_li(p, u, choice, &self.world),
        }
    }

    /// Density (solid angle at `p`, with the choice of emitter) with which `sample_li` picks
    /// the point `q` with normal `n` on emitter `i` (for the background, the direction
    /// `q − p`).
    pub fn pdf_li(&self, i: usize, p: Vec3, q: Vec3, n: Vec3) -> f32 {
        self.emitters[i].model().pdf_li(p, q, n, self.pmf_at(p, i))
    }

    /// [`pdf_li`](Self::pdf_li) for the receiver of
    /// [`sample_li_facing`](Self::sample_li_facing).
    pub fn pdf_li_facing(&self, i: usize, p: Vec3, facing: Option<Vec3>, q: Vec3, n: Vec3) -> f32 {
        match (&self.emitters[i], facing) {
            (Emitter::Background(b), Some(_)) => b.pdf_li_facing(p, facing, q, self.pmf_at(p, i)),
            _ => self.pdf_li(i, p, q, n),
        }
    }

    /// Starts a light path.
    pub fn sample_le(&self, u_choose: f32, u_pos: Vec2, u_dir: Vec2) -> Option<EmissionSample> {
        let (i, _) = self.choose(u_choose)?;
        let s = self.emitters[i]
            .model()
            .sample_le(u_pos, u_dir, self.pmf[i], &self.world, i)?;
        (s.pdf_dir > 0.0).then_some(s)
    }
}

/// A sphere around every shape and the camera.
fn bounding_sphere(scene: &Scene) -> (Vec3, f32) {
    let eye = scene.camera.position;
    let (lo, hi) = scene
        .bounds()
        .map_or((eye, eye), |(lo, hi)| (lo.min(eye), hi.max(eye)));
    let center = 0.5 * (lo + hi);
    (center, (0.5 * (hi - lo).length()).max(1e-3))
}
