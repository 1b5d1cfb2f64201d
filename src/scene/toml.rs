//! The native scene format (documented in docs/scene-format.md).

use super::Scene;
use std::path::Path;

/// Reads a native TOML scene.
pub fn read(path: &Path) -> crate::Result<Scene> {
    let text = std::fs::read_to_string(path).map_err(|e| crate::Error::io(path, e))?;
    from_str(&text, path)
}

/// Parses a native TOML scene; `path` names the file in messages and resolves relative paths.
pub fn from_str(_text: &str, path: &Path) -> crate::Result<Scene> {
    Err(crate::Error::input(
        path,
        "the TOML reader is not written yet",
    ))
}
