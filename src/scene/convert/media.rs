//! The scene's media as `[media.NAME]` tables, and the names shapes and the camera give.

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
        emission: (p.le != crate::math::Rgb::ZERO).then_some(Splat3(p.le)),
        g: (p.g != 0.0).then_some(p.g),
        resolution: None,
        density: None,
        emission_scale: None,
        bounds: None,
        transform: None,
    };
    match &m.kind {
        MediumKind::Homogeneous(h) => plain("homogeneous", h.point()),
        MediumKind::UniformGrid(grid) => {
            let (lo, hi) = grid.bounds();
            let to_world = grid.to_world();
            let rows = (0..4)
                .map(|r| to_world.row(r).to_array().to_vec())
                .collect();
            MediumDesc {
                resolution: Some(Idx3(grid.resolution().map(|n| n as u32))),
                density: Some(grid.density().to_vec()),
                emission_scale: grid.emission_scale().map(<[f32]>::to_vec),
                bounds: Some([V3(lo), V3(hi)]),
                transform: (to_world != crate::math::Mat4::IDENTITY).then_some({
                    OneOrMany::One(TransformOp {
                        translate: None,
                        rotate: None,
                        scale: None,
                        matrix: Some(rows),
                    })
                }),
                ..plain("uniformgrid", grid.unit())
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
