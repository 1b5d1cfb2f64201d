//! Cache files, so that later views of a scene reuse its values (section 3.3, last
//! paragraph). Little-endian binary:
//!
//! ```text
//! magic  "RLIRRAD\0"            8 bytes
//! version u32 (= 5)
//! scene hash u64                FNV-1a of the scene's geometry, materials and lights
//! bounces u32, accuracy f32, samples u32, ar f32, ambient 3×f32, gradients u32 (0 or 1)
//! per level (bounces of them): count u64, then count records of 28 f32
//!                               (position 3, normal 3, irradiance 3, R, then the
//!                               translational and rotational gradients, 3 per channel)
//! view u64                      0, or the key of the render view whose overture the cache
//!                               holds complete (`raylink precompute`; crate::farm)
//! checksum u64                  of every byte before it (crate::binary_file)
//! ```
//!
//! Records are stored per level in insertion order and re-inserted in that order, so a loaded
//! cache is the same tree as the one saved. Files are written atomically
//! (crate::binary_file). Version 1 differed only in its checksum, version 2 had no view key,
//! version 3 no gradients, version 4 values computed without glossy interreflection.

use super::gradients::Gradients;
use super::octree::Octree;
use super::record::Record;
use super::{scene_cube, Cache, IcOptions};
use crate::binary_file::{fnv1a, Format};
use crate::error::Result;
use crate::math::Vec3;
use crate::scene::Scene;
use std::path::Path;

pub const VERSION: u32 = 5;
/// Bytes of one record: 28 f32.
const RECORD_BYTES: usize = 28 * 4;
pub(crate) const FORMAT: Format = Format {
    magic: b"RLIRRAD\0",
    version: VERSION,
    what: "irradiance cache",
};

/// A hash of what the cached values depend on in the scene (not the camera).
pub fn scene_hash(scene: &Scene) -> u64 {
    let mut text = format!(
        "{:?}|{:?}|{:?}|{:?}|{:?}",
        scene.materials,
        scene.shapes,
        scene.lights,
        scene.background,
        scene.environment.as_ref().map(|e| format!("{e:?}").len())
    );
    if scene.has_instances() {
        text += &format!("|{:?}|{:?}", scene.prototypes, scene.instances);
    }
    fnv1a(text.as_bytes())
}

/// What follows the version: the scene hash and the options.
pub(crate) fn header(scene: &Scene, options: &IcOptions) -> Vec<u8> {
    let mut b = Vec::new();
    b.extend_from_slice(&scene_hash(scene).to_le_bytes());
    b.extend_from_slice(&options.bounces.to_le_bytes());
    b.extend_from_slice(&options.accuracy.to_le_bytes());
    b.extend_from_slice(&options.samples.to_le_bytes());
    b.extend_from_slice(&options.ar.to_le_bytes());
    for c in options.ambient.to_array() {
        b.extend_from_slice(&c.to_le_bytes());
    }
    b.extend_from_slice(&u32::from(options.gradients).to_le_bytes());
    b
}

/// Writes the cache to `path` atomically, marked with no view (for tests: the irradiance
/// cache technique saves with [`save_for_view`]).
#[cfg(test)]
pub fn save(path: &Path, cache: &Cache, scene: &Scene, options: &IcOptions) -> Result<()> {
    save_for_view(path, cache, scene, options, 0)
}

/// Writes the cache to `path` atomically, marked as holding the whole overture of the render
/// view `view` (a nonzero key; 0 marks none): a render of that view can use it as it is.
pub fn save_for_view(
    path: &Path,
    cache: &Cache,
    scene: &Scene,
    options: &IcOptions,
    view: u64,
) -> Result<()> {
    let mut b = FORMAT.try_start(RECORD_BYTES * cache.len(), path)?;
    b.extend_from_slice(&header(scene, options));
    for level in &cache.levels {
        b.extend_from_slice(&(level.len() as u64).to_le_bytes());
        for r in level.records() {
            let g = &r.grad;
            let vectors = [r.p, r.n, r.e]
                .into_iter()
                .chain(g.translation)
                .chain(g.rotation);
            for (i, v) in vectors.enumerate() {
                for x in v.to_array() {
                    b.extend_from_slice(&x.to_le_bytes());
                }
                if i == 2 {
                    b.extend_from_slice(&r.r.to_le_bytes());
                }
            }
        }
    }
    b.extend_from_slice(&view.to_le_bytes());
    FORMAT.save(path, b)
}

/// Reads a cache written by [`save_for_view`] for the same scene and options. Any other file
/// is an [`Error::Input`](crate::error::Error::Input) naming it.
pub fn load(path: &Path, scene: &Scene, options: &IcOptions) -> Result<Cache> {
    load_with_view(path, scene, options).map(|(cache, _)| cache)
}

/// As [`load`], also returning the view key the file was saved with (`None` for 0).
pub fn load_with_view(
    path: &Path,
    scene: &Scene,
    options: &IcOptions,
) -> Result<(Cache, Option<u64>)> {
    let file = FORMAT.load(path, &crate::input_file::IRRADIANCE_CACHE)?;
    let body = file.body();
    let bad = |problem: &str| FORMAT.error(path, problem);
    let expected = header(scene, options);
    if body.len() < expected.len() {
        return Err(bad("truncated header"));
    }
    if body[..8] != expected[..8] {
        return Err(bad("written for another scene"));
    }
    if body[..expected.len()] != expected[..] {
        return Err(bad(
            "written with other cache settings (ab, ic_accuracy, ic_samples, ar or \
             ic_gradients)",
        ));
    }
    let mut rest = &body[expected.len()..];
    let mut cache = Cache::new(scene, options);
    let (center, side) = scene_cube(scene);
    for (l, level) in cache.levels.iter_mut().enumerate() {
        if rest.len() < 8 {
            return Err(bad("truncated"));
        }
        let count = u64::from_le_bytes(rest[..8].try_into().unwrap());
        rest = &rest[8..];
        if count > (rest.len() / RECORD_BYTES) as u64 {
            return Err(bad("truncated"));
        }
        let mut tree = Octree::new(center, side, options.accuracy_at(l as u32));
        for _ in 0..count {
            let f: Vec<f32> = rest[..RECORD_BYTES]
                .chunks_exact(4)
                .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
                .collect();
            rest = &rest[RECORD_BYTES..];
            let v = |i: usize| Vec3::new(f[i], f[i + 1], f[i + 2]);
            let rec = Record {
                p: v(0),
                n: v(3),
                e: v(6),
                r: f[9],
                grad: Gradients {
                    translation: [v(10), v(13), v(16)],
                    rotation: [v(19), v(22), v(25)],
                },
            };
            // Gradients only where the settings compute them.
            if !options.gradients && rec.grad != Gradients::default() {
                return Err(bad(&format!(
                    "value {} of bounce level {l} has gradients, but the cache settings \
                     compute none",
                    tree.len()
                )));
            }
            // Finite values, a unit normal, irradiance that is not negative, a radius within
            // the scene's cube, and a point inside it: anything else no render computes.
            let inside = (rec.p - center).abs().max_element() <= side;
            let unit = (rec.n.length() - 1.0).abs() < 1e-3;
            if !(f.iter().all(|v| v.is_finite())
                && rec.r > 0.0
                && rec.r <= side
                && rec.e.min_element() >= 0.0
                && unit
                && inside)
            {
                return Err(bad(&format!(
                    "value {} of bounce level {l} is not one a render computes (a point \
                     outside the scene, a normal not of unit length, negative irradiance or a \
                     radius out of range)",
                    tree.len()
                )));
            }
            tree.insert(rec);
        }
        *level = tree;
    }
    if rest.len() < 8 {
        return Err(bad("truncated"));
    }
    let view = u64::from_le_bytes(rest[..8].try_into().unwrap());
    if rest.len() > 8 {
        return Err(bad("trailing data"));
    }
    Ok((cache, (view != 0).then_some(view)))
}
