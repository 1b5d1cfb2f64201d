//! Render checkpoints: a Monte Carlo film saved between tiles, so that an interrupted render
//! can be resumed (`raylink render --resume`) to exactly the image an uninterrupted render
//! would have made. Little-endian binary in raylink's container (`binary_file.rs`):
//!
//! ```text
//! magic "RLCHKPT\0", version u32 (= 2)
//! settings  u64 length + UTF-8       everything the pixels depend on (scene hash, options)
//! width u32, height u32
//! spp u32, pass u32, tiles_done u32  finished passes; the pass in progress and its tiles done
//! invalid u64, samples u64           dropped samples; camera samples taken
//! sums   width·height × 3 f64        per pixel: sum of its sample estimates (weighted)
//! weights width·height × f64         per pixel: sum of its splatted samples' weights
//! splats width·height × 3 f64        per pixel: filter-weighted light-path splats
//! with per-pixel statistics only (adaptive sampling, or kept for the variance layers):
//!   counts  width·height × u32       per pixel: samples taken
//!   squares width·height × 3 f64     per pixel: sum of its samples' squares
//!   active  width·height × u8        per pixel: 1 if it takes the next pass's samples
//!   and when samples are splatted over neighbouring pixels (statistics without adaptive
//!   sampling):
//!   own     width·height × 3 f64     per pixel: sum of its own samples' values
//! with a technique's own per-pixel state (stochastic progressive photon mapping):
//!   state   width·height × n f64     per pixel: its n values
//! checksum u64
//! ```
//!
//! The filter is part of the settings string; the film's float sums are stored exactly.

use super::Film;
use crate::binary_file::{Format, Reader};
use crate::error::Result;
use crate::input_file::{self, Allowance};
use std::path::{Path, PathBuf};

/// Bytes a pixel's film values take, its sample statistics, and the sums of its own
/// samples.
const FILM_BYTES: usize = 56;
const STATS_BYTES: usize = 4 + 24 + 1;
const OWN_BYTES: usize = 24;

/// Bytes a pixel of `film` takes in a checkpoint: its values, and its statistics if the
/// film keeps them.
fn bytes_per_pixel(film: &Film) -> usize {
    FILM_BYTES
        + 8 * film.state_len
        + film.statistics().map_or(0, |s| {
            STATS_BYTES + if s.sums.is_empty() { 0 } else { OWN_BYTES }
        })
}

pub(crate) const FORMAT: Format = Format {
    magic: b"RLCHKPT\0",
    version: 2,
    what: "render checkpoint",
};

/// `OUTPUT.checkpoint`, or with `key`, `OUTPUT.KEY.checkpoint`.
fn named(output: &Path, key: Option<&str>) -> PathBuf {
    let mut name = output.file_name().unwrap_or_default().to_os_string();
    if let Some(key) = key {
        name.push(format!(".{key}"));
    }
    name.push(".checkpoint");
    output.with_file_name(name)
}

/// A short key of a render's settings, for its checkpoint's name.
fn key(settings: &str) -> String {
    format!(
        "{:08x}",
        crate::binary_file::fnv1a(settings.as_bytes()) as u32
    )
}

/// The two names [`path_for`] chooses from, for checking them against the run's other
/// files before it looks at them.
pub fn names(output: &Path, settings: &str) -> [PathBuf; 2] {
    [named(output, None), named(output, Some(&key(settings)))]
}

/// Where a render writing `output` with `settings` keeps its checkpoint: beside the output,
/// `OUTPUT.checkpoint`, unless a checkpoint of another render (other settings or seed) is
/// there: then `OUTPUT.KEY.checkpoint` with a key of the settings, so that no render
/// overwrites another's. A file at that name that is not a checkpoint (which the render
/// would overwrite, then remove) is an error naming it.
pub fn path_for(output: &Path, settings: &str) -> Result<PathBuf> {
    path_for_within(output, settings, &Allowance::machine())
}

/// [`path_for`] within a job's memory: a checkpoint found at the name is read whole, its
/// bytes counted against `allowance`.
pub fn path_for_within(output: &Path, settings: &str, allowance: &Allowance) -> Result<PathBuf> {
    let plain = named(output, None);
    let ours = |path: &Path| -> Result<bool> {
        if path.symlink_metadata().is_err() {
            return Ok(true);
        }
        let found = settings_of(path, allowance).map_err(|e| match e {
            crate::error::Error::Input { path, detail } => crate::error::Error::input(
                path,
                format!(
                    "{detail}; the render keeps its checkpoint at this name (move the file or \
                     choose another output)"
                ),
            ),
            other => other,
        })?;
        Ok(found == settings)
    };
    if ours(&plain)? {
        return Ok(plain);
    }
    let keyed = named(output, Some(&key(settings)));
    if ours(&keyed)? {
        return Ok(keyed);
    }
    Err(FORMAT.error(
        &keyed,
        "written by a render with other settings whose key is the same (move it)",
    ))
}

/// The checkpoint a resume of the render writing `output` with `settings` reads, if any:
/// `OUTPUT.checkpoint` when that render wrote it, else its keyed one. A checkpoint of
/// another render with no keyed one beside it is an error saying so; a damaged one, an
/// error naming it.
pub fn find(output: &Path, settings: &str) -> Result<Option<PathBuf>> {
    find_within(output, settings, &Allowance::machine())
}

/// [`find`] within a job's memory: each checkpoint looked at is read whole, its bytes
/// counted against `allowance`.
pub fn find_within(
    output: &Path,
    settings: &str,
    allowance: &Allowance,
) -> Result<Option<PathBuf>> {
    let plain = named(output, None);
    let keyed = named(output, Some(&key(settings)));
    if !plain.exists() {
        return Ok(keyed.exists().then_some(keyed));
    }
    if settings_of(&plain, allowance)? == settings {
        return Ok(Some(plain));
    }
    if keyed.exists() {
        return Ok(Some(keyed));
    }
    Err(FORMAT.error(
        &plain,
        "written by a render with another scene or other options (resume with the options \
         of the interrupted run)",
    ))
}

/// The settings a checkpoint was written with (its checksum checked first).
fn settings_of(path: &Path, allowance: &Allowance) -> Result<String> {
    let file = FORMAT.load_within(path, &input_file::CHECKPOINT, allowance)?;
    let mut r = Reader { rest: file.body() };
    let bad = |problem: &str| FORMAT.error(path, problem);
    let len = r.u64().ok_or_else(|| bad("truncated"))?;
    if len > r.rest.len() as u64 {
        return Err(bad("truncated"));
    }
    String::from_utf8(r.rest[..len as usize].to_vec()).map_err(|_| bad("corrupt settings"))
}

/// Writes `film` atomically, with `settings` (a description of everything the pixels depend
/// on) to check a resume against.
pub fn save(path: &Path, film: &Film, settings: &str, samples: u64) -> Result<()> {
    // A program quitting at once (a second signal) waits for the checkpoint.
    let _keep = crate::atomic_file::finish_first();
    let (sums, weights, splats) = film.accumulators();
    let per_pixel = bytes_per_pixel(film);
    let mut b = FORMAT.try_start(settings.len() + per_pixel * sums.len() + 64, path)?;
    b.extend_from_slice(&(settings.len() as u64).to_le_bytes());
    b.extend_from_slice(settings.as_bytes());
    let (width, height) = film.size();
    let (pass, tiles_done) = film.pass_in_progress();
    for v in [width, height, film.spp, pass, tiles_done] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    b.extend_from_slice(&film.invalid.to_le_bytes());
    b.extend_from_slice(&samples.to_le_bytes());
    for c in sums.iter().flatten() {
        b.extend_from_slice(&c.to_le_bytes());
    }
    for w in weights {
        b.extend_from_slice(&w.to_le_bytes());
    }
    for c in splats.iter().flatten() {
        b.extend_from_slice(&c.to_le_bytes());
    }
    if let Some(stats) = film.statistics() {
        for n in &stats.counts {
            b.extend_from_slice(&n.to_le_bytes());
        }
        for c in stats.squares.iter().flatten() {
            b.extend_from_slice(&c.to_le_bytes());
        }
        b.extend(stats.active.iter().map(|&a| a as u8));
        for c in stats.sums.iter().flatten() {
            b.extend_from_slice(&c.to_le_bytes());
        }
    }
    for v in &film.state {
        b.extend_from_slice(&v.to_le_bytes());
    }
    FORMAT.save(path, b)
}

/// A film read back by [`load`], and the camera samples it had taken.
pub struct Resumed {
    pub film: Film,
    pub samples: u64,
}

/// Reads a checkpoint written by [`save`] for the same `settings` and film size (`blank`, a
/// new film of the render's size and filter, receives the values) of a render of `target`
/// samples per pixel. Any other file, or one whose counts that render never passes through,
/// is an [`Error::Input`](crate::error::Error::Input) naming it.
pub fn load(path: &Path, settings: &str, blank: Film, target: u32) -> Result<Resumed> {
    load_within(path, settings, blank, target, &Allowance::machine())
}

/// [`load`] within a job's memory: the file's bytes, read whole, count against
/// `allowance` (which holds the film they are restored into).
pub fn load_within(
    path: &Path,
    settings: &str,
    blank: Film,
    target: u32,
    allowance: &Allowance,
) -> Result<Resumed> {
    let bad = |problem: &str| FORMAT.error(path, problem);
    // A checkpoint of this film is its bytes a pixel and a settings string (another run's
    // may be longer): a file much larger is refused before it is read.
    let (w, h) = blank.size();
    let per_pixel = bytes_per_pixel(&blank);
    let most = (per_pixel as u64 * w as u64 * h as u64)
        .saturating_add(settings.len() as u64)
        .saturating_add(1 << 20);
    let size = input_file::check(path, &input_file::CHECKPOINT)?;
    if size > most {
        return Err(bad(&format!(
            "{size} bytes, more than a checkpoint of a {w}x{h} image holds"
        )));
    }
    let file = FORMAT.load_within(path, &input_file::CHECKPOINT, allowance)?;
    let mut r = Reader { rest: file.body() };
    let len = r.u64().ok_or_else(|| bad("truncated"))?;
    if len > r.rest.len() as u64 {
        return Err(bad("truncated"));
    }
    let (text, rest) = r.rest.split_at(len as usize);
    r.rest = rest;
    if text != settings.as_bytes() {
        return Err(bad(
            "written by a render with another scene or other options (resume with the \
             options of the interrupted run)",
        ));
    }
    let mut u = [0u32; 5];
    for v in &mut u {
        *v = r.u32().ok_or_else(|| bad("truncated"))?;
    }
    let [width, height, spp, pass, tiles_done] = u;
    if (width, height) != blank.size() {
        return Err(bad("written for another image size"));
    }
    let invalid = r.u64().ok_or_else(|| bad("truncated"))?;
    let samples = r.u64().ok_or_else(|| bad("truncated"))?;
    let pixels = width as usize * height as usize;
    // The statistics follow the film when the render samples adaptively or keeps them.
    if r.rest.len() != per_pixel * pixels {
        return Err(bad(
            if blank.state_len == 0 && r.rest.len() == FILM_BYTES * pixels {
                "holds no per-pixel sample statistics, and this render needs them (resume with \
             the options of the interrupted run)"
            } else if blank.statistics().is_none()
                && [STATS_BYTES, STATS_BYTES + OWN_BYTES]
                    .iter()
                    .any(|b| r.rest.len() == (FILM_BYTES + b) * pixels)
            {
                "holds per-pixel sample statistics, and this render has none"
            } else {
                "truncated or trailing data"
            },
        ));
    }
    let (film_bytes, rest) = r.rest.split_at(FILM_BYTES * pixels);
    // The technique's state comes last.
    let (rest, state) = rest.split_at(rest.len() - 8 * blank.state_len * pixels);
    let state: Vec<f64> = state
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
        .collect();
    let stats = blank.statistics().map(|kept| {
        let (counts, rest) = rest.split_at(4 * pixels);
        let (squares, rest) = rest.split_at(24 * pixels);
        let (active, own) = rest.split_at(pixels);
        let counts: Vec<u32> = counts
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes(c.try_into().unwrap_or([0; 4])))
            .collect();
        let f64_at = |c: &[u8]| f64::from_le_bytes(c.try_into().unwrap_or([0; 8]));
        let triples = |bytes: &[u8]| -> Vec<[f64; 3]> {
            bytes
                .chunks_exact(24)
                .map(|c| [f64_at(&c[..8]), f64_at(&c[8..16]), f64_at(&c[16..])])
                .collect()
        };
        let active: Vec<bool> = active.iter().map(|&a| a != 0).collect();
        let own = if kept.sums.is_empty() {
            Vec::new()
        } else {
            triples(own)
        };
        (counts, triples(squares), active, own)
    });
    let mut values = film_bytes
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap()));
    let mut next = || values.next().unwrap_or(f64::NAN);
    let sums: Vec<[f64; 3]> = (0..pixels).map(|_| [next(), next(), next()]).collect();
    let weights: Vec<f64> = (0..pixels).map(|_| next()).collect();
    let splats: Vec<[f64; 3]> = (0..pixels).map(|_| [next(), next(), next()]).collect();
    if sums
        .iter()
        .chain(&splats)
        .flatten()
        .chain(&weights)
        .any(|v| !v.is_finite())
    {
        return Err(bad("a pixel value is not finite"));
    }
    if samples > (spp as u64 + pass as u64) * pixels as u64 {
        return Err(bad("counts more samples than its passes hold"));
    }
    let film = blank
        .restored(
            (sums, weights, splats),
            (spp, pass, tiles_done, invalid),
            stats,
            state,
            target,
        )
        .map_err(|e| bad(&e))?;
    Ok(Resumed { film, samples })
}
