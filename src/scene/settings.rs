//! Render settings a scene file may carry (pbrt's `Sampler`, `Integrator`, `PixelFilter`;
//! a `[render]` table in TOML): the library's [`Settings`], with where the file gives each,
//! so that a bad value is reported at its line. Command-line options override them.

pub use crate::settings::Settings;

/// Where a scene file gives a setting.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SettingSource {
    /// The setting's name ([`Settings`]' field).
    pub setting: &'static str,
    /// The key as the file writes it (`[render.irradiance-cache] accuracy`).
    pub key: String,
    /// Its line in the file.
    pub line: usize,
    /// The file that gives it, when not the scene file itself (a pbrt `Include`).
    pub file: Option<std::path::PathBuf>,
}
