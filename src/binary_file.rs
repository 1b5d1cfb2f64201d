//! raylink's own binary files (irradiance caches, illumination networks): an 8-byte magic, a
//! u32 format version, the body, and a u64 checksum of everything before it, all
//! little-endian. Files are written atomically ([`crate::atomic_file`]).

use crate::error::{Error, Result};
use crate::input_file;
use std::path::Path;

/// One kind of file.
pub struct Format {
    pub magic: &'static [u8; 8],
    pub version: u32,
    /// What the file holds, for messages ("irradiance cache").
    pub what: &'static str,
}

/// FNV-1a over bytes: scene hashes.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h = 0xcbf29ce484222325u64;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x100000001b3);
    }
    h
}

/// The file checksum: FNV-1a over little-endian 64-bit words (the tail zero-padded), eight
/// times fewer steps than over bytes for files of hundreds of megabytes.
pub fn checksum(bytes: &[u8]) -> u64 {
    let mut h = 0xcbf29ce484222325u64;
    let mut words = bytes.chunks_exact(8);
    for w in &mut words {
        h ^= u64::from_le_bytes(w.try_into().unwrap());
        h = h.wrapping_mul(0x100000001b3);
    }
    let mut tail = [0u8; 8];
    tail[..words.remainder().len()].copy_from_slice(words.remainder());
    h ^= u64::from_le_bytes(tail);
    h.wrapping_mul(0x100000001b3) ^ bytes.len() as u64
}

/// A file read by [`Format::load`]: its magic, version and checksum were right.
pub struct Loaded {
    bytes: Vec<u8>,
}

impl Loaded {
    /// What follows the version, without the checksum.
    pub fn body(&self) -> &[u8] {
        &self.bytes[12..self.bytes.len() - 8]
    }
}

impl Format {
    /// A buffer holding the magic and version: append the body, then [`Format::save`].
    pub fn start(&self, capacity: usize) -> Vec<u8> {
        let mut b = Vec::with_capacity(capacity + 20);
        b.extend_from_slice(self.magic);
        b.extend_from_slice(&self.version.to_le_bytes());
        b
    }

    /// As [`Format::start`] for writing `path`, or [`Error::OutOfMemory`] if the buffer cannot
    /// be allocated (a huge film or network).
    pub fn try_start(&self, capacity: usize, path: &Path) -> Result<Vec<u8>> {
        let mut b = Vec::new();
        crate::platform::try_reserve(&mut b, capacity.saturating_add(20), || {
            format!("writing the {} {}", self.what, path.display())
        })?;
        b.extend_from_slice(self.magic);
        b.extend_from_slice(&self.version.to_le_bytes());
        Ok(b)
    }

    /// Appends the checksum to a buffer made by [`Format::start`] and writes it atomically.
    pub fn save(&self, path: &Path, mut bytes: Vec<u8>) -> Result<()> {
        let sum = checksum(&bytes);
        bytes.extend_from_slice(&sum.to_le_bytes());
        crate::atomic_file::write(path, &bytes)
    }

    /// The one-line error for a file of this kind that cannot be used.
    pub fn error(&self, path: &Path, problem: &str) -> Error {
        Error::input(path, format!("not a usable {}: {problem}", self.what))
    }

    /// Reads `path`, a regular file within `kind`'s limit and the machine's memory budget,
    /// and checks its magic, version and checksum.
    pub fn load(&self, path: &Path, kind: &input_file::Kind) -> Result<Loaded> {
        self.load_within(path, kind, &input_file::Allowance::machine())
    }

    /// [`Format::load`] within a job's memory: the file's bytes, all held while it is
    /// checked, count against `allowance`.
    pub fn load_within(
        &self,
        path: &Path,
        kind: &input_file::Kind,
        allowance: &input_file::Allowance,
    ) -> Result<Loaded> {
        let bytes = input_file::read(path, kind, Some(allowance))?;
        if bytes.len() < 12 || &bytes[..8] != self.magic {
            return Err(self.error(path, &format!("no raylink {} header", self.what)));
        }
        let version = u32::from_le_bytes(bytes[8..12].try_into().unwrap());
        if version != self.version {
            return Err(self.error(
                path,
                &format!(
                    "format version {version}, this raylink reads {}",
                    self.version
                ),
            ));
        }
        if bytes.len() < 20 {
            return Err(self.error(path, "truncated"));
        }
        let (data, tail) = bytes.split_at(bytes.len() - 8);
        if checksum(data) != u64::from_le_bytes(tail.try_into().unwrap()) {
            return Err(self.error(path, "checksum mismatch (truncated or corrupt)"));
        }
        Ok(Loaded { bytes })
    }
}

/// Reads little-endian values from the front of a byte slice.
pub struct Reader<'a> {
    pub rest: &'a [u8],
}

impl Reader<'_> {
    pub fn take<const N: usize>(&mut self) -> Option<[u8; N]> {
        if self.rest.len() < N {
            return None;
        }
        let (a, b) = self.rest.split_at(N);
        self.rest = b;
        a.try_into().ok()
    }

    pub fn u32(&mut self) -> Option<u32> {
        self.take::<4>().map(u32::from_le_bytes)
    }

    pub fn u64(&mut self) -> Option<u64> {
        self.take::<8>().map(u64::from_le_bytes)
    }

    pub fn f32(&mut self) -> Option<f32> {
        self.take::<4>().map(f32::from_le_bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_damage() {
        let dir = std::env::temp_dir().join(format!("raylink-binfile-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("x.bin");
        let format = Format {
            magic: b"RLTEST\0\0",
            version: 3,
            what: "test file",
        };
        let mut b = format.start(5);
        b.extend_from_slice(b"hello");
        format.save(&path, b).unwrap();
        let kind = input_file::CHECKPOINT;
        assert_eq!(format.load(&path, &kind).unwrap().body(), b"hello");
        let other = Format {
            version: 4,
            ..format
        };
        let e = other.load(&path, &kind).err().unwrap().to_string();
        assert!(e.contains("x.bin") && e.contains("format version 3"), "{e}");
        let mut bytes = std::fs::read(&path).unwrap();
        bytes[13] ^= 1;
        std::fs::write(&path, &bytes).unwrap();
        let e = format.load(&path, &kind).err().unwrap().to_string();
        assert!(e.contains("checksum"), "{e}");
        std::fs::write(&path, b"RLTEST").unwrap();
        assert!(format.load(&path, &kind).is_err());
        // Nothing but the file itself is left in the directory.
        let names: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
        assert_eq!(names.len(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
