//! Writing a file so that it is either untouched or complete: the bytes go to a temporary
//! file in the same directory, are synced, and the temporary file is renamed over the
//! target. A failed run never leaves a half-written file or damages the one it replaces.
//! A temporary file or folder is always a new one (created exclusively), so it never
//! replaces a file that was there.
//!
//! The temporary files and folders being written are listed process-wide (the one piece of
//! global state of the library), so that a program ended by a signal while writing can
//! remove them first: [`remove_temporaries`].

use crate::error::{Error, Result};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard};

/// A temporary file or folder this process is writing.
struct InFlight {
    path: PathBuf,
    folder: bool,
}

/// The temporary files and folders this process is writing.
static IN_FLIGHT: Mutex<Vec<InFlight>> = Mutex::new(Vec::new());

/// Held while a write that must not be lost (a checkpoint) is made: a program quitting at
/// once waits for it before removing the temporaries.
static FINISHING: Mutex<()> = Mutex::new(());

fn in_flight() -> MutexGuard<'static, Vec<InFlight>> {
    // A panic elsewhere while holding the lock leaves the list as valid as before.
    IN_FLIGHT.lock().unwrap_or_else(|e| e.into_inner())
}

/// A guard to hold while writing a file that a program quitting at once must not discard
/// (a checkpoint of the work so far): [`remove_temporaries`] waits for it.
pub fn finish_first() -> impl Drop {
    FINISHING.lock().unwrap_or_else(|e| e.into_inner())
}

/// Removes the temporary files this process is writing and returns holding the lock of
/// their list, so that no new one is created until the guard is dropped: for a program about
/// to end at once (on a second Ctrl-C), which keeps the guard until it exits. A write under
/// [`finish_first`] is waited for. Called from an ordinary thread (a signal-handling thread),
/// not from inside a signal handler.
pub fn remove_temporaries() -> impl Drop {
    let finishing = FINISHING.lock().unwrap_or_else(|e| e.into_inner());
    let list = in_flight();
    remove_all(&list);
    Held {
        _finishing: finishing,
        _list: list,
    }
}

/// The locks [`remove_temporaries`] returns holding.
struct Held {
    _finishing: MutexGuard<'static, ()>,
    _list: MutexGuard<'static, Vec<InFlight>>,
}

impl Drop for Held {
    fn drop(&mut self) {}
}

/// Removes the temporary files this process is writing, unless their list is being changed
/// (then nothing): for a process ending at once because memory ran out, which must not wait
/// for a lock this thread may hold.
pub(crate) fn remove_temporaries_if_free() {
    let list = match IN_FLIGHT.try_lock() {
        Ok(list) => list,
        Err(std::sync::TryLockError::Poisoned(e)) => e.into_inner(),
        Err(std::sync::TryLockError::WouldBlock) => return,
    };
    remove_all(&list);
}

fn remove_all(list: &[InFlight]) {
    // Files first: a writer renaming one into a listed folder then fails instead of adding
    // to the folder while it is removed.
    for t in list.iter().filter(|t| !t.folder) {
        let _ = std::fs::remove_file(&t.path);
    }
    for t in list.iter().filter(|t| t.folder) {
        let _ = std::fs::remove_dir_all(&t.path);
    }
}

/// Creates a new temporary file or folder beside `target` by `make` (which must fail if
/// the name exists), listed from its creation; a name taken by another file is skipped.
fn create_new<T>(
    target: &Path,
    folder: bool,
    make: impl Fn(&Path) -> std::io::Result<T>,
) -> std::io::Result<(PathBuf, T)> {
    let mut attempts = 0;
    loop {
        let path = temp_path(target);
        // Listed before it exists, and created under the lock: a removal by
        // `remove_temporaries` either comes before (then waits for the list) or sees it.
        let mut list = in_flight();
        match make(&path) {
            Ok(made) => {
                list.push(InFlight {
                    path: path.clone(),
                    folder,
                });
                return Ok((path, made));
            }
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && attempts < 100 => {
                attempts += 1;
            }
            Err(e) => return Err(e),
        }
    }
}

/// A temporary file beside `path`, created empty and listed while it exists; removed on drop
/// unless [`Temporary::persist`]ed (renamed over its target).
pub(crate) struct Temporary {
    path: PathBuf,
    file: std::fs::File,
}

impl Temporary {
    /// Creates a new temporary file for writing `target` (beside the file it names through
    /// any symbolic links: see [`through_links`]).
    pub(crate) fn create(target: &Path) -> std::io::Result<Temporary> {
        let (path, file) = create_new(&through_links(target), false, |p| {
            std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(p)
        })?;
        Ok(Temporary { path, file })
    }

    pub(crate) fn file(&mut self) -> &mut std::fs::File {
        &mut self.file
    }

    /// Syncs the file and renames it over `target` (the file a symbolic link `target` leads
    /// to, the link kept); on failure it is removed (on drop).
    pub(crate) fn persist(mut self, target: &Path) -> std::io::Result<()> {
        self.file.sync_all()?;
        std::fs::rename(&self.path, through_links(target))?;
        unlist(&self.path);
        self.path = PathBuf::new();
        Ok(())
    }
}

impl Drop for Temporary {
    fn drop(&mut self) {
        if !self.path.as_os_str().is_empty() {
            // Best effort: it may already be gone.
            let _ = std::fs::remove_file(&self.path);
            unlist(&self.path);
        }
    }
}

/// The file `path` leads to through symbolic links (each link's target taken relative to its
/// folder), which need not exist yet: an output that is a link is written through it, so
/// that the link stays and the file it names is replaced. A chain longer than the system's
/// limit (a loop) is left as it is, for the write to report.
pub(crate) fn through_links(path: &Path) -> PathBuf {
    let mut p = path.to_path_buf();
    for _ in 0..40 {
        match std::fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => match std::fs::read_link(&p) {
                Ok(next) => {
                    let dir = p.parent().unwrap_or(Path::new(""));
                    p = dir.join(next);
                }
                Err(_) => return p,
            },
            _ => return p,
        }
    }
    path.to_path_buf()
}

fn unlist(path: &Path) {
    unlist_in(&mut in_flight(), path);
}

fn unlist_in(list: &mut Vec<InFlight>, path: &Path) {
    if let Some(i) = list.iter().position(|t| t.path == path) {
        list.swap_remove(i);
    }
}

/// A new temporary folder beside `target`, listed while it exists (a program quitting at
/// once removes it); removed on drop unless [`TempFolder::install`]ed.
pub(crate) struct TempFolder {
    path: PathBuf,
}

impl TempFolder {
    pub(crate) fn create(target: &Path) -> std::io::Result<TempFolder> {
        let (path, ()) = create_new(target, true, |p| std::fs::create_dir(p))?;
        Ok(TempFolder { path })
    }

    pub(crate) fn path(&self) -> &Path {
        &self.path
    }

    /// Renames the folder to `target`. An existing `target` (a folder) is first renamed
    /// aside, under the list's lock so that a program quitting at once finds either the old
    /// folder or the new one in place; returns where the old one went, still listed as a
    /// temporary: the caller removes what it knows to be there, then [`unlist_folder`]s it.
    pub(crate) fn install(mut self, target: &Path) -> std::io::Result<Option<PathBuf>> {
        let mut list = in_flight();
        let old = if target.symlink_metadata().is_ok() {
            let old = temp_path(target);
            std::fs::rename(target, &old)?;
            list.push(InFlight {
                path: old.clone(),
                folder: true,
            });
            Some(old)
        } else {
            None
        };
        if let Err(e) = std::fs::rename(&self.path, target) {
            if let Some(old) = &old {
                let _ = std::fs::rename(old, target);
                unlist_in(&mut list, old);
            }
            return Err(e);
        }
        unlist_in(&mut list, &self.path);
        self.path = PathBuf::new();
        Ok(old)
    }
}

impl Drop for TempFolder {
    fn drop(&mut self) {
        if !self.path.as_os_str().is_empty() {
            let _ = std::fs::remove_dir_all(&self.path);
            unlist(&self.path);
        }
    }
}

/// Takes a folder off the list of temporaries (it has been removed, or is kept).
pub(crate) fn unlist_folder(path: &Path) {
    unlist(path);
}

/// What every temporary file's name starts with, then the writing process's id.
const TEMP_PREFIX: &str = ".raylink-tmp-";

/// A temporary file beside `path` for writing it: `.raylink-tmp-PID-N.EXT`, hidden, unique
/// per process and write, the target's extension kept (an image writer picks the format by
/// it) and short whatever the target's name (it always fits the file system's name limit
/// when the target's does).
pub(crate) fn temp_path(path: &Path) -> PathBuf {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let ext = path
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    parent(path).join(format!("{TEMP_PREFIX}{}-{n}{ext}", std::process::id()))
}

/// The directory holding `path` (`.` for a bare file name).
fn parent(path: &Path) -> &Path {
    path.parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
}

/// Removes the temporary files a raylink process that no longer runs left in `dir` (killed
/// while writing, by a second Ctrl-C say). Best effort: what cannot be read or removed stays.
pub(crate) fn remove_stale_temps(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(rest) = name.to_str().and_then(|n| n.strip_prefix(TEMP_PREFIX)) else {
            continue;
        };
        let Some(pid) = rest.split('-').next().and_then(|p| p.parse::<u32>().ok()) else {
            continue;
        };
        let alive = Path::new("/proc").join(pid.to_string()).exists();
        if !alive && pid != std::process::id() {
            // A folder of meshes being converted, or a file.
            let is_dir = entry.file_type().is_ok_and(|t| t.is_dir());
            let _ = if is_dir {
                std::fs::remove_dir_all(entry.path())
            } else {
                std::fs::remove_file(entry.path())
            };
        }
    }
}

/// Writes `bytes` to `path` atomically; errors name `path` and keep the operating system's
/// reason (a full disk is `No space left on device`). On failure nothing is left behind and
/// an existing `path` is unchanged.
pub fn write(path: &Path, bytes: &[u8]) -> Result<()> {
    let result = (|| {
        let mut temp = Temporary::create(path)?;
        temp.file().write_all(bytes)?;
        temp.persist(path)
    })();
    result.map_err(|e| Error::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temporary_names_are_short_hidden_and_keep_the_extension() {
        let long = "x".repeat(250) + ".exr";
        let t = temp_path(&Path::new("out").join(&long));
        let name = t.file_name().unwrap().to_string_lossy().into_owned();
        assert!(
            name.starts_with(".raylink-tmp-") && name.ends_with(".exr"),
            "{name}"
        );
        assert!(name.len() < 64, "{name}");
        assert_eq!(t.parent(), Some(Path::new("out")));
        assert_ne!(temp_path(Path::new("a.exr")), temp_path(Path::new("a.exr")));
    }

    /// A program quitting at once waits for a checkpoint being written, then removes the
    /// other temporaries; a temporary never takes the name of a file that is there.
    #[test]
    fn quitting_at_once_waits_for_a_write_that_must_finish() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("x.checkpoint");
        let (tx, rx) = std::sync::mpsc::channel();
        let t = target.clone();
        let writer = std::thread::spawn(move || {
            let _keep = finish_first();
            let mut temp = Temporary::create(&t).unwrap();
            tx.send(()).unwrap();
            std::thread::sleep(std::time::Duration::from_millis(300));
            temp.file().write_all(b"film").unwrap();
            temp.persist(&t).unwrap();
        });
        rx.recv().unwrap();
        let other = Temporary::create(&dir.path().join("y.exr")).unwrap();
        let other_path = other.path.clone();
        std::mem::forget(other);
        drop(remove_temporaries());
        writer.join().unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"film");
        assert!(!other_path.exists());
        unlist(&other_path);

        let folder = TempFolder::create(&dir.path().join("m.meshes")).unwrap();
        let kept = folder.path().to_path_buf();
        std::mem::forget(folder);
        drop(remove_temporaries());
        assert!(!kept.exists());
        unlist(&kept);
    }

    #[test]
    fn only_the_temporary_files_of_dead_processes_are_removed() {
        let dir = tempfile::tempdir().unwrap();
        // No process has a pid this large (the kernel's limit is 2^22).
        let dead = dir.path().join(".raylink-tmp-4294967294-0.exr");
        let ours = dir
            .path()
            .join(format!(".raylink-tmp-{}-7.exr", std::process::id()));
        let other = dir.path().join("render.exr");
        for f in [&dead, &ours, &other] {
            std::fs::write(f, b"x").unwrap();
        }
        remove_stale_temps(dir.path());
        assert!(!dead.exists() && ours.exists() && other.exists());
    }
}
