//! The illumination network in the technique lifecycle. Its preparation is view-independent:
//! the network is loaded from its file (no preprocess) or built and saved there, then the
//! light is distributed over it; a relight starts from the file's light basis or reflectance
//! series where it can (no distribution at all). Renders of any view then read it.

use super::distribute::{self, DistributeOptions, Solution};
use super::render::{NetworkRenderer, Tables};
use super::{file, relight, Network, NetworkParams};
use super::{DEFAULT_SLOPES, DEFAULT_STEP, DEFAULT_TOLERANCE};
use crate::control::Control;
use crate::error::{Error, Result};
use crate::math::{Ray, Rgb, Rng};
use crate::scene::Scene;
use crate::settings::{NetworkBuilder, Relight, Settings, TechniqueKind};
use crate::transport::settings::{Setting, TechniqueInfo, COMMON};
use crate::transport::technique::{Lifecycle, Tiles};
use crate::transport::View;
use crate::transport::{Context, Integrator, RayStats, Sample};
use crate::transport::{PixelSampling, PIXELS};
use std::path::{Path, PathBuf};

/// The illumination network, as the technique list shows it.
pub(crate) const TECHNIQUE: TechniqueInfo = TechniqueInfo {
    kind: TechniqueKind::Network,
    summary: "Buckalew & Fussell's illumination networks: a view-independent network of \
              patches and links, built once, lit by a distribution process.",
    settings: &[
        COMMON,
        PIXELS,
        &[
            Setting {
                name: "slopes",
                scene_key: Some(("render.network", "slopes")),
                example: "8",
                doc: "Slopes per axis S (3·S² links per patch; default 12).",
            },
            Setting {
                name: "intercept_step",
                scene_key: Some(("render.network", "intercept_step")),
                example: "0.03125",
                doc: "Intercept step h, as a fraction of the scene's largest extent (default 1/64).",
            },
            Setting {
                name: "patch_size",
                scene_key: Some(("render.network", "patch_size")),
                example: "0.03125",
                doc: "Patch edge, as a fraction of the scene's largest extent (default: the intercept step).",
            },
            Setting {
                name: "network_jitter",
                scene_key: Some(("render.network", "jitter")),
                example: "0.5",
                doc: "Intercept jitter, a fraction of the intercept step (0 to 1; default 1).",
            },
            Setting {
                name: "network_builder",
                scene_key: Some(("render.network", "builder")),
                example: "\"embree\"",
                doc: "How links are found: scan conversion (default) or closest-hit queries.",
            },
            Setting {
                name: "tolerance",
                scene_key: Some(("render.network", "tolerance")),
                example: "0.01",
                doc: "Stop distributing when the unshot flux is below this fraction of the emitted flux (default 0.001).",
            },
            Setting {
                name: "network_file",
                scene_key: Some(("render.network", "file")),
                example: "\"net.bin\"",
                doc: "Loaded from this file if it exists (no preprocess), else built and saved there.",
            },
            Setting {
                name: "light_scale",
                scene_key: None,
                example: "2.0",
                doc: "Multiply every emission by this factor (relighting a saved network; default 1).",
            },
            Setting {
                name: "network_order",
                scene_key: Some(("render.network", "order")),
                example: "\"sweeps\"",
                doc: "Order of the distribution: cg (default), sweeps or shoot.",
            },
            Setting {
                name: "network_hybrid",
                scene_key: Some(("render.network", "hybrid")),
                example: "true",
                doc: "Direct light per pixel; only indirect light from the network.",
            },
            Setting {
                name: "relight",
                scene_key: None,
                example: "true",
                doc: "What a relight changes in a saved network (the relight command's lights).",
            },
        ],
    ],
    pbrt: &[],
    progressive: false,
    renders_parts: true,
    follows_time: false,
    media: false,
};

/// The illumination network's settings.
#[derive(Clone, Debug, PartialEq)]
pub struct NetworkSettings {
    /// Slopes, intercept step, patch size and jitter (the seed is the job's).
    pub params: NetworkParams,
    pub builder: NetworkBuilder,
    pub distribute: DistributeOptions,
    /// Loaded from it if it exists (no preprocess), else built and saved there.
    pub file: Option<PathBuf>,
    /// Direct light per pixel, only indirect light from the network.
    pub hybrid: bool,
    pub sampling: PixelSampling,
    pub max_depth: u32,
    /// Relighting the network in `file` (which must exist).
    pub relight: Option<Relight>,
}

impl NetworkSettings {
    /// From the parameter set, with the defaults, every value checked.
    pub(crate) fn from_settings(s: &Settings, max_depth: u32) -> Result<NetworkSettings> {
        let step = s.intercept_step.unwrap_or(DEFAULT_STEP);
        let params = NetworkParams {
            slopes: s.slopes.unwrap_or(DEFAULT_SLOPES),
            step,
            patch_size: s.patch_size.unwrap_or(step),
            jitter: s.network_jitter.unwrap_or(1.0),
            seed: 0,
        };
        params.validate()?;
        let tolerance = s.tolerance.unwrap_or(DEFAULT_TOLERANCE);
        if !(tolerance > 0.0 && tolerance < 1.0) {
            return Err(Error::setting(
                "tolerance",
                format!("must be between 0 and 1 (exclusive), got {tolerance}"),
            ));
        }
        let light_scale = s.light_scale.unwrap_or(1.0);
        if !(light_scale.is_finite() && light_scale >= 0.0) {
            return Err(Error::setting(
                "light_scale",
                format!("must be a non-negative number, got {light_scale}"),
            ));
        }
        if s.relight.is_some() && s.network_file.is_none() {
            return Err(Error::setting(
                "network_file",
                "is needed to relight: a network saved by an earlier render",
            ));
        }
        Ok(NetworkSettings {
            params,
            builder: s.network_builder.unwrap_or(NetworkBuilder::Scan),
            distribute: DistributeOptions {
                tolerance,
                light_scale,
                order: s.network_order.unwrap_or_default(),
                ..Default::default()
            },
            file: s.network_file.clone(),
            hybrid: s.network_hybrid.unwrap_or(false),
            sampling: PixelSampling::from_settings(s)?,
            max_depth,
            relight: s.relight.clone(),
        })
    }

    /// What of them changes pixels, for a job's settings key.
    pub(crate) fn key(&self) -> String {
        let p = &self.params;
        format!(
            " {} slopes={} intercept_step={} patch_size={} jitter={} \
             builder={} tolerance={} light_scale={} order={} hybrid={}",
            self.sampling.key(),
            p.slopes,
            p.step,
            p.patch_size,
            p.jitter,
            self.builder.name(),
            self.distribute.tolerance,
            self.distribute.light_scale,
            self.distribute.order.name(),
            self.hybrid
        )
    }

    /// A part of the image reads a network precomputed for the whole scene.
    pub(crate) fn check_part(&self) -> Result<()> {
        match &self.file {
            Some(f) if f.exists() => Ok(()),
            Some(f) => Err(Error::input(
                f,
                "no such network: precompute it with the render's settings first \
                 (`raylink precompute`, `Renderer::precompute`)",
            )),
            None => Err(Error::setting(
                "network_file",
                "is needed to render a part of the image with the network integrator: \
                 precompute the network first (`raylink precompute`, \
                 `Renderer::precompute`)",
            )),
        }
    }
}

pub(crate) struct NetworkTechnique {
    settings: NetworkSettings,
    /// Each material's emission as the scene file gives it, before a relight's changes.
    file_emission: Vec<Rgb>,
    prepared: Option<Prepared>,
}

/// A distributed network, as a technique that gives radiance along camera rays.
struct Prepared {
    net: Network,
    solution: Solution,
    hybrid: bool,
    tables: Tables,
    /// Seconds taken to read the network from its file (and relight it), if it was read
    /// rather than built: its statistics' preprocess times are then the build's that saved it.
    loaded: Option<f64>,
}

impl Integrator for Prepared {
    fn radiance(&self, ctx: &Context, ray: &Ray, rng: &mut Rng, stats: &mut RayStats) -> Sample {
        NetworkRenderer {
            net: &self.net,
            solution: &self.solution,
            hybrid: self.hybrid,
            tables: Some(&self.tables),
        }
        .radiance(ctx, ray, rng, stats)
    }
}

/// The scene with a relight's light strengths applied (`None`: no relight of lights), and
/// what it checks of the relight's names.
pub(crate) fn relit_scene(scene: &Scene, settings: &NetworkSettings) -> Result<Option<Scene>> {
    let Some(relight) = &settings.relight else {
        return Ok(None);
    };
    for name in &relight.reflectance_series {
        if !scene.materials.iter().any(|m| &m.name == name) {
            return Err(Error::input(
                &scene.source,
                format!("reflectance series of {name}: no material named \"{name}\""),
            ));
        }
    }
    if relight.lights.is_empty() {
        return Ok(None);
    }
    let mut relit = scene.clone();
    for (name, k) in &relight.lights {
        let m = relit
            .materials
            .iter_mut()
            .find(|m| &m.name == name && m.emission.max_element() > 0.0)
            .ok_or_else(|| {
                Error::input(
                    &scene.source,
                    format!("light {name}: no emissive material named \"{name}\""),
                )
            })?;
        m.emission *= *k;
    }
    Ok(Some(relit))
}

impl NetworkTechnique {
    /// The technique for `scene` as its file gives it (before a relight's changes).
    pub(crate) fn new(settings: NetworkSettings, scene: &Scene) -> NetworkTechnique {
        NetworkTechnique {
            settings,
            file_emission: scene.materials.iter().map(|m| m.emission).collect(),
            prepared: None,
        }
    }

    fn params(&self, view: &View) -> NetworkParams {
        NetworkParams {
            seed: view.seed,
            ..self.settings.params
        }
    }

    /// The network itself, without light: loaded from the file if it exists (with the
    /// seconds that took), else built (and saved there).
    fn structure(
        &self,
        ctx: &Context,
        view: &View,
        control: &Control,
    ) -> Result<(Network, Option<f64>)> {
        let params = self.params(view);
        let scene = ctx.scene;
        match &self.settings.file {
            Some(f) if f.exists() => {
                let start = std::time::Instant::now();
                let n = file::load(f, scene, Some(&params))?;
                let seconds = start.elapsed().as_secs_f64();
                control.note(&format!(
                    "network: loaded {} in {seconds:.2} s (no preprocess): {} nodes",
                    f.display(),
                    n.nodes()
                ));
                Ok((n, Some(seconds)))
            }
            _ => {
                let builder = self.settings.builder;
                let phase = control.phase("preprocess", None, "");
                let n = Network::build_with(scene, ctx, params, builder, control)?;
                phase.end(&format!(
                    "{} nodes, {} links, {} intersections ({} builder)",
                    n.nodes(),
                    n.stats.link_ends / 2,
                    n.stats.intersections,
                    builder.name()
                ));
                if let Some(f) = &self.settings.file {
                    file::save(f, &n, scene, None)?;
                }
                Ok((n, None))
            }
        }
    }
}

impl Lifecycle for NetworkTechnique {
    fn prepares(&self) -> bool {
        true
    }

    fn prepare(&mut self, ctx: &Context, view: &View, control: &Control) -> Result<()> {
        let scene = ctx.scene;
        let options = &self.settings.distribute;
        if !scene.lights.is_empty() && !self.settings.hybrid {
            control.warn(
                "the network carries only emissive surfaces; the scene's point, spot and directional \
                 lights light it only in hybrid mode",
            );
        }
        warn_one_value_per_patch(scene, control);
        let (net, solution, loaded) = match (&self.settings.relight, &self.settings.file) {
            (Some(relight), Some(f)) => {
                let params = self.params(view);
                let from = (f.as_path(), &params, options);
                let start = std::time::Instant::now();
                let (net, solution) =
                    relight_network(from, relight, scene, &self.file_emission, control)?;
                (net, solution, Some(start.elapsed().as_secs_f64()))
            }
            _ => {
                let (net, loaded) = self.structure(ctx, view, control)?;
                let surfaces = distribute::surfaces(&net, scene, options.light_scale);
                check_bounded(&net, scene, &surfaces)?;
                let phase = control.phase("distribution", None, "sweeps");
                let shown = std::sync::Mutex::new(std::time::Instant::now());
                let report = |unshot: f64| {
                    phase.advance(1);
                    // A few updates a second: the shooting order asks once per node.
                    let mut last = shown.lock().unwrap_or_else(|e| e.into_inner());
                    if last.elapsed().as_millis() >= 100 {
                        *last = std::time::Instant::now();
                        phase.status(&format!("unshot {unshot:.2e} of emitted"));
                    }
                };
                let run = distribute::Run {
                    start: std::time::Instant::now(),
                    cancel: Some(&control.cancel),
                    report: Some(&report),
                };
                let solution = distribute::distribute_surfaces(&net, surfaces, options, run);
                control.cancel.check("the network's light distribution")?;
                let st = &solution.stats;
                phase.end(&format!(
                    "{} sweeps or shots, unshot {:.2e} of emitted",
                    st.sweeps,
                    st.unshot.iter().sum::<f64>() / st.emitted.iter().sum::<f64>().max(1e-300)
                ));
                (net, solution, loaded)
            }
        };
        let hybrid = self.settings.hybrid;
        self.prepared = Some(Prepared {
            tables: Tables::new(&net, &solution, hybrid),
            net,
            solution,
            hybrid,
            loaded,
        });
        Ok(())
    }

    fn tiles(&self) -> Tiles<'_> {
        Tiles::Pixels(
            self.prepared.as_ref().expect("the renderer prepares first"),
            self.settings.sampling,
        )
    }

    fn precompute(&mut self, ctx: &Context, view: &View, control: &Control) -> Result<()> {
        if self.settings.file.is_none() {
            return Err(Error::setting(
                "network_file",
                "is where a precomputed network goes: give one",
            ));
        }
        // The structure only: each render distributes the light itself.
        self.structure(ctx, view, control).map(drop)
    }

    fn report(&self) -> Vec<String> {
        let Some(p) = &self.prepared else {
            return Vec::new();
        };
        let (network, solution) = (&p.net, &p.solution);
        let st = &solution.stats;
        let bs = &network.stats;
        let links = bs.link_ends / 2;
        // A network read from its file reports its build's counts and speed, not this run's.
        let built = if p.loaded.is_some() {
            " when it was built"
        } else {
            ""
        };
        vec![
            format!(
                "network stats: {} polygons, {} patches, {} nodes, {} slots per node",
                network.patches.polygons.len(),
                network.patches.cells,
                network.nodes(),
                network.slots(),
            ),
            format!(
                "network stats: {} links ({:.1} per node), {} escapes, {} beyond a slot's \
                 first, {} line-patch intersections ({:.1} M/s{built}), {} closest-hit queries",
                links,
                bs.link_ends as f64 / network.nodes().max(1) as f64,
                bs.escapes,
                bs.extra,
                bs.intersections,
                bs.intersections as f64 / bs.seconds.max(1e-9) / 1e6,
                bs.rays,
            ),
            format!(
                "network stats: memory {:.1} MB network + {:.1} MB buffers, {} map entries",
                network.memory() as f64 / 1e6,
                (solution.memory() + p.tables.memory()) as f64 / 1e6,
                st.map_entries,
            ),
            format!(
                "network stats: {}, distribution {:.3} s, {} sweeps, unshot {:.2e} of emitted",
                match p.loaded {
                    None => format!(
                        "preprocess {:.3} s (lines {:.3} s, assembly {:.3} s)",
                        bs.seconds, bs.link_seconds, bs.assemble_seconds
                    ),
                    Some(s) => format!(
                        "read from its file in {s:.3} s (no preprocess; the build that saved \
                         it took {:.3} s)",
                        bs.seconds
                    ),
                },
                st.seconds,
                st.sweeps,
                st.unshot.iter().sum::<f64>() / st.emitted.iter().sum::<f64>().max(1e-300),
            ),
        ]
    }
}

/// An error naming the scene file and the material when light in some channel can never be
/// absorbed or leave the scene ([`distribute::lossless_channel`]): its radiance has no
/// finite value.
fn check_bounded(network: &Network, scene: &Scene, surfaces: &[distribute::Surface]) -> Result<()> {
    match distribute::lossless_channel(network, surfaces) {
        None => Ok(()),
        Some((c, node)) => {
            let material = &scene.materials[network.node_material(node, scene).0].name;
            Err(Error::input(
                &scene.source,
                format!(
                    "no {} light emitted by material '{material}' can leave: every surface it \
                     reaches reflects or transmits all of it (diffuse + specular + \
                     transmission = 1) and no line leads out of the scene, so its radiance \
                     grows without bound; lower one of them below 1",
                    ["red", "green", "blue"][c]
                ),
            ))
        }
    }
}

/// A relight's network and solution: from the file's light basis when it holds one for
/// these reflectances (reading only the file's prefix: no link table, no distribution), else
/// the whole network and a distribution (storing a basis when the file has none or
/// `store_basis` asks).
fn relight_network(
    (file, params, options): (&Path, &NetworkParams, &DistributeOptions),
    spec: &Relight,
    scene: &Scene,
    file_emission: &[Rgb],
    control: &Control,
) -> Result<(Network, Solution)> {
    let store_basis = spec.store_basis || !spec.reflectance_series.is_empty();
    let emission: Vec<_> = scene.materials.iter().map(|m| m.emission).collect();
    let start = std::time::Instant::now();
    let (prefix, basis) = file::load_prefix(file, scene, Some(params))?;
    if let Some(b) = basis.as_ref().filter(|_| !store_basis) {
        match b.superpose(&prefix, scene, &emission, options) {
            Ok(solution) => {
                control.note(&format!(
                    "network: relit from the light basis in {} ({} emissive materials) in \
                     {:.3} s: no preprocess, no distribution (0 sweeps), link table not read",
                    file.display(),
                    b.lights.len(),
                    start.elapsed().as_secs_f64()
                ));
                return Ok((prefix, solution));
            }
            // No series stored: nothing more to try before distributing.
            Err(why) if b.series.is_empty() => {
                control.note(&format!("network: {why}; distributing again"))
            }
            Err(why) => match b.relit_from_series(&prefix, scene, &emission, options) {
                Ok((solution, series)) => {
                    control.note(&format!(
                        "network: relit from the reflectance series of '{}' in {} ({} terms) \
                         in {:.3} s: no preprocess, no distribution (0 sweeps), link table not \
                         read",
                        series.name,
                        file.display(),
                        series.terms.len(),
                        start.elapsed().as_secs_f64()
                    ));
                    return Ok((prefix, solution));
                }
                Err(series) => {
                    control.note(&format!("network: {why}, and {series}; distributing again"))
                }
            },
        }
    }
    drop(prefix);
    let start = std::time::Instant::now();
    let (network, _) = file::load_all(file, scene, Some(params))?;
    control.note(&format!(
        "network: loaded {} in {:.2} s (no preprocess): {} nodes",
        file.display(),
        start.elapsed().as_secs_f64(),
        network.nodes()
    ));
    // A distribution follows: of the lights as they are now, or (a new basis) of the file's.
    let lit: Vec<_> = (emission.iter().zip(file_emission))
        .map(|(&e, &f)| (e * options.light_scale).max(f))
        .collect();
    check_bounded(
        &network,
        scene,
        &distribute::surfaces_with(&network, scene, &lit),
    )?;
    // Stopped between sweeps by a signal; then nothing is stored.
    let run = distribute::Run {
        start: std::time::Instant::now(),
        cancel: Some(&control.cancel),
        report: None,
    };
    let solution = match basis.as_ref().filter(|_| !store_basis) {
        None => {
            let mut b = relight::LightBasis::compute(&network, scene, file_emission, options, run);
            control.cancel.check("the network's light basis")?;
            for name in &spec.reflectance_series {
                b.add_series(&network, scene, (options, run), name)
                    .map_err(|e| Error::input(&scene.source, format!("reflectance series: {e}")))?;
                control.cancel.check("the network's reflectance series")?;
                let s = b.series.last().expect("a series was added");
                control.note(&format!(
                    "network: reflectance series of '{name}': {} terms ({} sweeps)",
                    s.terms.len(),
                    s.sweeps
                ));
            }
            file::save(file, &network, scene, Some(&b))?;
            control.note(&format!(
                "network: distribution of a light basis in {:.2} s ({} emissive materials, {} \
                 sweeps in all), stored in {}",
                b.seconds,
                b.lights.len(),
                b.lights.iter().map(|l| l.sweeps).sum::<u32>(),
                file.display()
            ));
            b.superpose(&network, scene, &emission, options)
                .map_err(|e| Error::input(file, e))?
        }
        // The stored basis, for the old reflectances, is where the distribution starts.
        Some(b) => {
            let solution = b.redistribute(&network, scene, &emission, options, run);
            control.cancel.check("the network's light distribution")?;
            control.note(&format!(
                "network: distribution in {:.2} s ({} sweeps or shots{})",
                solution.stats.seconds,
                solution.stats.sweeps,
                if solution.stats.warm_start {
                    ", starting from the stored light basis"
                } else {
                    ""
                }
            ));
            solution
        }
    };
    Ok((network, solution))
}

/// Warns of what the network cannot vary over a patch: a textured emission, specular
/// colour or mix amount, and an emitter's cut-out.
fn warn_one_value_per_patch(scene: &Scene, control: &Control) {
    if let Some(m) = scene.materials.iter().find(|m| {
        m.emission_map.is_some()
            || m.approximation().specular_map.is_some()
            || m.approximation().reflectance_map.is_some()
            || m.mix().is_some_and(|x| x.amount_map.is_some())
    }) {
        control.warn(&format!(
            "material \"{}\" varies by texture: the network takes one value per patch (an \
             emission's or a mix amount's mean, a specular colour's largest value)",
            m.name
        ));
    }
    let cut_out_emitter = scene
        .shapes
        .iter()
        .any(|s| s.alpha.is_some() && scene.materials[s.material].is_emissive());
    if cut_out_emitter {
        control.warn("an emitter has an alpha cut-out: the network lets all of it emit");
    }
}
