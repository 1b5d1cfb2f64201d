//! Convert's `NAME.meshes` folder: the meshes go to a new temporary folder that replaces
//! it only once all are written. An existing folder is replaced only if it holds nothing
//! but meshes convert writes (`mesh_NNNN.ply`); anything else there, or a file that is not
//! a folder under that name, is refused before anything is written, so that nothing convert
//! did not write is removed or moved.

use crate::atomic_file::TempFolder;
use crate::error::{Error, Result};
use crate::output_paths::FilePlan;
use crate::scene::{Geometry, Scene, Sphere};
use std::path::{Path, PathBuf};

pub(super) struct MeshDir {
    /// `NAME.meshes`, as the TOML refers to it.
    name: String,
    target: PathBuf,
    /// The folder being written, once the first mesh is.
    tmp: Option<TempFolder>,
    /// What stops the writing between meshes (a signal).
    pub(super) cancel: Option<crate::control::CancelToken>,
}

/// Whether convert writes `name` into a mesh folder: `mesh_` and digits, `.ply`.
fn is_mesh_name(name: &str) -> bool {
    name.strip_prefix("mesh_")
        .and_then(|n| n.strip_suffix(".ply"))
        .is_some_and(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
}

/// The meshes in an existing mesh folder `dir`, or the refusal naming what else is there.
fn existing_meshes(dir: &Path) -> Result<Vec<PathBuf>> {
    let meta = match dir.symlink_metadata() {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(Error::io(dir, e)),
    };
    if !meta.is_dir() {
        return Err(Error::Invalid(format!(
            "{}: is not a folder, and convert writes the scene's meshes into a folder of that \
             name (move it or choose another output)",
            dir.display()
        )));
    }
    let mut meshes = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))? {
        let entry = entry.map_err(|e| Error::io(dir, e))?;
        let name = entry.file_name();
        let regular = entry.file_type().is_ok_and(|t| t.is_file());
        if !(regular && name.to_str().is_some_and(is_mesh_name)) {
            return Err(Error::Invalid(format!(
                "{}: holds {}, which convert did not write, and convert replaces the folder \
                 (move it or choose another output)",
                dir.display(),
                name.to_string_lossy()
            )));
        }
        meshes.push(entry.path());
    }
    Ok(meshes)
}

impl MeshDir {
    /// The mesh folder of `output` (`name` in `out_dir`), after checking every file the
    /// conversion writes against every file the scene was read from, and what is there.
    pub(super) fn new(scene: &Scene, output: &Path, out_dir: &Path, name: String) -> Result<Self> {
        let target = out_dir.join(&name);
        let mut plan = FilePlan::new();
        plan.reads("an input of the scene", &scene.inputs)
            .write("-o", output);
        let prototypes = scene.prototypes.iter().flat_map(|p| &p.shapes);
        let has_meshes = scene
            .shapes
            .iter()
            .chain(prototypes)
            .any(|s| !matches!(s.geometry, Geometry::Sphere(Sphere { .. })));
        if has_meshes {
            plan.write_folder("the mesh folder", &target);
        }
        plan.check()?;
        if has_meshes {
            existing_meshes(&target)?;
            crate::atomic_file::remove_stale_temps(out_dir);
        }
        Ok(MeshDir {
            name,
            target,
            tmp: None,
            cancel: None,
        })
    }

    /// Writes shape `i`'s mesh as PLY; returns the path the TOML gives it.
    pub(super) fn write(&mut self, i: usize, g: &Geometry) -> Result<String> {
        if let Some(cancel) = &self.cancel {
            cancel.check("writing the converted scene")?;
        }
        if self.tmp.is_none() {
            let folder =
                TempFolder::create(&self.target).map_err(|e| Error::io(&self.target, e))?;
            self.tmp = Some(folder);
        }
        let dir = self
            .tmp
            .as_ref()
            .map(TempFolder::path)
            .unwrap_or(Path::new("."));
        let file = format!("mesh_{i:04}.ply");
        let path = dir.join(&file);
        match g {
            Geometry::Triangles(m) => super::super::ply::write(
                &path,
                &m.positions,
                m.normals.as_deref(),
                m.uvs.as_deref(),
                &m.indices,
                &[],
            )?,
            Geometry::Quads(q) => {
                super::super::ply::write(&path, &q.positions, None, None, &[], &q.indices)?
            }
            Geometry::Sphere(Sphere { .. }) => unreachable!("spheres are written inline"),
        }
        Ok(format!("{}/{file}", self.name))
    }

    /// Swaps the new meshes in: an old folder (checked again: only meshes) aside, the new
    /// one in place, the old meshes removed.
    pub(super) fn install(self) -> Result<()> {
        let Some(tmp) = self.tmp else {
            return Ok(());
        };
        existing_meshes(&self.target)?;
        let old = tmp
            .install(&self.target)
            .map_err(|e| Error::io(&self.target, e))?;
        if let Some(old) = old {
            // Only what was checked; a file added since stays, in the hidden folder.
            for mesh in existing_meshes(&old).unwrap_or_default() {
                let _ = std::fs::remove_file(mesh);
            }
            let _ = std::fs::remove_dir(&old);
            crate::atomic_file::unlist_folder(&old);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn mesh_names() {
        assert!(super::is_mesh_name("mesh_0007.ply") && super::is_mesh_name("mesh_12345.ply"));
        for other in ["mesh_.ply", "mesh_0007.obj", "bunny.ply", "mesh_00a1.ply"] {
            assert!(!super::is_mesh_name(other), "{other}");
        }
    }
}
