//! `raylink._raylink`: the Python extension over the raylink library. It describes a job
//! (a scene and the settings given as keywords) and runs it through the library's
//! `Renderer`, as the command line does; the pure-Python package in `raylink/` wraps it.

mod errors;
mod run;
mod settings;

use errors::to_py;
use numpy::{PyArray3, PyReadonlyArray3};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use raylink::image::output::check_output_path;
use raylink::{
    Backend, Image, Job, MemoryBudget, MetaValue, Metadata, OutputOptions, Relight, Settings,
    Shown, TechniqueKind, Watch,
};
use run::{drive, passes, Pass, Reporter};
use std::path::PathBuf;
use std::sync::Arc;

/// A scene read from a file (`.toml` or `.pbrt`) or from TOML text.
#[pyclass(frozen, module = "raylink")]
struct Scene {
    inner: Arc<raylink::Scene>,
}

/// The scene's own warnings (what its reader replaced) as Python warnings.
fn warn_scene(py: Python<'_>, scene: &raylink::Scene) -> PyResult<()> {
    let category = py.get_type::<pyo3::exceptions::PyUserWarning>();
    for w in &scene.warnings {
        PyErr::warn(py, &category, &std::ffi::CString::new(w.as_str())?, 2)?;
    }
    Ok(())
}

#[pymethods]
impl Scene {
    /// Reads a scene file, choosing the reader by extension (`.toml`, `.pbrt`).
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Scene> {
        let scene = py.detach(|| raylink::Scene::load(&path)).map_err(to_py)?;
        warn_scene(py, &scene)?;
        Ok(Scene {
            inner: Arc::new(scene),
        })
    }

    /// Reads a scene in the native TOML format from `text`; `path` names it in messages and
    /// is where relative file names (meshes, textures) start from.
    #[staticmethod]
    #[pyo3(signature = (text, path = None))]
    fn from_toml(py: Python<'_>, text: &str, path: Option<PathBuf>) -> PyResult<Scene> {
        let path = path.unwrap_or_else(|| PathBuf::from("<string>"));
        let scene = py
            .detach(|| {
                let scene = raylink::scene::toml::from_str(text, &path)?;
                scene.check_extent()?;
                Ok(scene)
            })
            .map_err(to_py)?;
        warn_scene(py, &scene)?;
        Ok(Scene {
            inner: Arc::new(scene),
        })
    }

    /// The camera's image width in pixels.
    #[getter]
    fn width(&self) -> u32 {
        self.inner.camera.width
    }

    /// The camera's image height in pixels.
    #[getter]
    fn height(&self) -> u32 {
        self.inner.camera.height
    }

    /// The names of the scene's materials (the lights `relight` scales are the emissive ones).
    #[getter]
    fn materials(&self) -> Vec<String> {
        self.inner
            .materials
            .iter()
            .map(|m| m.name.clone())
            .collect()
    }

    /// The file the scene was read from.
    #[getter]
    fn source(&self) -> PathBuf {
        self.inner.source.clone()
    }

    fn __repr__(&self) -> String {
        format!(
            "Scene({:?}: {} shapes, {} materials, {} lights, {}x{})",
            self.inner.source.display().to_string(),
            self.inner.shapes.len(),
            self.inner.materials.len(),
            self.inner.lights.len(),
            self.inner.camera.width,
            self.inner.camera.height
        )
    }
}

/// A `Scene`, or the path of a scene file to read.
fn scene_arg(py: Python<'_>, scene: &Bound<'_, PyAny>) -> PyResult<Arc<raylink::Scene>> {
    if let Ok(s) = scene.cast::<Scene>() {
        return Ok(s.get().inner.clone());
    }
    let path: PathBuf = scene.extract().map_err(|_| {
        pyo3::exceptions::PyTypeError::new_err("scene must be a raylink.Scene or a path")
    })?;
    Ok(Scene::load(py, path)?.inner)
}

/// The image of a render, with its statistics.
#[pyclass(frozen, module = "raylink")]
struct Rendered {
    /// The image: float32, height x width x 3 (linear RGB).
    #[pyo3(get)]
    image: Py<PyArray3<f32>>,
    /// Whether the render was cancelled before every sample was taken.
    #[pyo3(get)]
    partial: bool,
    /// Camera samples taken.
    #[pyo3(get)]
    samples: u64,
    /// Seconds the render took (its preparation not included).
    #[pyo3(get)]
    seconds: f64,
    /// Seconds the technique's preparation took in this render (0 when it was done before).
    #[pyo3(get)]
    prepare_seconds: f64,
    /// The statistics as the command line prints them.
    #[pyo3(get)]
    summary: String,
    pixels: Image,
    metadata: Metadata,
}

/// The output options, as the command line's `--exposure`, `--half` and `--color-space`.
fn output_options(exposure: f32, half: bool, color_space: &str) -> PyResult<OutputOptions> {
    if !exposure.is_finite() {
        return Err(to_py(raylink::Error::setting(
            "exposure",
            format!("must be a finite number of stops, got {exposure}"),
        )));
    }
    let color_space = raylink::image::output::color_space_named(color_space)
        .map_err(|why| to_py(raylink::Error::setting("color_space", why)))?;
    Ok(OutputOptions {
        exposure,
        half,
        color_space,
    })
}

#[pymethods]
impl Rendered {
    /// Writes the image through the command line's outputs (EXR, HDR, TIFF, PNG, JPEG by
    /// extension) with its metadata; `exposure` (stops) applies to PNG and JPEG, `half` to
    /// EXR, `color_space` ("srgb", "rec2020", "dci-p3", "aces2065-1") to the linear formats.
    #[pyo3(signature = (path, *, exposure = 0.0, half = false, color_space = "srgb"))]
    fn write(
        &self,
        py: Python<'_>,
        path: PathBuf,
        exposure: f32,
        half: bool,
        color_space: &str,
    ) -> PyResult<()> {
        let options = output_options(exposure, half, color_space)?;
        py.detach(|| {
            check_output_path(&path)?;
            raylink::write_image(&path, &self.pixels, &self.metadata, &options)
        })
        .map_err(to_py)
    }

    fn __repr__(&self) -> String {
        format!(
            "Rendered({}x{}{}, {})",
            self.pixels.width,
            self.pixels.height,
            if self.partial { ", partial" } else { "" },
            self.summary
        )
    }
}

/// What an image records of its render, as the command line's outputs do.
fn metadata(job: &Job, partial: bool) -> Metadata {
    let t = &job.technique;
    let mut m: Metadata = vec![
        (
            "Software".into(),
            MetaValue::Str(format!("raylink {} (Python)", raylink::VERSION)),
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
    if partial {
        m.push(("raylink:partial".into(), MetaValue::Int(1)));
    }
    m
}

/// A render job and the engine that runs it: the scene's intersection structure and the
/// technique's preparation (an irradiance cache, an illumination network) are made once and
/// serve every render after, from any camera.
#[pyclass(module = "raylink")]
struct Renderer {
    inner: raylink::Renderer,
    budget: MemoryBudget,
}

/// The job for `scene` and `given`, as the command line makes it.
fn job(
    scene: &raylink::Scene,
    given: &Settings,
    size: (Option<u32>, Option<u32>),
    seed: u64,
    threads: Option<usize>,
    backend: &str,
) -> PyResult<Job> {
    let accel = match backend.to_ascii_lowercase().as_str() {
        "embree" => Backend::Embree,
        "bvh" => Backend::Bvh,
        other => {
            return Err(to_py(raylink::Error::setting(
                "backend",
                format!("must be \"embree\" or \"bvh\", got \"{other}\""),
            )))
        }
    };
    if threads == Some(0) {
        return Err(to_py(raylink::Error::setting(
            "threads",
            "must be at least 1",
        )));
    }
    let technique = raylink::job::technique_for(scene, given).map_err(to_py)?;
    Ok(Job {
        width: size.0.unwrap_or(scene.camera.width),
        height: size.1.unwrap_or(scene.camera.height),
        seed,
        threads,
        accel,
        ..Job::new(scene, technique)
    })
}

/// A memory budget such as "8G" (the command line's `--max-memory`), or the default.
fn budget(max_memory: Option<&str>) -> PyResult<MemoryBudget> {
    match max_memory {
        None => Ok(MemoryBudget::default()),
        Some(text) => raylink::job::parse_size(text)
            .map(MemoryBudget::bytes)
            .map_err(|e| to_py(raylink::Error::setting("max_memory", e))),
    }
}

/// `relight`'s `lights`: material name to a factor or an (r, g, b) of factors.
fn lights(lights: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<(String, raylink::math::Rgb)>> {
    let mut out = Vec::new();
    for (name, k) in lights.into_iter().flat_map(|d| d.iter()) {
        let name: String = name.extract()?;
        let k = if let Ok(k) = k.extract::<f32>() {
            raylink::math::Rgb::splat(k)
        } else if let Ok((r, g, b)) = k.extract::<(f32, f32, f32)>() {
            raylink::math::Rgb::new(r, g, b)
        } else {
            raylink::math::Rgb::splat(f32::NAN)
        };
        if name.is_empty() || !k.is_finite() || k.min_element() < 0.0 {
            return Err(to_py(raylink::Error::setting(
                "lights",
                format!(
                    "takes {{NAME: K}} or {{NAME: (R, G, B)}} with non-negative numbers, got \
                     {name:?}: {k}"
                ),
            )));
        }
        out.push((name, k));
    }
    Ok(out)
}

#[pymethods]
impl Renderer {
    /// A render of `scene` (a `Scene` or a scene file's path) with the settings given as
    /// keywords (the scene file's `[render]` settings where none is given), at `width` x
    /// `height` (default: the camera's), with random streams from `seed`. Checks the job
    /// and builds the intersection structure.
    #[new]
    #[pyo3(signature = (scene, *, width = None, height = None, seed = 0, threads = None,
        backend = "embree", max_memory = None, relight = None, **settings))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        scene: &Bound<'_, PyAny>,
        width: Option<u32>,
        height: Option<u32>,
        seed: u64,
        threads: Option<usize>,
        backend: &str,
        max_memory: Option<&str>,
        relight: Option<&Bound<'_, PyDict>>,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Renderer> {
        let scene = scene_arg(py, scene)?;
        let mut given = settings::from_kwargs(&scene, settings)?;
        if let Some(r) = relight {
            given.relight = Some(relight_settings(r)?);
        }
        let job = job(&scene, &given, (width, height), seed, threads, backend)?;
        let budget = budget(max_memory)?;
        let reporter = Arc::new(Reporter::default());
        let control = run::control(budget, &reporter);
        let (_, rx) = passes();
        let inner = drive(py, None, &control, &reporter, rx, || {
            raylink::Renderer::new(scene, job, &control)
        })?
        .map_err(to_py)?;
        Ok(Renderer { inner, budget })
    }

    /// The image width in pixels.
    #[getter]
    fn width(&self) -> u32 {
        self.inner.job().width
    }

    /// The image height in pixels.
    #[getter]
    fn height(&self) -> u32 {
        self.inner.job().height
    }

    /// The technique's name ("path", "network", ...).
    #[getter]
    fn integrator(&self) -> String {
        self.inner.job().technique.kind().to_string()
    }

    /// Every setting that changes pixels, as one line.
    #[getter]
    fn settings_key(&self) -> String {
        self.inner.job().settings_key()
    }

    /// Runs the technique's preparation now (an irradiance cache's overture, an illumination
    /// network's preprocess, or its loading, and its light distribution); the first render
    /// does it otherwise. `progress` is called as for `render`.
    #[pyo3(signature = (progress = None))]
    fn prepare(&mut self, py: Python<'_>, progress: Option<Bound<'_, PyAny>>) -> PyResult<()> {
        let reporter = Arc::new(Reporter::default());
        let control = run::control(self.budget, &reporter);
        let (_, rx) = passes();
        let inner = &mut self.inner;
        drive(py, progress.as_ref(), &control, &reporter, rx, || {
            inner.prepare(&control)
        })?
        .map_err(to_py)
    }

    /// Renders the job. `progress(event)` is called with the progress at most ten times a
    /// second and, for the progressive techniques, with the image after every pass (and in
    /// the middle of passes at most every `mid_pass` seconds, if given); returning `False`
    /// from it cancels the render, which returns what it finished (`partial`). Ctrl-C
    /// cancels it too and raises `KeyboardInterrupt`.
    #[pyo3(signature = (progress = None, mid_pass = None))]
    fn render(
        &mut self,
        py: Python<'_>,
        progress: Option<Bound<'_, PyAny>>,
        mid_pass: Option<f64>,
    ) -> PyResult<Rendered> {
        let mid_pass = match mid_pass {
            Some(t) if !(t.is_finite() && t > 0.0) => {
                return Err(to_py(raylink::Error::setting(
                    "mid_pass",
                    format!("must be a positive number of seconds, got {t}"),
                )))
            }
            t => t.map(std::time::Duration::from_secs_f64),
        };
        let reporter = Arc::new(Reporter::default());
        let control = run::control(self.budget, &reporter);
        let (tx, rx) = passes();
        let watching = progress.is_some();
        let inner = &mut self.inner;
        let rendered = drive(py, progress.as_ref(), &control, &reporter, rx, || {
            let mut show = |film: &raylink::Film, shown: Shown, _: &raylink::RenderStats| {
                if watching {
                    let spp = match shown {
                        Shown::AfterPass => film.spp,
                        Shown::MidPass => film.mean_spp().floor() as u32,
                    };
                    let _ = tx.send(Pass {
                        image: film.image()?,
                        spp,
                    });
                }
                Ok(())
            };
            let watch = Watch {
                film: &mut show,
                mid_pass,
            };
            inner.render_progressive(&control, None, watch)
        })?
        .map_err(to_py)?;
        let partial = rendered.is_partial();
        let stats = &rendered.stats;
        Ok(Rendered {
            image: run::to_array(py, &rendered.image).unbind(),
            partial,
            samples: stats.samples,
            seconds: stats.seconds,
            prepare_seconds: stats.prepare_seconds,
            summary: stats.summary(),
            metadata: metadata(self.inner.job(), partial),
            pixels: rendered.image,
        })
    }

    /// The auxiliary images of the view, by name: "albedo", "normal" and "position"
    /// (height x width x 3), "depth", "object_id" and "material_id" (height x width; the ids
    /// are 1 + the index of the shape or material seen, 0 for the background).
    #[pyo3(signature = (progress = None))]
    fn aovs<'py>(
        &self,
        py: Python<'py>,
        progress: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let reporter = Arc::new(Reporter::default());
        let control = run::control(self.budget, &reporter);
        let (_, rx) = passes();
        let inner = &self.inner;
        let layers = drive(py, progress.as_ref(), &control, &reporter, rx, || {
            inner.render_aov_layers(&control)
        })?
        .map_err(to_py)?
        .ok_or_else(|| {
            to_py(raylink::Error::Cancelled {
                stage: "the auxiliary images".into(),
            })
        })?;
        let names = [
            "albedo",
            "normal",
            "depth",
            "position",
            "object_id",
            "material_id",
        ];
        let out = PyDict::new(py);
        for ((name, aov), image) in names.iter().zip(raylink::Aov::LAYERS).zip(&layers) {
            if aov.channels().len() == 1 {
                out.set_item(name, run::to_array2(py, image))?;
            } else {
                out.set_item(name, run::to_array(py, image))?;
            }
        }
        Ok(out)
    }

    /// Looks through another camera: each value given replaces the current camera's
    /// (`fov` in degrees). The network renders the new view from what it prepared; the
    /// irradiance cache adds what the new view needs on the next render.
    #[pyo3(signature = (*, position = None, look_at = None, up = None, fov = None))]
    fn set_camera(
        &mut self,
        position: Option<[f32; 3]>,
        look_at: Option<[f32; 3]>,
        up: Option<[f32; 3]>,
        fov: Option<f32>,
    ) -> PyResult<()> {
        let mut camera = self.inner.scene().camera.clone();
        if let Some(p) = position {
            camera.position = p.into();
        }
        if let Some(l) = look_at {
            camera.look_at = l.into();
        }
        if let Some(u) = up {
            camera.up = u.into();
        }
        if let Some(f) = fov {
            camera.fov_deg = f;
        }
        self.inner.set_camera(camera).map_err(to_py)
    }

    /// Statistics of the technique's preparation, one line each.
    fn report(&self) -> Vec<String> {
        self.inner.report()
    }

    fn __repr__(&self) -> String {
        format!("Renderer({})", self.inner.job().settings_key())
    }
}

/// `relight`'s dict: `lights`, `store_basis`, `reflectance_series`.
fn relight_settings(d: &Bound<'_, PyDict>) -> PyResult<Relight> {
    let l = d.get_item("lights")?;
    let store_basis = match d.get_item("store_basis")? {
        Some(v) => v.extract()?,
        None => false,
    };
    let reflectance_series = match d.get_item("reflectance_series")? {
        Some(v) => v.extract()?,
        None => Vec::new(),
    };
    let lights = match &l {
        Some(l) => lights(Some(l.cast::<PyDict>()?))?,
        None => Vec::new(),
    };
    Ok(Relight {
        lights,
        store_basis,
        reflectance_series,
    })
}

/// Reads an image file (EXR, HDR, TIFF, PNG, JPEG) as float32, height x width x 3.
#[pyfunction]
fn read_image<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let (image, _) = py.detach(|| raylink::read_image(&path)).map_err(to_py)?;
    Ok(run::to_array(py, &image))
}

/// Writes a float32 height x width x 3 array through the command line's outputs.
#[pyfunction]
#[pyo3(signature = (path, image, *, exposure = 0.0, half = false, color_space = "srgb"))]
fn write_image(
    py: Python<'_>,
    path: PathBuf,
    image: PyReadonlyArray3<'_, f32>,
    exposure: f32,
    half: bool,
    color_space: &str,
) -> PyResult<()> {
    let options = output_options(exposure, half, color_space)?;
    let view = image.as_array();
    let (h, w, c) = view.dim();
    if c != 3 || h == 0 || w == 0 {
        return Err(to_py(raylink::Error::setting(
            "image",
            format!("must be height x width x 3, got {h} x {w} x {c}"),
        )));
    }
    let too_large = |n: usize| {
        u32::try_from(n).map_err(|_| to_py(raylink::Error::setting("image", "is too large")))
    };
    let mut out = Image::new(too_large(w)?, too_large(h)?);
    for (i, p) in out.pixels.iter_mut().enumerate() {
        let (y, x) = (i / w, i % w);
        *p = raylink::math::Rgb::new(view[[y, x, 0]], view[[y, x, 1]], view[[y, x, 2]]);
    }
    let metadata: Metadata = vec![(
        "Software".into(),
        MetaValue::Str(format!("raylink {} (Python)", raylink::VERSION)),
    )];
    py.detach(|| {
        check_output_path(&path)?;
        raylink::write_image(&path, &out, &metadata, &options)
    })
    .map_err(to_py)
}

/// Checks that an image can be written at `path` (its format known by the extension, its
/// folder there), as the command line checks its outputs before any work.
#[pyfunction]
fn check_output(path: PathBuf) -> PyResult<()> {
    check_output_path(&path).map_err(to_py)
}

/// The technique names `integrator` takes.
#[pyfunction]
fn integrators() -> Vec<&'static str> {
    TechniqueKind::ALL.iter().map(|k| k.name()).collect()
}

#[pymodule]
fn _raylink(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", raylink::VERSION)?;
    m.add("SETTINGS", settings::NAMES.to_vec())?;
    m.add("RaylinkError", m.py().get_type::<errors::RaylinkError>())?;
    m.add("Cancelled", m.py().get_type::<errors::Cancelled>())?;
    m.add_class::<Scene>()?;
    m.add_class::<Renderer>()?;
    m.add_class::<Rendered>()?;
    m.add_class::<run::ProgressEvent>()?;
    m.add_function(wrap_pyfunction!(read_image, m)?)?;
    m.add_function(wrap_pyfunction!(write_image, m)?)?;
    m.add_function(wrap_pyfunction!(integrators, m)?)?;
    m.add_function(wrap_pyfunction!(check_output, m)?)?;
    Ok(())
}
