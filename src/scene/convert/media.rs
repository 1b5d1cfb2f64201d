//! The scene's media as `[media.NAME]` tables, and the names shapes and the camera give.

use crate::math::{Mat4, Rgb, Vec3};
use crate::scene::media::{Medium, MediumInterface, MediumKind, MediumPoint};
use crate::scene::toml::schema::{
    Idx3, MediumDesc, OneOrMany, ShapeMediaDesc, Splat3, TransformOp, V3,
};

/// Each medium's key: its own name where unique and not empty, else `medium<index>`.
pub(super) fn keys(media: &[Medium]) -> Vec<String> {
    let mut keys: Vec<String> = Vec::new();
    for (i, m) in media.iter().enumerate() {
        let key = if m.name.is_empty() || keys.contains(&m.name) {
            format!("medium{i}")
        } else {
            m.name.clone()
        };
        keys.push(key);
    }
    keys
}

/// The `[media]` tables, by key.
pub(super) fn tables(media: &[Medium], keys: &[String]) -> Vec<(String, MediumDesc)> {
    media
        .iter()
        .zip(keys)
        .map(|(m, key)| (key.clone(), table(m)))
        .collect()
}

fn table(m: &Medium) -> MediumDesc {
    let plain = |kind: &str, p: &MediumPoint| MediumDesc {
        kind: kind.into(),
        sigma_a: Some(Splat3(p.sigma_a)),
        sigma_s: Some(Splat3(p.sigma_s)),
        scale: None,
        emission: (p.le != Rgb::ZERO).then_some(Splat3(p.le)),
        g: (p.g != 0.0).then_some(p.g),
        resolution: None,
        density: None,
        emission_scale: None,
        sigma_a_grid: None,
        sigma_s_grid: None,
        emission_grid: None,
        file: None,
        grid: None,
        bounds: None,
        transform: None,
    };
    // A grid's box and its place in the world.
    let place = |(lo, hi): (Vec3, Vec3), to_world: Mat4| {
        let rows = (0..4)
            .map(|r| to_world.row(r).to_array().to_vec())
            .collect();
        let transform = (to_world != Mat4::IDENTITY).then_some({
            OneOrMany::One(TransformOp {
                translate: None,
                rotate: None,
                scale: None,
                matrix: Some(rows),
            })
        });
        (Some([V3(lo), V3(hi)]), transform)
    };
    let flat = |v: Option<&[Rgb]>| v.map(|v| v.iter().flat_map(|c| c.to_array()).collect());
    match &m.kind {
        MediumKind::Homogeneous(h) => plain("homogeneous", h.point()),
        MediumKind::UniformGrid(grid) => {
            let (bounds, transform) = place(grid.bounds(), grid.to_world());
            MediumDesc {
                resolution: Some(Idx3(grid.resolution().map(|n| n as u32))),
                density: Some(grid.density().to_vec()),
                emission_scale: grid.emission_scale().map(<[f32]>::to_vec),
                bounds,
                transform,
                ..plain("uniformgrid", grid.unit())
            }
        }
        // Too large to write out sample by sample: the file it came from, named again.
        MediumKind::SparseGrid(grid) => {
            let source = grid.source();
            let file = std::path::absolute(&source.file).unwrap_or(source.file.clone());
            let (_, transform) = place((Vec3::ZERO, Vec3::ONE), source.transform);
            MediumDesc {
                file: Some(file.to_string_lossy().into_owned()),
                grid: (source.grid != "density").then(|| source.grid.clone()),
                transform,
                ..plain("nanovdb", grid.unit())
            }
        }
        MediumKind::RgbGrid(grid) => {
            let (bounds, transform) = place(grid.bounds(), grid.to_world());
            MediumDesc {
                kind: "rgbgrid".into(),
                sigma_a: None,
                sigma_s: None,
                emission: None,
                scale: (grid.scale() != 1.0).then_some(grid.scale()),
                g: (grid.g() != 0.0).then_some(grid.g()),
                resolution: Some(Idx3(grid.resolution().map(|n| n as u32))),
                sigma_a_grid: flat(grid.sigma_a()),
                sigma_s_grid: flat(grid.sigma_s()),
                emission_grid: flat(grid.emission()),
                bounds,
                transform,
                ..plain(
                    "rgbgrid",
                    &MediumPoint {
                        sigma_a: Rgb::ZERO,
                        sigma_s: Rgb::ZERO,
                        le: Rgb::ZERO,
                        g: 0.0,
                    },
                )
            }
        }
    }
}

/// A medium's name, `""` for vacuum.
pub(super) fn name(medium: Option<u32>, keys: &[String]) -> Option<String> {
    medium.map(|m| keys[m as usize].clone())
}

/// A shape's `media` table.
pub(super) fn shape(
    interface: &Option<MediumInterface>,
    keys: &[String],
) -> Option<ShapeMediaDesc> {
    interface.map(|i| ShapeMediaDesc {
        inside: name(i.inside, keys),
        outside: name(i.outside, keys),
    })
}
