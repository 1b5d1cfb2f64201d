//! Opening the files raylink reads, by one rule for every reader: an input must be a regular
//! file, checked from its metadata before it is opened (a FIFO would block the reading until
//! some other program wrote to it, a device such as `/dev/zero` never ends, a directory or a
//! socket cannot be read), and no larger than its reader's fixed limit ([`Kind`]) nor, where
//! the reader knows the job's memory budget, than what the budget leaves ([`Allowance`]).
//! A file that breaks the rule is refused with one line naming it, before any of it is read.
//!
//! The limits are listed for users in `docs/robustness.md` ("Input files").

use crate::control::MemoryBudget;
use crate::error::{human_size, Error, Result};
use std::fs::{File, FileType};
use std::io::Read;
#[cfg(unix)]
use std::os::unix::fs::{FileTypeExt, OpenOptionsExt};
use std::path::Path;

const MIB: u64 = 1 << 20;
const GIB: u64 = 1 << 30;

/// What one reader takes: its files' name in messages and the most bytes it reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Kind {
    /// The files, plural, for messages ("OBJ files").
    pub files: &'static str,
    /// A fixed limit on the file's size in bytes.
    pub max_bytes: u64,
}

/// Native TOML scenes and animations.
pub const TOML_SCENE: Kind = Kind {
    files: "TOML scene files",
    max_bytes: 256 * MIB,
};
/// One pbrt scene file or included file (the text of a whole scene has its own limit,
/// `pbrt::MAX_SCENE_TEXT`).
pub const PBRT_SCENE: Kind = Kind {
    files: "pbrt scene files",
    max_bytes: GIB,
};
pub const OBJ: Kind = Kind {
    files: "OBJ files",
    max_bytes: 2 * GIB,
};
pub const MTL: Kind = Kind {
    files: "MTL files",
    max_bytes: 64 * MIB,
};
pub const PLY: Kind = Kind {
    files: "PLY files",
    max_bytes: 4 * GIB,
};
/// Tabulated BRDFs in raylink's text format.
pub const BRDF_TABLE: Kind = Kind {
    files: "tabulated BRDF files",
    max_bytes: 256 * MIB,
};
/// MERL measured BRDFs: every one is 12 + 3·90·90·180·8 bytes.
pub const MERL: Kind = Kind {
    files: "MERL BRDF files",
    max_bytes: 34_992_012,
};
/// NanoVDB volumes (their dense grids are bounded by `media::MAX_GRID_SAMPLES` as well).
pub const NANOVDB: Kind = Kind {
    files: "NanoVDB files",
    max_bytes: 4 * GIB,
};
/// Images: textures, environment maps, goniometric maps, render parts to merge, references.
/// What their header declares is checked as well (`image::output::MAX_IMAGE_VALUES`).
pub const IMAGE: Kind = Kind {
    files: "images",
    max_bytes: 2 * GIB,
};
pub const IRRADIANCE_CACHE: Kind = Kind {
    files: "irradiance-cache files",
    max_bytes: 16 * GIB,
};
pub const NETWORK: Kind = Kind {
    files: "illumination-network files",
    max_bytes: 64 * GIB,
};
/// Render checkpoints; a resume also bounds the file by the film it restores.
pub const CHECKPOINT: Kind = Kind {
    files: "checkpoints",
    max_bytes: 64 * GIB,
};

/// The memory a read may take: the job's budget, of which `held` bytes are taken already.
#[derive(Clone, Copy, Debug)]
pub struct Allowance {
    pub budget: MemoryBudget,
    pub held: u64,
}

impl Allowance {
    pub fn new(budget: MemoryBudget, held: u64) -> Allowance {
        Allowance { budget, held }
    }

    /// The machine's default budget with nothing held: for a read outside any job.
    pub fn machine() -> Allowance {
        Allowance::new(MemoryBudget::default(), 0)
    }

    /// [`Error::Memory`] if `bytes` more would pass the budget; `what` names the reading.
    pub fn check(&self, what: &str, bytes: u64) -> Result<()> {
        self.budget.check(what, self.held.saturating_add(bytes))
    }
}

/// Why a file that is not a regular one cannot be read, for messages.
fn not_regular(t: FileType) -> &'static str {
    if t.is_dir() {
        "is a directory, not a regular file"
    } else {
        special_kind(t).unwrap_or("is not a regular file")
    }
}

/// The Unix special files by name (FIFOs, devices, sockets).
#[cfg(unix)]
fn special_kind(t: FileType) -> Option<&'static str> {
    if t.is_fifo() {
        Some("is a FIFO (named pipe), not a regular file")
    } else if t.is_char_device() {
        Some("is a character device, not a regular file")
    } else if t.is_block_device() {
        Some("is a block device, not a regular file")
    } else if t.is_socket() {
        Some("is a socket, not a regular file")
    } else {
        None
    }
}

#[cfg(not(unix))]
fn special_kind(_: FileType) -> Option<&'static str> {
    None
}

/// The size of a regular file of at most `kind.max_bytes`, or the refusal naming `path`.
fn checked_size(path: &Path, kind: &Kind, meta: &std::fs::Metadata) -> Result<u64> {
    let t = meta.file_type();
    if !t.is_file() {
        return Err(Error::input(path, not_regular(t)));
    }
    let size = meta.len();
    if size > kind.max_bytes {
        return Err(Error::input(
            path,
            format!(
                "is {}, more than raylink reads from {} ({}, a fixed limit)",
                human_size(size),
                kind.files,
                human_size(kind.max_bytes)
            ),
        ));
    }
    Ok(size)
}

/// Checks, from its metadata and without opening it, that `path` is a regular file within
/// `kind`'s limit; returns its size. A file that cannot be looked at is [`Error::Io`].
pub fn check(path: &Path, kind: &Kind) -> Result<u64> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    checked_size(path, kind, &meta)
}

/// Opens `path` for reading after [`check`]ing it, and checks what was opened again (the
/// name may have been given to another file in between): its open never blocks, even on a
/// FIFO. Returns the file and its size.
pub fn open(path: &Path, kind: &Kind) -> Result<(File, u64)> {
    check(path, kind)?;
    // O_NONBLOCK: opening a FIFO waits for a writer without it. It changes nothing for the
    // regular file that is read (checked below).
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    options.custom_flags(rustix::fs::OFlags::NONBLOCK.bits() as i32);
    let file = options.open(path).map_err(|e| Error::io(path, e))?;
    let meta = file.metadata().map_err(|e| Error::io(path, e))?;
    let size = checked_size(path, kind, &meta)?;
    Ok((file, size))
}

/// Reads the whole of `path` within `kind`'s limit and, with an `allowance`, the memory
/// budget (the file's bytes are what reading it takes).
pub fn read(path: &Path, kind: &Kind, allowance: Option<&Allowance>) -> Result<Vec<u8>> {
    let (file, size) = open(path, kind)?;
    if let Some(a) = allowance {
        a.check(&format!("reading {}", path.display()), size)?;
    }
    let mut bytes = Vec::new();
    crate::platform::try_reserve(&mut bytes, size as usize, || {
        format!("reading {}", path.display())
    })?;
    // Not trusting the size: the file may grow while it is read.
    file.take(kind.max_bytes + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(path, e))?;
    if bytes.len() as u64 > kind.max_bytes {
        return Err(Error::input(
            path,
            format!(
                "grew past {}, the most raylink reads from {} (a fixed limit), while it was \
                 read",
                human_size(kind.max_bytes),
                kind.files
            ),
        ));
    }
    Ok(bytes)
}

/// [`read`] as UTF-8 text; other bytes are an [`Error::Io`] of kind `InvalidData`, as the
/// standard library's `read_to_string` gives.
pub fn read_to_string(path: &Path, kind: &Kind, allowance: Option<&Allowance>) -> Result<String> {
    let bytes = read(path, kind, allowance)?;
    String::from_utf8(bytes).map_err(|_| {
        Error::io(
            path,
            std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                "stream did not contain valid UTF-8",
            ),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regular_files_within_the_limit_are_read_and_others_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.txt");
        std::fs::write(&path, b"hello").unwrap();
        assert_eq!(read(&path, &MTL, None).unwrap(), b"hello");
        let small = Kind {
            files: "test files",
            max_bytes: 4,
        };
        let e = read(&path, &small, None).unwrap_err().to_string();
        assert!(
            e.contains("a.txt: is 5 bytes, more than raylink reads"),
            "{e}"
        );
        let e = read(dir.path(), &MTL, None).unwrap_err().to_string();
        assert!(e.ends_with("is a directory, not a regular file"), "{e}");
        let e = read(Path::new("/dev/zero"), &MTL, None)
            .unwrap_err()
            .to_string();
        assert_eq!(e, "/dev/zero: is a character device, not a regular file");
        let budget = Allowance::new(MemoryBudget::bytes(10), 6);
        let e = read(&path, &MTL, Some(&budget)).unwrap_err();
        assert!(matches!(e, Error::Memory { needed: 11, .. }), "{e}");
        let missing = read(&dir.path().join("no"), &MTL, None).unwrap_err();
        assert!(matches!(missing, Error::Io { .. }), "{missing}");
    }
}
