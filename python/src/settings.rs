//! Keyword arguments to the library's [`Settings`]: the keywords are the settings' own names
//! (`spp`, `max_depth`, `ic_accuracy`), the values Python's numbers, strings, booleans and
//! paths. Ranges are the technique's to check ([`raylink::job::technique_for`]), as for the
//! command line, so both refuse a value with the same words.

use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use raylink::image::filter::Filter;
use raylink::job::{AntiAliasing, NetworkBuilder, NetworkOrder};
use raylink::{Error, Scene, Settings, TechniqueKind};
use std::path::PathBuf;

/// The render settings a keyword can give, besides `filter_radius` (which goes with
/// `filter`). `relight` is given by [`crate::relight`]'s `lights`.
pub const NAMES: &[&str] = &[
    "integrator",
    "spp",
    "max_depth",
    "time_limit",
    "adaptive_threshold",
    "adaptive_min_samples",
    "guiding",
    "spectral",
    "max_component_value",
    "filter",
    "filter_radius",
    "aa",
    "aa_threshold",
    "aa_depth",
    "area_samples",
    "fresnel",
    "ab",
    "ic_accuracy",
    "ic_samples",
    "ic_gradients",
    "ar",
    "cache_file",
    "show_cache_points",
    "slopes",
    "intercept_step",
    "patch_size",
    "network_jitter",
    "network_builder",
    "tolerance",
    "network_file",
    "light_scale",
    "network_order",
    "network_hybrid",
    "photons_per_iteration",
    "sppm_radius",
];

/// A value of the wrong type or form, named as the setting (a `raylink.RaylinkError`).
fn bad(name: &str, detail: impl Into<String>) -> PyErr {
    crate::errors::to_py(Error::setting(name, detail))
}

fn finite32(name: &str, v: &Bound<'_, PyAny>) -> PyResult<f32> {
    let x: f64 = v.extract().map_err(|_| bad(name, "must be a number"))?;
    let y = x as f32;
    if !y.is_finite() {
        return Err(bad(name, format!("must be a finite number, got {x}")));
    }
    Ok(y)
}

fn finite64(name: &str, v: &Bound<'_, PyAny>) -> PyResult<f64> {
    let x: f64 = v.extract().map_err(|_| bad(name, "must be a number"))?;
    if !x.is_finite() {
        return Err(bad(name, format!("must be a finite number, got {x}")));
    }
    Ok(x)
}

fn count(name: &str, v: &Bound<'_, PyAny>) -> PyResult<u32> {
    if v.is_instance_of::<pyo3::types::PyBool>() {
        return Err(bad(name, "must be a whole number, got a bool"));
    }
    let n: i64 = v
        .extract()
        .map_err(|_| bad(name, "must be a whole number"))?;
    u32::try_from(n).map_err(|_| bad(name, format!("must be between 0 and {}, got {n}", u32::MAX)))
}

fn flag(name: &str, v: &Bound<'_, PyAny>) -> PyResult<bool> {
    v.extract().map_err(|_| bad(name, "must be True or False"))
}

fn text(name: &str, v: &Bound<'_, PyAny>) -> PyResult<String> {
    v.extract().map_err(|_| bad(name, "must be a string"))
}

fn path(name: &str, v: &Bound<'_, PyAny>) -> PyResult<PathBuf> {
    v.extract()
        .map_err(|_| bad(name, "must be a path (str or os.PathLike)"))
}

/// One of `choices` (`name` in messages).
fn choice<T: Copy>(name: &str, v: &Bound<'_, PyAny>, choices: &[(&str, T)]) -> PyResult<T> {
    let given = text(name, v)?;
    choices
        .iter()
        .find(|(n, _)| n.eq_ignore_ascii_case(&given))
        .map(|&(_, t)| t)
        .ok_or_else(|| {
            let names: Vec<String> = choices.iter().map(|(n, _)| format!("\"{n}\"")).collect();
            bad(
                name,
                format!("must be one of {}, got \"{given}\"", names.join(", ")),
            )
        })
}

/// The settings `kwargs` give (only those given; `None` values are left out), for `scene`
/// (a filter radius alone keeps the scene's filter, as `--filter-radius` does).
pub fn from_kwargs(scene: &Scene, kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<Settings> {
    let mut s = Settings::default();
    let Some(kwargs) = kwargs else {
        return Ok(s);
    };
    let mut filter_name = None;
    let mut filter_radius = None;
    for (key, value) in kwargs.iter() {
        let key: String = key.extract()?;
        if value.is_none() {
            continue;
        }
        let v = &value;
        let n = key.as_str();
        match n {
            "integrator" => {
                let name = text(n, v)?;
                let kind = TechniqueKind::from_name(&name).ok_or_else(|| {
                    let all: Vec<&str> = TechniqueKind::ALL.iter().map(|k| k.name()).collect();
                    bad(
                        n,
                        format!("must be one of {}, got \"{name}\"", all.join(", ")),
                    )
                })?;
                s.integrator = Some(kind);
            }
            "spp" => s.spp = Some(count(n, v)?),
            "max_depth" => s.max_depth = Some(count(n, v)?),
            "time_limit" => s.time_limit = Some(finite64(n, v)?),
            "adaptive_threshold" => s.adaptive_threshold = Some(finite32(n, v)?),
            "adaptive_min_samples" => s.adaptive_min_samples = Some(count(n, v)?),
            "max_component_value" => s.max_component_value = Some(finite32(n, v)?),
            "filter" => filter_name = Some(text(n, v)?),
            "filter_radius" => filter_radius = Some(finite32(n, v)?),
            "aa" => {
                s.aa = Some(choice(
                    n,
                    v,
                    &[
                        ("adaptive", AntiAliasing::Adaptive),
                        ("uniform", AntiAliasing::Uniform),
                    ],
                )?)
            }
            "aa_threshold" => s.aa_threshold = Some(finite32(n, v)?),
            "aa_depth" => s.aa_depth = Some(count(n, v)?),
            "area_samples" => s.area_samples = Some(count(n, v)?),
            "guiding" => s.guiding = Some(flag(n, v)?),
            "spectral" => s.spectral = Some(flag(n, v)?),
            "fresnel" => s.fresnel = Some(flag(n, v)?),
            "ab" => s.ab = Some(count(n, v)?),
            "ic_accuracy" => s.ic_accuracy = Some(finite32(n, v)?),
            "ic_samples" => s.ic_samples = Some(count(n, v)?),
            "ic_gradients" => s.ic_gradients = Some(flag(n, v)?),
            "ar" => s.ar = Some(finite32(n, v)?),
            "cache_file" => s.cache_file = Some(path(n, v)?),
            "show_cache_points" => s.show_cache_points = Some(flag(n, v)?),
            "slopes" => s.slopes = Some(count(n, v)?),
            "intercept_step" => s.intercept_step = Some(finite32(n, v)?),
            "patch_size" => s.patch_size = Some(finite32(n, v)?),
            "network_jitter" => s.network_jitter = Some(finite32(n, v)?),
            "network_builder" => {
                s.network_builder = Some(choice(
                    n,
                    v,
                    &[
                        ("scan", NetworkBuilder::Scan),
                        ("embree", NetworkBuilder::Embree),
                    ],
                )?)
            }
            "tolerance" => s.tolerance = Some(finite32(n, v)?),
            "network_file" => s.network_file = Some(path(n, v)?),
            "light_scale" => s.light_scale = Some(finite32(n, v)?),
            "network_order" => {
                s.network_order = Some(choice(
                    n,
                    v,
                    &[
                        ("cg", NetworkOrder::ConjugateGradients),
                        ("sweeps", NetworkOrder::Sweeps),
                        ("shoot", NetworkOrder::Shoot),
                    ],
                )?)
            }
            "network_hybrid" => s.network_hybrid = Some(flag(n, v)?),
            "photons_per_iteration" => s.photons_per_iteration = Some(count(n, v)?),
            "sppm_radius" => s.sppm_radius = Some(finite32(n, v)?),
            _ => {
                return Err(PyTypeError::new_err(format!(
                    "unexpected keyword argument '{key}' (the settings are: {})",
                    NAMES.join(", ")
                )))
            }
        }
    }
    s.filter = filter(scene, filter_name.as_deref(), filter_radius)?;
    Ok(s)
}

/// The filter `filter` and `filter_radius` give: a name with its default radius, or a radius
/// alone for the scene's filter (the command line's `--filter` and `--filter-radius`).
fn filter(scene: &Scene, name: Option<&str>, radius: Option<f32>) -> PyResult<Option<Filter>> {
    Filter::given(scene.settings.filter, name, radius).map_err(|e| bad("filter", e))
}
