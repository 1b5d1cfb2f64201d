//! `raylink merge`: assembles parts of a render (EXR files written with `--tile` or `--crop`)
//! into the full image. Parts must come from the same scene with the same settings and seed,
//! have the same full size, and cover every pixel exactly once; anything else is refused with
//! one line naming the file.

use super::{META_REGION, META_SCENE_HASH, META_SETTINGS, META_TILE};
use crate::error::{Error, Result};
use crate::image::io::{self, RawImage};
use crate::image::{Image, MetaValue, Metadata};
use crate::math::Rgb;
use std::path::{Path, PathBuf};

/// The merged image and its metadata: the parts' common attributes (`Software` and the
/// `raylink:` ones), with render seconds and rays summed over the parts, samples per pixel
/// averaged over the image, and `raylink:merged_parts`.
pub struct Merged {
    pub image: Image,
    pub metadata: Metadata,
}

/// Attributes every part must agree on, with how to name them in a message.
const MUST_MATCH: [(&str, &str); 5] = [
    ("Software", "raylink version"),
    (META_SCENE_HASH, "scene"),
    ("raylink:integrator", "integrator"),
    ("raylink:seed", "seed"),
    (META_SETTINGS, "settings"),
];

fn shown(v: Option<&MetaValue>) -> String {
    match v {
        Some(MetaValue::Str(s)) => s.clone(),
        Some(MetaValue::Int(i)) => i.to_string(),
        Some(MetaValue::Float(f)) => f.to_string(),
        None => "none".into(),
    }
}

/// A part: its file, pixels and window.
struct Part {
    path: PathBuf,
    raw: RawImage,
}

fn read_part(path: &Path) -> Result<Part> {
    // An unreadable part is bad input (exit 2), as every unreadable image is.
    let raw = io::read(path)?;
    let bad = |detail: String| Error::input(path, detail);
    if raw.meta(META_SETTINGS).is_none() || raw.meta(META_SCENE_HASH).is_none() {
        return Err(bad(format!(
            "not a raylink render part (no {META_SETTINGS} or {META_SCENE_HASH} metadata)"
        )));
    }
    let w = raw.window;
    if w.full_x != 0 || w.full_y != 0 {
        return Err(bad(format!(
            "the full image starts at ({}, {}), not (0, 0)",
            w.full_x, w.full_y
        )));
    }
    let fits = w.x >= 0
        && w.y >= 0
        && w.x as u64 + raw.width as u64 <= w.full_width as u64
        && w.y as u64 + raw.height as u64 <= w.full_height as u64;
    if !fits {
        return Err(bad(format!(
            "its {}x{} pixels at ({}, {}) lie outside its {}x{} image",
            raw.width, raw.height, w.x, w.y, w.full_width, w.full_height
        )));
    }
    if !raw
        .channels
        .starts_with(&["R".into(), "G".into(), "B".into()])
    {
        return Err(bad(format!(
            "channels {:?}, expected R, G, B",
            raw.channels
        )));
    }
    Ok(Part {
        path: path.to_path_buf(),
        raw,
    })
}

/// Reads and assembles the parts; see the module documentation for what is refused.
pub fn merge(paths: &[PathBuf]) -> Result<Merged> {
    let Some(first_path) = paths.first() else {
        return Err(Error::Invalid("merge needs at least one part".into()));
    };
    let mut first_part = Some(read_part(first_path)?);
    // The first part's metadata, which every other part is compared with.
    let first = first_part.as_ref().map(|p| RawImage {
        data: Vec::new(),
        ..p.raw.clone()
    });
    let first = first.expect("just read");
    let (width, height) = (first.window.full_width, first.window.full_height);
    // Which part covers each pixel (u32::MAX: none yet).
    let mut owner = vec![u32::MAX; width as usize * height as usize];
    let mut image = Image::new(width, height);
    let mut parts: Vec<Part> = Vec::with_capacity(paths.len());
    for (index, path) in paths.iter().enumerate() {
        let part = match first_part.take() {
            Some(p) => p,
            None => read_part(path)?,
        };
        let bad = |detail: String| Error::input(path, detail);
        let w = part.raw.window;
        if (w.full_width, w.full_height) != (width, height) {
            return Err(bad(format!(
                "is part of a {}x{} image, but {} of a {width}x{height} one",
                w.full_width,
                w.full_height,
                first_path.display()
            )));
        }
        for (key, what) in MUST_MATCH {
            let (mine, theirs) = (part.raw.meta(key), first.meta(key));
            if mine != theirs {
                return Err(bad(format!(
                    "rendered with another {what} than {} ({key}: {} vs {})",
                    first_path.display(),
                    shown(mine),
                    shown(theirs)
                )));
            }
        }
        let n = part.raw.channels.len();
        for row in 0..part.raw.height {
            for col in 0..part.raw.width {
                let (x, y) = (w.x as u32 + col, w.y as u32 + row);
                let o = &mut owner[(y * width + x) as usize];
                if *o != u32::MAX {
                    return Err(bad(format!(
                        "overlaps {} at pixel ({x}, {y})",
                        paths[*o as usize].display()
                    )));
                }
                *o = index as u32;
                let v = &part.raw.data[((row * part.raw.width + col) as usize) * n..];
                image.set(x, y, Rgb::new(v[0], v[1], v[2]));
            }
        }
        // Keep the metadata, not the pixels.
        parts.push(Part {
            path: part.path,
            raw: RawImage {
                data: Vec::new(),
                ..part.raw
            },
        });
    }
    if let Some(i) = owner.iter().position(|&o| o == u32::MAX) {
        let (x, y) = (i as u32 % width, i as u32 / width);
        let missing = missing_tiles(&parts)
            .map(|m| format!(" (missing tiles: {m})"))
            .unwrap_or_default();
        return Err(Error::input(
            first_path,
            format!(
                "the {} parts given leave pixel ({x}, {y}) of the {width}x{height} image \
                 uncovered{missing}",
                paths.len()
            ),
        ));
    }
    Ok(Merged {
        image,
        metadata: merged_metadata(&parts, width, height),
    })
}

/// The tile numbers absent from parts that are all `--tile I/N` of the same N.
fn missing_tiles(parts: &[Part]) -> Option<String> {
    let mut count = None;
    let mut seen = Vec::new();
    for p in parts {
        let Some(MetaValue::Str(label)) = p.raw.meta(META_TILE) else {
            return None;
        };
        let (i, n) = label.split_once('/')?;
        let (i, n): (u32, u32) = (i.parse().ok()?, n.parse().ok()?);
        if *count.get_or_insert(n) != n {
            return None;
        }
        seen.push(i);
    }
    let n = count?;
    let missing: Vec<String> = (0..n)
        .filter(|i| !seen.contains(i))
        .map(|i| format!("{i}/{n}"))
        .collect();
    (!missing.is_empty()).then(|| missing.join(", "))
}

fn merged_metadata(parts: &[Part], width: u32, height: u32) -> Metadata {
    let first = &parts[0].raw;
    let mut seconds = 0.0f64;
    let mut rays = 0u64;
    let mut samples = 0.0f64;
    for p in parts {
        if let Some(MetaValue::Float(s)) = p.raw.meta("raylink:render_seconds") {
            seconds += *s as f64;
        }
        if let Some(MetaValue::Str(r)) = p.raw.meta("raylink:rays") {
            rays += r.parse::<u64>().unwrap_or(0);
        }
        if let Some(MetaValue::Float(s)) = p.raw.meta("raylink:samples_per_pixel") {
            samples += *s as f64 * p.raw.width as f64 * p.raw.height as f64;
        }
    }
    let mut out: Metadata = Vec::new();
    for (name, value) in &first.metadata {
        let kept = name == "Software" || name.starts_with("raylink:");
        let per_part = [META_TILE, META_REGION].contains(&name.as_str());
        if !kept || per_part {
            continue;
        }
        let value = match name.as_str() {
            "raylink:render_seconds" => MetaValue::Float(seconds as f32),
            "raylink:rays" => MetaValue::Str(rays.to_string()),
            "raylink:samples_per_pixel" => {
                MetaValue::Float((samples / (width as f64 * height as f64)) as f32)
            }
            // Anything else the parts disagree on is left out.
            _ if parts.iter().any(|p| p.raw.meta(name) != Some(value)) => continue,
            _ => value.clone(),
        };
        out.push((name.clone(), value));
    }
    out.push((
        "raylink:merged_parts".into(),
        MetaValue::Int(parts.len() as i32),
    ));
    out
}
