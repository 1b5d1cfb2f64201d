//! `raylink render`, `relight` and `precompute`: a job from the options and the scene,
//! rendered by the library, written to the outputs; checkpoints, intermediate writes and the
//! partial image of an interrupted render.

use crate::farm;
use crate::options::{self, IntegratorName, RenderArgs};
use crate::{Cli, Failure};
use raylink::image::display::DisplayServer;
use raylink::image::output::{check_output_path, color_space_named, write_image_layers, Layer};
use raylink::output_paths::FilePlan;
use raylink::spectrum::ColorSpace;
use raylink::{checkpoint, input_file};
use raylink::{
    write_image, Aov, Control, Error, Job, MetaValue, Metadata, OutputOptions, Relight, Rendered,
    Renderer, Scene, Settings, Technique, TechniqueKind,
};
use std::path::PathBuf;
use std::sync::Arc;

/// Options of `raylink relight`.
#[derive(clap::Args)]
pub struct RelightArgs {
    #[command(flatten)]
    pub render: RenderArgs,
    /// Multiply the emission of the scene's material NAME by K, or by R,G,B channel by
    /// channel (a colour; repeatable).
    #[arg(long = "light", value_name = "NAME=K")]
    lights: Vec<String>,
    /// Recompute the light basis (one distribution per emissive material) for the scene's
    /// reflectances and store it in the network file, replacing one made for other
    /// reflectances and its reflectance series (a file without a basis gets one on its first
    /// relight anyway).
    #[arg(long)]
    store_basis: bool,
    /// With the light basis, store a reflectance series for the diffuse material NAME
    /// (repeatable): a later relight that gives that material another single colour, the
    /// rest of the scene unchanged, is then a weighted sum of the series' terms, with no
    /// distribution and without reading the link table. Implies --store-basis; costs about
    /// a dozen distributions per material; needs a network of diffuse surfaces.
    #[arg(long = "reflectance-series", value_name = "NAME")]
    reflectance_series: Vec<String>,
}

/// The output options, checked against the outputs they would change.
fn output_options(args: &RenderArgs) -> Result<OutputOptions, Error> {
    let ext = |p: &PathBuf| {
        p.extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .unwrap_or_default()
    };
    let mut seen = std::collections::HashSet::new();
    for out in &args.outputs {
        if !seen.insert(out) {
            return Err(Error::Invalid(format!(
                "{}: the same output is given twice",
                out.display()
            )));
        }
    }
    if args.half && !args.outputs.iter().any(|o| ext(o) == "exr") {
        return Err(Error::Invalid(
            "--half applies to EXR outputs, and none is given".into(),
        ));
    }
    if args.exposure.is_some()
        && !args
            .outputs
            .iter()
            .any(|o| matches!(ext(o).as_str(), "png" | "jpg" | "jpeg"))
    {
        return Err(Error::Invalid(
            "--exposure applies to 8-bit outputs (PNG, JPEG), and none is given".into(),
        ));
    }
    let color_space = match &args.color_space {
        None => ColorSpace::srgb(),
        Some(name) => {
            let space = color_space_named(name)
                .map_err(|why| Error::Invalid(format!("--color-space: {why}")))?;
            if space != ColorSpace::srgb()
                && !args
                    .outputs
                    .iter()
                    .any(|o| matches!(ext(o).as_str(), "exr" | "hdr" | "tif" | "tiff"))
            {
                return Err(Error::Invalid(
                    "--color-space applies to linear outputs (EXR, HDR, TIFF), and none is \
                     given"
                        .into(),
                ));
            }
            space
        }
    };
    Ok(OutputOptions {
        exposure: args.exposure.unwrap_or(0.0),
        half: args.half,
        color_space,
    })
}

/// The cache or network file a technique reads if it is there and writes otherwise (or
/// rewrites, relighting), in the run's plan of files.
pub fn technique_files(plan: &mut FilePlan, args: &RenderArgs) {
    if let Some(f) = &args.cache_file {
        plan.read_write("--cache-file", f);
    }
    if let Some(f) = &args.network.network_file {
        plan.read_write("--network-file", f);
    }
}

/// True for an OpenEXR output (`.exr`, any case), the one format that holds layers.
fn is_exr(path: &std::path::Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
}

/// The auxiliary images' files beside the first output.
fn aov_paths(first: &std::path::Path) -> Vec<PathBuf> {
    let stem = first.file_stem().unwrap_or_default().to_string_lossy();
    Aov::ALL
        .iter()
        .map(|aov| first.with_file_name(format!("{stem}.{}.exr", aov.name())))
        .collect()
}

/// Loads the scene and prints what its reader replaced.
pub fn load_scene(path: &std::path::Path, control: &Control) -> Result<Scene, Error> {
    load_scene_and_animation(path, control).map(|(scene, _)| scene)
}

/// [`load_scene`], and the keyframes of a native TOML scene that has them, from one reading.
pub fn load_scene_and_animation(
    path: &std::path::Path,
    control: &Control,
) -> Result<(Scene, Option<raylink::scene::animation::Animation>), Error> {
    let (scene, animation) = Scene::load_with_animation(path, control)?;
    for w in &scene.warnings {
        if crate::log::enabled(crate::log::Level::Warn) {
            eprintln!("warning: {w}");
        }
    }
    Ok((scene, animation))
}

/// What every render records in its images.
fn metadata(args: &RenderArgs, job: &Job) -> Metadata {
    let t = &job.technique;
    let mut m: Metadata = vec![
        (
            "Software".into(),
            MetaValue::Str(format!("raylink {}", raylink::VERSION)),
        ),
        (
            "raylink:scene".into(),
            MetaValue::Str(args.scene.display().to_string()),
        ),
        (
            "raylink:integrator".into(),
            MetaValue::Str(t.kind().to_string()),
        ),
        ("raylink:seed".into(), MetaValue::Str(job.seed.to_string())),
        (
            "raylink:max_depth".into(),
            MetaValue::Int(t.max_depth() as i32),
        ),
    ];
    match t {
        Technique::Whitted(w) => m.push((
            "raylink:sampling".into(),
            MetaValue::Str(w.sampling.to_string()),
        )),
        Technique::Network(n) => m.push((
            "raylink:sampling".into(),
            MetaValue::Str(n.sampling.to_string()),
        )),
        _ => {}
    }
    if let Some(mc) = t.monte_carlo() {
        m.push((
            "raylink:filter".into(),
            MetaValue::Str(mc.filter.to_string()),
        ));
        if let Some(a) = mc.adaptive {
            m.push((
                "raylink:adaptive_threshold".into(),
                MetaValue::Float(a.threshold),
            ));
            m.push((
                "raylink:adaptive_min_samples".into(),
                MetaValue::Int(a.min_samples as i32),
            ));
        }
        if mc.guiding {
            m.push(("raylink:guiding".into(), MetaValue::Str("true".into())));
        }
        if mc.spectral {
            m.push((
                "raylink:spectral".into(),
                MetaValue::Str("true (three sampled wavelengths, output linear sRGB)".into()),
            ));
        }
        if let Some(v) = mc.max_component_value {
            m.push((
                "raylink:max_component_value".into(),
                MetaValue::Str(format!("{v} (samples clamped: the image is biased)")),
            ));
        }
    }
    m
}

/// `raylink render`, and `relight` with its settings in `extra`.
pub fn run_render(cli: &Cli, mut args: RenderArgs, extra: Settings) -> Result<(), Failure> {
    let control = cli.control(args.quiet, args.max_memory.as_deref())?;
    options::check(&args)?;
    // Without -o, the output the scene names: the scene is read first to find it.
    let mut early_scene = None;
    let mut output_label = "-o";
    if args.outputs.is_empty() {
        let pbrt = args
            .scene
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("pbrt"));
        let scene = load_scene(&args.scene, &control)?;
        let Some(output) = scene.output.clone() else {
            return Err(Error::Invalid(format!(
                "-o FILE is needed: {} names no output ({})",
                args.scene.display(),
                if pbrt {
                    "pbrt's Film \"filename\""
                } else {
                    "[render] output"
                }
            ))
            .into());
        };
        args.outputs.push(output);
        output_label = if pbrt {
            "Film \"filename\""
        } else {
            "[render] output"
        };
        early_scene = Some(scene);
    }
    farm::resolve_outputs(&mut args)?;
    for out in &args.outputs {
        // A bad output path is a bad option: report it before any work is done.
        check_output_path(out).map_err(|e| {
            if early_scene.is_some() {
                Error::Invalid(format!("{}: {output_label}: {e}", args.scene.display()))
            } else {
                Error::Invalid(e.to_string())
            }
        })?;
    }
    let mut out_options = output_options(&args)?;
    let scene = match early_scene {
        Some(scene) => scene,
        None => load_scene(&args.scene, &control)?,
    };
    // The scene's colour space (pbrt's `ColorSpace`, `[render] color_space`) unless the
    // command line names one.
    if let (None, Some(space)) = (&args.color_space, scene.color_space) {
        out_options.color_space = space;
    }
    // A relight may read only a network file's prefix; a render reads all of it.
    let whole_network = extra.relight.is_none();
    crate::log::debug(|| {
        format!(
            "{}: {} shapes, {} instances, {} materials, {} lights",
            args.scene.display(),
            scene.shapes.len(),
            scene.instances.len(),
            scene.materials.len(),
            scene.lights.len()
        )
    });
    let mut job = options::job(&args, &scene, extra)?;
    let aovs = if args.aov {
        aov_paths(&args.outputs[0])
    } else {
        Vec::new()
    };
    job.region = farm::region(&args, &job)?;
    let settings = job.settings_key() + &format!(" half={}", args.half);
    // What a resume must match: the settings parts record for merging, with the version and
    // the scene.
    let resume_key = format!(
        "raylink {} scene {:016x} {settings}",
        raylink::VERSION,
        raylink::farm::scene_hash(&scene)
    );
    let progressive = job.technique.passes().is_some() && job.region.is_none();
    // The inputs first (a cache or network file that is there is read), then the outputs.
    // A cache or network file is read whole into memory, where it counts against the
    // budget as the scene's files do.
    for (file, kind, whole) in [
        (&args.cache_file, &input_file::IRRADIANCE_CACHE, true),
        (
            &args.network.network_file,
            &input_file::NETWORK,
            whole_network,
        ),
    ] {
        if let Some(f) = file.as_ref().filter(|f| f.exists()) {
            let size = input_file::check(f, kind)?;
            if whole {
                input_file::Allowance::new(control.budget, 0)
                    .check(&format!("reading {}", f.display()), size)?;
            }
        }
    }
    let mut plan = FilePlan::new();
    plan.reads("an input of the scene", &scene.inputs);
    technique_files(&mut plan, &args);
    plan.writes(output_label, &args.outputs)
        .writes("--aov", &aovs);
    if progressive {
        plan.writes(
            "the checkpoint",
            &checkpoint::names(&args.outputs[0], &resume_key),
        );
    }
    plan.check()?;
    let checkpoint = if progressive {
        // A checkpoint found there is read beside the film and image the job will hold.
        let allowance = input_file::Allowance::new(control.budget, job.image_bytes());
        Some(checkpoint::path_for_within(
            &args.outputs[0],
            &resume_key,
            &allowance,
        )?)
    } else {
        None
    };
    // What writes the image, before the work (it is not loaded at start-up).
    raylink::image::io::load()?;
    let mut metadata = metadata(&args, &job);
    farm::part_metadata(&mut metadata, settings.clone(), &scene, &args, &job);
    let scene = Arc::new(scene);
    let mut renderer = Renderer::new(scene.clone(), job, &control)?;
    let job = renderer.job().clone();
    if args.light_passes {
        refuse_light_passes(&args, &renderer)?;
    }
    if job.region.is_some() {
        renderer.prepare(&control)?;
        let rendered = renderer.render(&control)?;
        cli.print_report(&args, &renderer);
        return farm::write_part(
            cli,
            &args,
            &renderer,
            rendered,
            metadata,
            &out_options,
            &control,
        );
    }
    let display = match &args.display_server {
        Some(address) => Some(DisplayServer::start(
            address.parse()?,
            &display_title(&args),
        )),
        None => None,
    };
    let mut partial_note = String::new();
    let mut unsaved = None;
    let rendered = if let Some(checkpoint) = &checkpoint {
        let (rendered, note, checkpoint_error) = render_with_checkpoints(
            &args,
            &mut renderer,
            (checkpoint, &resume_key),
            (&metadata, &out_options),
            display.as_ref(),
            &control,
        )?;
        partial_note = note;
        unsaved = checkpoint_error;
        rendered
    } else {
        renderer.render(&control)?
    };
    cli.print_report(&args, &renderer);
    let Rendered { image, stats, film } = rendered;
    if stats.invalid > 0 && crate::log::enabled(crate::log::Level::Warn) {
        eprintln!(
            "raylink: warning: {} samples were not finite and were dropped",
            stats.invalid
        );
    }
    if stats.cancelled && stats.samples == 0 {
        // Nothing rendered overwrites nothing.
        return Err(cli.interrupted("the render", "nothing was rendered, so nothing was written"));
    }
    if stats.cancelled {
        metadata.push(("raylink:partial".into(), MetaValue::Int(1)));
    }
    let pixels = job.width as f32 * job.height as f32;
    metadata.extend(farm::stats_metadata(&stats, pixels));
    for out in &args.outputs {
        write_image(out, &image, &metadata, &out_options)?;
        crate::log::debug(|| format!("wrote {}", out.display()));
    }
    if let Some(why) = display.and_then(|d| d.finish(&image)) {
        if crate::log::enabled(crate::log::Level::Warn) {
            let address = args.display_server.as_deref().unwrap_or_default();
            eprintln!("raylink: warning: --display-server {address}: {why}");
        }
    }
    if stats.cancelled {
        let outputs: Vec<String> = args
            .outputs
            .iter()
            .map(|p| p.display().to_string())
            .collect();
        if let Some(e) = unsaved {
            // The image is kept; the film for --resume is not: a failure while working.
            return Err(Failure::Incomplete {
                detail: format!(
                    "{} during the render: wrote the partial image {}, but the checkpoint \
                     for --resume could not be saved: {e}",
                    cli.stopped_by(),
                    outputs.join(", ")
                ),
            });
        }
        return Err(cli.interrupted(
            "the render",
            &format!(
                "wrote the partial image {} ({})",
                outputs.join(", "),
                if partial_note.is_empty() {
                    "the tiles finished; the rest is black".to_string()
                } else {
                    partial_note
                }
            ),
        ));
    }
    if args.aov {
        let images = renderer
            .render_aov_layers(&control)?
            .ok_or_else(|| cli.interrupted("the auxiliary images", "the image was written"))?;
        for (path, img) in aovs.iter().zip(&images) {
            write_image(path, img, &metadata, &out_options)?;
            crate::log::debug(|| format!("wrote {}", path.display()));
        }
        // The EXR outputs again, now with every auxiliary image as a layer.
        let mut layers: Vec<Layer> = Aov::LAYERS
            .iter()
            .zip(&images)
            .map(|(aov, image)| Layer {
                name: aov.name(),
                channels: aov.channels(),
                image,
            })
            .collect();
        // Each pixel's error estimate, its samples' variance and its sample count (with
        // adaptive sampling, or kept for these layers by the techniques whose samples
        // belong to a pixel).
        let adaptive = match &film {
            Some(film) => film.statistics_images()?,
            None => None,
        };
        if let Some([error, variance, samples]) = &adaptive {
            layers.push(Layer {
                name: "error",
                channels: &["X"],
                image: error,
            });
            layers.push(Layer {
                name: "variance",
                channels: &["R", "G", "B"],
                image: variance,
            });
            layers.push(Layer {
                name: "samples",
                channels: &["X"],
                image: samples,
            });
        }
        let passes = if args.light_passes {
            renderer
                .render_light_passes(args.light_groups, &control)?
                .ok_or_else(|| cli.interrupted("the light passes", "the image was written"))?
                .layers
        } else {
            Vec::new()
        };
        for (name, image) in &passes {
            layers.push(Layer {
                name,
                channels: &["R", "G", "B"],
                image,
            });
        }
        for out in args.outputs.iter().filter(|o| is_exr(o)) {
            write_image_layers(out, &image, &layers, &metadata, &out_options)?;
            crate::log::debug(|| {
                format!("wrote {} again with the auxiliary layers", out.display())
            });
        }
    }
    if crate::log::info(args.quiet) {
        eprintln!("{}", stats.summary());
    }
    Ok(())
}

/// Refuses --light-passes where they cannot be had, before the render: the technique's
/// reasons, a part of an image, no EXR output to hold them.
fn refuse_light_passes(args: &RenderArgs, renderer: &Renderer) -> Result<(), Error> {
    renderer.check_light_passes(args.light_groups)?;
    if renderer.job().region.is_some() {
        return Err(Error::setting(
            "light_passes",
            "does not apply to a part of an image (--tile/--crop)",
        ));
    }
    if !args.outputs.iter().any(|o| is_exr(o)) {
        return Err(Error::setting(
            "light_passes",
            "needs an .exr output: the passes are layers of the EXR file",
        ));
    }
    Ok(())
}

/// The viewer's name for the image: the first output's file name, with the process id so
/// that two renders of one name stay apart (as pbrt-v4 names them).
fn display_title(args: &RenderArgs) -> String {
    let name = args.outputs[0]
        .file_name()
        .map_or_else(|| "raylink".into(), |n| n.to_string_lossy());
    format!("{name} ({})", std::process::id())
}

/// A progressive render with --resume, --checkpoint-interval and --write-interval; the
/// checkpoint of an interrupted render is saved. Returns the render and, if interrupted,
/// what the checkpoint keeps, or why it could not be saved (the partial image is still to
/// be written).
fn render_with_checkpoints(
    args: &RenderArgs,
    renderer: &mut Renderer,
    (checkpoint, settings): (&std::path::Path, &str),
    (metadata, out_options): (&Metadata, &OutputOptions),
    display: Option<&DisplayServer>,
    control: &Control,
) -> Result<(Rendered, String, Option<Error>), Failure> {
    let job = renderer.job().clone();
    let (width, height) = (job.width, job.height);
    let passes = job.technique.passes().unwrap_or(1);
    let mc = job.technique.monte_carlo();
    let mut resumed_samples = 0;
    if args.resume && mc.is_some_and(|m| m.guiding) {
        return Err(Error::setting(
            "guiding",
            "cannot be used with --resume: a checkpoint does not keep the guide",
        )
        .into());
    }
    let resume = if args.resume {
        // A checkpoint's bytes beside the film and image the job holds already.
        let allowance = input_file::Allowance::new(control.budget, job.image_bytes());
        let Some(found) = checkpoint::find_within(&args.outputs[0], settings, &allowance)? else {
            return Err(Error::Invalid(format!(
                "--resume: there is no checkpoint {} (an interrupted render or \
                 --checkpoint-interval writes one)",
                checkpoint.display()
            ))
            .into());
        };
        let blank = job
            .blank_film()?
            .ok_or_else(|| Error::Invalid("a progressive render without a film".into()))?;
        let resumed = checkpoint::load_within(&found, settings, blank, passes, &allowance)?;
        resumed_samples = resumed.samples;
        Some(resumed.film)
    } else {
        None
    };
    let mut last_write = std::time::Instant::now();
    let mut last_checkpoint = std::time::Instant::now();
    let mut after_pass = |film: &raylink::Film, shown: raylink::Shown, _: &raylink::RenderStats| {
        if let Some(display) = display {
            display.show(&film.image()?);
        }
        if shown == raylink::Shown::MidPass {
            // Checkpoints and intermediate images hold whole passes only.
            return Ok(());
        }
        if args
            .checkpoint_interval
            .is_some_and(|t| last_checkpoint.elapsed().as_secs_f64() >= t)
            && film.spp < passes
        {
            // Samples so far are only an estimate here; the image does not use them.
            let samples = (film.mean_spp() * width as f64 * height as f64) as u64;
            checkpoint::save(checkpoint, film, settings, samples)?;
            last_checkpoint = std::time::Instant::now();
        }
        let due = args
            .write_interval
            .is_some_and(|t| last_write.elapsed().as_secs_f64() >= t);
        if due && film.spp < passes {
            let mut meta = metadata.clone();
            meta.push((
                "raylink:samples_per_pixel".into(),
                MetaValue::Float(film.spp as f32),
            ));
            meta.push(("raylink:partial".into(), MetaValue::Int(1)));
            for out in &args.outputs {
                write_image(out, &film.image()?, &meta, out_options)?;
            }
            last_write = std::time::Instant::now();
        }
        Ok(())
    };
    let watch = raylink::Watch {
        film: &mut after_pass,
        // A viewer is shown the film a few times a second, as pbrt-v4 updates it.
        mid_pass: display.map(|_| std::time::Duration::from_millis(250)),
    };
    let mut rendered = renderer.render_progressive(control, resume, watch)?;
    rendered.stats.samples += resumed_samples;
    let film = rendered
        .film
        .as_ref()
        .expect("a whole progressive render has a film");
    let mut note = String::new();
    if rendered.stats.cancelled && rendered.stats.samples > 0 {
        if let Err(e) = checkpoint::save(checkpoint, film, settings, rendered.stats.samples) {
            return Ok((rendered, note, Some(e)));
        }
        let taken = if mc.is_some_and(|m| m.adaptive.is_some()) {
            // Adaptive sampling: pixels take different counts, up to spp.
            format!(
                "{:.2} samples per pixel on average, at most {passes}",
                film.mean_spp(),
            )
        } else if mc.is_none() {
            format!("{} of {passes} iterations", film.spp)
        } else {
            format!("{:.2} of {passes} samples per pixel", film.mean_spp())
        };
        note = format!(
            "{taken}; the film is in {} for --resume",
            checkpoint.display()
        );
    } else if !rendered.stats.cancelled && checkpoint.exists() {
        // The render is complete: its checkpoint is stale.
        let _ = std::fs::remove_file(checkpoint);
    }
    Ok((rendered, note, None))
}

/// `raylink relight`: a network render that must load its network and may change the lights.
pub fn run_relight(cli: &Cli, args: RelightArgs) -> Result<(), Failure> {
    let mut render = args.render;
    if render
        .integrator
        .is_some_and(|i| i != IntegratorName(TechniqueKind::Network))
    {
        return Err(Error::Invalid(
            "relight renders with the network integrator; leave out --integrator".into(),
        )
        .into());
    }
    render.integrator = Some(IntegratorName(TechniqueKind::Network));
    match &render.network.network_file {
        None => {
            return Err(Error::Invalid(
                "relight needs --network-file FILE (a network saved by raylink render \
                 --network-file)"
                    .into(),
            )
            .into())
        }
        Some(f) if !f.exists() => {
            return Err(Error::Invalid(format!(
                "{}: no such network file (save one with raylink render --network-file)",
                f.display()
            ))
            .into())
        }
        Some(_) => {}
    }
    let mut lights = Vec::new();
    for l in &args.lights {
        match parse_light(l) {
            Some(p) => lights.push(p),
            None => {
                return Err(Error::Invalid(format!(
                    "--light takes NAME=K or NAME=R,G,B with non-negative numbers, got \"{l}\""
                ))
                .into())
            }
        }
    }
    let relight = Relight {
        lights,
        store_basis: args.store_basis,
        reflectance_series: args.reflectance_series,
    };
    let extra = Settings {
        relight: Some(relight),
        ..Settings::default()
    };
    run_render(cli, render, extra)
}

/// `NAME=K` (every channel times K) or `NAME=R,G,B`, with finite non-negative factors.
fn parse_light(text: &str) -> Option<(String, raylink::math::Rgb)> {
    let (name, factors) = text.split_once('=')?;
    let k: Vec<f32> = factors
        .split(',')
        .map(|f| f.trim().parse::<f32>().ok())
        .collect::<Option<_>>()?;
    let k = match k[..] {
        [k] => raylink::math::Rgb::splat(k),
        [r, g, b] => raylink::math::Rgb::new(r, g, b),
        _ => return None,
    };
    let valid = !name.is_empty() && k.is_finite() && k.min_element() >= 0.0;
    valid.then(|| (name.to_string(), k))
}

/// `raylink precompute`: the irradiance cache (`--cache-file`) of one view, or the
/// illumination network (`--network-file`), computed once and written atomically for render
/// jobs to read.
pub fn run_precompute(cli: &Cli, mut args: RenderArgs) -> Result<(), Failure> {
    let control = cli.control(args.quiet, args.max_memory.as_deref())?;
    if !args.outputs.is_empty() {
        return Err(Error::Invalid("precompute writes no image: -o does not apply".into()).into());
    }
    if args.part.part().is_some() {
        return Err(Error::Invalid(
            "precompute covers the whole view: --tile and --crop do not apply".into(),
        )
        .into());
    }
    let wanted = match (&args.cache_file, &args.network.network_file) {
        (Some(_), None) => IntegratorName(TechniqueKind::IrradianceCache),
        (None, Some(_)) => IntegratorName(TechniqueKind::Network),
        _ => {
            return Err(Error::Invalid(
                "precompute needs one of --cache-file F (irradiance cache) and \
                 --network-file F (illumination network)"
                    .into(),
            )
            .into())
        }
    };
    if let Some(i) = args.integrator.filter(|&i| i != wanted) {
        return Err(Error::Invalid(format!(
            "--integrator {} does not precompute anything; --cache-file is for \
             irradiance-cache, --network-file for network",
            i.kind()
        ))
        .into());
    }
    args.integrator = Some(wanted);
    options::check(&args)?;
    let scene = load_scene(&args.scene, &control)?;
    let job = options::job(&args, &scene, Settings::default())?;
    let mut plan = FilePlan::new();
    plan.reads("an input of the scene", &scene.inputs);
    technique_files(&mut plan, &args);
    plan.check()?;
    debug_assert!(matches!(
        job.technique.kind(),
        TechniqueKind::IrradianceCache | TechniqueKind::Network
    ));
    let start = std::time::Instant::now();
    let mut renderer = Renderer::new(scene, job, &control)?;
    renderer.precompute(&control)?;
    if crate::log::info(args.quiet) {
        eprintln!("precomputed in {:.2} s", start.elapsed().as_secs_f64());
    }
    Ok(())
}
