//! The parameter set of a render: every setting a front end or a scene file can give, each
//! optional, named as scene files and messages name it. `Technique::create` turns it
//! into a technique with its defaults and checks.

use crate::image::filter::Filter;
use crate::math::Rgb;
use std::path::PathBuf;

/// The most samples per pixel any technique takes (a square: 1024 x 1024 for uniform
/// supersampling). The one bound: every reader and front end leaves the check to the
/// technique, or checks against this.
pub const MAX_SPP: u32 = 1 << 20;

/// The light-transport techniques, by name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TechniqueKind {
    /// Whitted 1980: recursive reflection, refraction and shadows.
    Whitted,
    /// Path tracing with next-event estimation and multiple importance sampling.
    Path,
    /// Light (particle) tracing: paths from the lights, connected to the camera.
    Light,
    /// Bidirectional path tracing, all strategies combined by multiple importance sampling.
    Bdpt,
    /// Ward's irradiance caching.
    IrradianceCache,
    /// Buckalew & Fussell's illumination networks.
    Network,
    /// Stochastic progressive photon mapping (Hachisuka & Jensen).
    Sppm,
    /// Vertex connection and merging (Georgiev et al.).
    Vcm,
}

impl TechniqueKind {
    pub const ALL: [TechniqueKind; 8] = [
        TechniqueKind::Whitted,
        TechniqueKind::Path,
        TechniqueKind::Light,
        TechniqueKind::Bdpt,
        TechniqueKind::IrradianceCache,
        TechniqueKind::Network,
        TechniqueKind::Sppm,
        TechniqueKind::Vcm,
    ];

    /// The name in scene files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            TechniqueKind::Whitted => "whitted",
            TechniqueKind::Path => "path",
            TechniqueKind::Light => "light",
            TechniqueKind::Bdpt => "bdpt",
            TechniqueKind::IrradianceCache => "irradiance-cache",
            TechniqueKind::Network => "network",
            TechniqueKind::Sppm => "sppm",
            TechniqueKind::Vcm => "vcm",
        }
    }

    pub fn from_name(name: &str) -> Option<TechniqueKind> {
        TechniqueKind::ALL
            .into_iter()
            .find(|k| k.name().eq_ignore_ascii_case(name))
    }
}

impl std::fmt::Display for TechniqueKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Whitted's anti-aliasing: adaptive corner subdivision or a regular grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AntiAliasing {
    Adaptive,
    Uniform,
}

/// How the illumination network finds its links.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum NetworkBuilder {
    /// Incremental scan conversion of the polygons (the paper's preprocess).
    #[default]
    Scan,
    /// Repeated closest-hit queries along every line through the intersection backend.
    Embree,
}

impl NetworkBuilder {
    /// Its name in scene files and settings (`scan`, `embree`).
    pub fn name(self) -> &'static str {
        match self {
            NetworkBuilder::Scan => "scan",
            NetworkBuilder::Embree => "embree",
        }
    }
}

/// The order in which the network's nodes process their light.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum NetworkOrder {
    /// Jacobi sweeps over all nodes, in parallel.
    Sweeps,
    /// Largest unshot flux first (Southwell iteration, as progressive radiosity), one node at
    /// a time. Networks with directional nodes use sweeps.
    Shoot,
    /// Conjugate gradients on the symmetrised system: about half the gathers of the sweeps
    /// for the same tolerance. Networks with directional nodes use sweeps.
    #[default]
    ConjugateGradients,
}

impl NetworkOrder {
    /// Its name in scene files and settings (`cg`, `sweeps`, `shoot`).
    pub fn name(self) -> &'static str {
        match self {
            NetworkOrder::ConjugateGradients => "cg",
            NetworkOrder::Sweeps => "sweeps",
            NetworkOrder::Shoot => "shoot",
        }
    }
}

/// What `relight` changes in a saved network (see `NetworkSettings::relight`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Relight {
    /// Multiply the emission of the scene's material NAME by K, channel by channel (a
    /// strength and a colour: `Rgb::splat(2.0)` doubles it, `Rgb::new(1.0, 0.5, 0.5)` tints
    /// it red).
    pub lights: Vec<(String, Rgb)>,
    /// Compute and store the light basis afresh (replacing the file's).
    pub store_basis: bool,
    /// Store a reflectance series for each of these diffuse materials with the basis.
    pub reflectance_series: Vec<String>,
}

/// Every setting a front end can give, each optional (unset: the technique's default). The
/// field names are the settings' names in messages.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Settings {
    /// The technique (default: Whitted).
    pub integrator: Option<TechniqueKind>,
    /// Samples per pixel (Monte Carlo, default 16); Whitted and network: a square number
    /// selects uniform supersampling.
    pub spp: Option<u32>,
    /// Ray-tree depth (Whitted) or bounces (Monte Carlo). Default 8.
    pub max_depth: Option<u32>,
    /// Monte Carlo: render whole passes until this many seconds have passed.
    pub time_limit: Option<f64>,
    /// Path tracing: stop sampling a pixel once its error estimate is below this.
    pub adaptive_threshold: Option<f32>,
    /// Path tracing: samples every pixel takes before adaptive sampling may stop it.
    pub adaptive_min_samples: Option<u32>,
    /// Path tracing: learn where light comes from and sample from it (path guiding).
    pub guiding: Option<bool>,
    /// Path tracing: carry light at sampled wavelengths instead of RGB (spectral mode).
    pub spectral: Option<bool>,
    /// Monte Carlo: scale samples down so that no channel exceeds this (biased).
    pub max_component_value: Option<f32>,
    /// Monte Carlo: the pixel filter (default pbrt's Gaussian).
    pub filter: Option<Filter>,
    pub aa: Option<AntiAliasing>,
    pub aa_threshold: Option<f32>,
    pub aa_depth: Option<u32>,
    /// Whitted: shadow rays per area light (default 16).
    pub area_samples: Option<u32>,
    /// Whitted: Fresnel-weighted reflection and transmission everywhere.
    pub fresnel: Option<bool>,
    /// Irradiance cache: bounces.
    pub ab: Option<u32>,
    pub ic_accuracy: Option<f32>,
    pub ic_samples: Option<u32>,
    /// Irradiance cache: Ward & Heckbert's gradients (default on).
    pub ic_gradients: Option<bool>,
    pub ar: Option<f32>,
    /// Irradiance cache: values are loaded from this file if it exists and saved to it.
    pub cache_file: Option<PathBuf>,
    /// Irradiance cache: mark the first-level values the camera sees.
    pub show_cache_points: Option<bool>,
    pub slopes: Option<u32>,
    pub intercept_step: Option<f32>,
    pub patch_size: Option<f32>,
    pub network_jitter: Option<f32>,
    pub network_builder: Option<NetworkBuilder>,
    pub tolerance: Option<f32>,
    /// Network: loaded from this file if it exists, else built and saved there.
    pub network_file: Option<PathBuf>,
    pub light_scale: Option<f32>,
    pub network_order: Option<NetworkOrder>,
    pub network_hybrid: Option<bool>,
    pub relight: Option<Relight>,
    /// Stochastic progressive photon mapping: photons per iteration.
    pub photons_per_iteration: Option<u32>,
    /// Stochastic progressive photon mapping: the initial search radius.
    pub sppm_radius: Option<f32>,
}

/// Calls macro `$m` with the name of every field of [`Settings`]: the one list that
/// [`Settings::overlaid`] and [`Settings::given`] go through, so a new setting is in both.
macro_rules! for_each_setting {
    ($m:ident) => {
        $m!(
            integrator,
            spp,
            max_depth,
            time_limit,
            adaptive_threshold,
            adaptive_min_samples,
            guiding,
            spectral,
            max_component_value,
            filter,
            aa,
            aa_threshold,
            aa_depth,
            area_samples,
            fresnel,
            ab,
            ic_accuracy,
            ic_samples,
            ic_gradients,
            ar,
            cache_file,
            show_cache_points,
            slopes,
            intercept_step,
            patch_size,
            network_jitter,
            network_builder,
            tolerance,
            network_file,
            light_scale,
            network_order,
            network_hybrid,
            relight,
            photons_per_iteration,
            sppm_radius
        )
    };
}

impl Settings {
    /// The name of every setting.
    pub const NAMES: &'static [&'static str] = {
        macro_rules! names {
            ($($f:ident),*) => { &[$(stringify!($f)),*] };
        }
        for_each_setting!(names)
    };

    /// These settings with every setting `over` gives replacing its own.
    pub fn overlaid(self, over: &Settings) -> Settings {
        macro_rules! pick {
            ($($f:ident),*) => { Settings { $($f: over.$f.clone().or(self.$f),)* } };
        }
        for_each_setting!(pick)
    }

    /// The names of the settings that are set.
    pub fn given(&self) -> Vec<&'static str> {
        let mut v = Vec::new();
        macro_rules! given {
            ($($f:ident),*) => { $( if self.$f.is_some() { v.push(stringify!($f)); } )* };
        }
        for_each_setting!(given);
        v
    }
}
