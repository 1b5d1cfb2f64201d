//! One rule for every file raylink writes: before any work, each path a run will write
//! (images, auxiliary images, checkpoints, caches, networks, CSVs, retrace maps, converted
//! scenes and their mesh folders) is compared with every path it reads and with every other
//! path it writes, as files: the folder's canonical path and the name (so `./a.png` and
//! `a.png` are one file), the target of a symbolic link, and the device and inode of a file
//! that exists (a hard link is the same file). A collision is bad input, refused with one
//! line naming both, before anything is written.
//!
//! The rule is listed for users in `docs/robustness.md` ("Files").

use crate::error::{Error, Result};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// A path as the file system resolves it, for comparing.
#[derive(Debug)]
struct Resolved {
    /// The canonical folder (as far as it exists) and the name: the file the name gives,
    /// followed through no final symbolic link.
    name: PathBuf,
    /// The canonical path of a file that exists (every symbolic link followed).
    target: Option<PathBuf>,
    /// Device and inode of a file that exists.
    id: Option<(u64, u64)>,
}

impl Resolved {
    fn of(path: &Path) -> Resolved {
        let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
        let name = match (abs.parent(), abs.file_name()) {
            (Some(dir), Some(name)) => canonical_prefix(dir).join(name),
            _ => canonical_prefix(&abs),
        };
        Resolved {
            name,
            target: path.canonicalize().ok(),
            id: file_id(path),
        }
    }

    /// The paths this file is known by.
    fn paths(&self) -> impl Iterator<Item = &PathBuf> {
        std::iter::once(&self.name).chain(&self.target)
    }
}

/// The device and inode of an existing file, which name it whatever path reaches it; `None`
/// off Unix, where the canonical paths alone tell files apart.
fn file_id(path: &Path) -> Option<(u64, u64)> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
    }
    #[cfg(not(unix))]
    {
        let _ = path;
        None
    }
}

/// `dir` canonicalised as far as it exists, the rest of it appended as given (a folder an
/// output is written into may not exist yet).
fn canonical_prefix(dir: &Path) -> PathBuf {
    if let Ok(c) = dir.canonicalize() {
        return c;
    }
    match (dir.parent(), dir.file_name()) {
        (Some(parent), Some(name)) => canonical_prefix(parent).join(name),
        _ => dir.to_path_buf(),
    }
}

struct Entry {
    what: String,
    path: PathBuf,
    resolved: Resolved,
    /// A folder written as a whole: whatever lies under it is replaced with it.
    folder: bool,
    /// A file written that is read first (a cache, a network): another write to it would
    /// overwrite an input.
    also_read: bool,
}

/// The files one run reads and writes, checked together by [`FilePlan::check`].
#[derive(Default)]
pub struct FilePlan {
    reads: Vec<Entry>,
    writes: Vec<Entry>,
}

impl FilePlan {
    pub fn new() -> FilePlan {
        FilePlan::default()
    }

    /// A file the run reads; `what` names it in messages ("the scene", "a part to merge").
    pub fn read(&mut self, what: impl Into<String>, path: &Path) -> &mut FilePlan {
        self.reads.push(entry(what.into(), path, false));
        self
    }

    /// Files the run reads, all called `what`.
    pub fn reads<'a>(
        &mut self,
        what: &str,
        paths: impl IntoIterator<Item = &'a PathBuf>,
    ) -> &mut FilePlan {
        for p in paths {
            self.read(what, p);
        }
        self
    }

    /// A file the run writes (and may read first, as a network file it relights); `what`
    /// names it in messages, by its option where it has one ("-o", "--csv").
    pub fn write(&mut self, what: impl Into<String>, path: &Path) -> &mut FilePlan {
        self.writes.push(entry(what.into(), path, false));
        self
    }

    /// Files the run writes, all called `what`.
    pub fn writes<'a>(
        &mut self,
        what: &str,
        paths: impl IntoIterator<Item = &'a PathBuf>,
    ) -> &mut FilePlan {
        for p in paths {
            self.write(what, p);
        }
        self
    }

    /// A file the run reads if it exists, and writes (a cache or network file).
    pub fn read_write(&mut self, what: impl Into<String>, path: &Path) -> &mut FilePlan {
        let mut e = entry(what.into(), path, false);
        e.also_read = true;
        self.writes.push(e);
        self
    }

    /// A folder the run replaces as a whole (convert's mesh folder): no input may lie in it.
    pub fn write_folder(&mut self, what: impl Into<String>, path: &Path) -> &mut FilePlan {
        self.writes.push(entry(what.into(), path, true));
        self
    }

    /// [`Error::Invalid`] naming the first written path that is a file read, another
    /// written path, or a folder holding a file read.
    pub fn check(&self) -> Result<()> {
        for w in &self.writes {
            check_name_lengths(w)?;
        }
        // By every path and id a file is known by, its first entry: reads first, so that a
        // write meeting a read says what it would overwrite.
        let mut seen: HashMap<Key, (bool, usize)> = HashMap::new();
        for (i, r) in self.reads.iter().enumerate() {
            for key in keys(&r.resolved) {
                seen.entry(key).or_insert((true, i));
            }
        }
        for (i, w) in self.writes.iter().enumerate() {
            let clash = keys(&w.resolved).find_map(|k| seen.get(&k).copied());
            if let Some((is_read, j)) = clash {
                return Err(if is_read {
                    overwrites(w, &self.reads[j])
                } else if self.writes[j].also_read {
                    overwrites(w, &self.writes[j])
                } else {
                    same_file(w, &self.writes[j])
                });
            }
            for key in keys(&w.resolved) {
                seen.entry(key).or_insert((false, i));
            }
        }
        for folder in self.writes.iter().filter(|w| w.folder) {
            let inside = |e: &Entry| {
                e.resolved
                    .paths()
                    .any(|p| folder.resolved.paths().any(|f| p.starts_with(f) && p != f))
            };
            if let Some(r) = self.reads.iter().find(|r| inside(r)) {
                return Err(Error::Invalid(format!(
                    "{}: {} would replace the folder holding one of the inputs ({} {}); it \
                     would be overwritten",
                    folder.path.display(),
                    folder.what,
                    r.what,
                    r.path.display()
                )));
            }
            if let Some(w) = self.writes.iter().find(|w| inside(w)) {
                return Err(same_file(w, folder));
            }
        }
        Ok(())
    }
}

/// The longest name a file system takes for one file or folder (`NAME_MAX` on Linux).
pub const MAX_NAME_BYTES: usize = 255;

/// Refuses a written path with a file or folder name longer than [`MAX_NAME_BYTES`], which
/// no file system would take once the work was done.
fn check_name_lengths(w: &Entry) -> Result<()> {
    match w
        .path
        .iter()
        .find(|c| c.as_encoded_bytes().len() > MAX_NAME_BYTES)
    {
        Some(long) => Err(Error::Invalid(format!(
            "{}: {} has a name of {} bytes; file systems take at most {MAX_NAME_BYTES}",
            w.path.display(),
            w.what,
            long.as_encoded_bytes().len()
        ))),
        None => Ok(()),
    }
}

fn entry(what: String, path: &Path, folder: bool) -> Entry {
    Entry {
        what,
        path: path.to_path_buf(),
        resolved: Resolved::of(path),
        folder,
        also_read: false,
    }
}

#[derive(Hash, PartialEq, Eq)]
enum Key {
    Path(PathBuf),
    Id(u64, u64),
}

fn keys(r: &Resolved) -> impl Iterator<Item = Key> + '_ {
    r.paths()
        .map(|p| Key::Path(p.clone()))
        .chain(r.id.map(|(dev, ino)| Key::Id(dev, ino)))
}

fn overwrites(w: &Entry, r: &Entry) -> Error {
    Error::Invalid(format!(
        "{}: {} is one of the inputs ({} {}); it would be overwritten",
        w.path.display(),
        w.what,
        r.what,
        r.path.display()
    ))
}

fn same_file(w: &Entry, other: &Entry) -> Error {
    Error::Invalid(format!(
        "{}: {} is the same file as {} ({}); one would overwrite the other",
        w.path.display(),
        w.what,
        other.what,
        other.path.display()
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_are_compared_as_files() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::create_dir(d.join("sub")).unwrap();
        std::fs::write(d.join("mesh.obj"), b"v 0 0 0").unwrap();
        std::fs::hard_link(d.join("mesh.obj"), d.join("hard.obj")).unwrap();
        std::os::unix::fs::symlink(d.join("mesh.obj"), d.join("soft.obj")).unwrap();
        let check = |write: &Path| {
            let mut plan = FilePlan::new();
            plan.read("the mesh", &d.join("mesh.obj"));
            plan.write("-o", write);
            plan.check()
        };
        for same in ["mesh.obj", "sub/../mesh.obj", "./hard.obj", "soft.obj"] {
            let e = check(&d.join(same)).unwrap_err().to_string();
            assert!(
                e.contains("-o is one of the inputs (the mesh"),
                "{same}: {e}"
            );
        }
        assert!(check(&d.join("sub/mesh.obj")).is_ok());
        assert!(check(&d.join("new/deeper/mesh.obj")).is_ok());

        let mut plan = FilePlan::new();
        plan.write("-o", &d.join("f_1.png"));
        plan.write("--csv", &d.join("sub/../f_1.png"));
        let e = plan.check().unwrap_err().to_string();
        assert!(e.contains("--csv is the same file as -o"), "{e}");

        let mut plan = FilePlan::new();
        plan.read("the mesh", &d.join("sub/../mesh.obj"));
        plan.write_folder("the mesh folder", &d.join("sub/.."));
        let e = plan.check().unwrap_err().to_string();
        assert!(e.contains("would replace the folder holding"), "{e}");
    }
}
