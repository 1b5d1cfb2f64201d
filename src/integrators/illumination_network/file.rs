//! Network files: the preprocess's result, so that new views and new lighting reuse it.
//! Little-endian binary:
//!
//! ```text
//! magic "RLNETWK\0"          8 bytes
//! version u32 (= 1)
//! geometry hash u64          FNV-1a of the scene's shapes (not materials or lights:
//!                            relighting changes those and keeps the network)
//! slopes u32, step f32, patch_size f32, jitter f32, seed u64
//! cells u32, nodes u32, extra links u32
//! build stats: intersections, link ends, escapes, extra, degenerate, rays (u64 each),
//!              seconds f64
//! key_of_node: nodes × u32
//! links: nodes × 3·S² × u32
//! extra_start: (nodes + 1) × u32, extra: extra links × 2 × u32
//! checksum u64               FNV-1a over the 64-bit words of everything before it
//! ```
//!
//! Patches (polygons and cells) are not stored: they are a function of the scene's geometry
//! and the parameters, rebuilt on load and checked against the stored cell count. Files are
//! written to a temporary name beside the target and renamed into place.

use super::patches::Patches;
use super::ray_space::RaySpace;
use super::{BuildStats, Network, NetworkParams, ESCAPE, NONE};
use crate::binary_file::{fnv1a, Format, Reader};
use crate::scene::Scene;
use crate::Result;
use std::path::Path;

pub const VERSION: u32 = 1;
const FORMAT: Format = Format {
    magic: b"RLNETWK\0",
    version: VERSION,
    what: "illumination network",
};

/// A hash of the scene's geometry (what the network depends on).
pub fn geometry_hash(scene: &Scene) -> u64 {
    let geometry: Vec<_> = scene.shapes.iter().map(|s| &s.geometry).collect();
    fnv1a(format!("{geometry:?}").as_bytes())
}

fn params_bytes(p: &NetworkParams) -> Vec<u8> {
    let mut b = Vec::new();
    b.extend_from_slice(&p.slopes.to_le_bytes());
    b.extend_from_slice(&p.step.to_le_bytes());
    b.extend_from_slice(&p.patch_size.to_le_bytes());
    b.extend_from_slice(&p.jitter.to_le_bytes());
    b.extend_from_slice(&p.seed.to_le_bytes());
    b
}

/// Writes the network to `path` atomically.
pub fn save(path: &Path, net: &Network, scene: &Scene) -> Result<()> {
    let mut b = FORMAT.start(64 + 4 * (net.links.len() + net.nodes()));
    b.extend_from_slice(&geometry_hash(scene).to_le_bytes());
    b.extend_from_slice(&params_bytes(&net.params));
    b.extend_from_slice(&net.patches.cells.to_le_bytes());
    b.extend_from_slice(&(net.nodes() as u32).to_le_bytes());
    b.extend_from_slice(&(net.extra.len() as u32).to_le_bytes());
    let s = &net.stats;
    for v in [
        s.intersections,
        s.link_ends,
        s.escapes,
        s.extra,
        s.degenerate,
        s.rays,
    ] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    b.extend_from_slice(&s.seconds.to_le_bytes());
    for v in net
        .key_of_node
        .iter()
        .chain(&net.links)
        .chain(&net.extra_start)
        .chain(net.extra.iter().flatten())
    {
        b.extend_from_slice(&v.to_le_bytes());
    }
    FORMAT.save(path, b)
}

/// Reads a network written by [`save`] for the same scene geometry. `expected`, when given,
/// must equal the stored parameters. Any other file is an [`Error::Input`] naming it.
pub fn load(path: &Path, scene: &Scene, expected: Option<&NetworkParams>) -> Result<Network> {
    let file = FORMAT.load(path)?;
    let bad = |problem: &str| FORMAT.error(path, problem);
    let mut r = Reader { rest: file.body() };
    let truncated = || bad("truncated");
    if r.u64().ok_or_else(truncated)? != geometry_hash(scene) {
        return Err(bad("written for another scene geometry"));
    }
    let params = NetworkParams {
        slopes: r.u32().ok_or_else(truncated)?,
        step: r.f32().ok_or_else(truncated)?,
        patch_size: r.f32().ok_or_else(truncated)?,
        jitter: r.f32().ok_or_else(truncated)?,
        seed: r.u64().ok_or_else(truncated)?,
    };
    params.validate().map_err(|e| bad(&e))?;
    if let Some(e) = expected {
        if params_bytes(e) != params_bytes(&params) {
            return Err(bad(&format!(
                "built with other parameters (--slopes {}, --intercept-step {}, --patch-size {}, \
                 --network-jitter {}, --seed {})",
                params.slopes, params.step, params.patch_size, params.jitter, params.seed
            )));
        }
    }
    let cells = r.u32().ok_or_else(truncated)?;
    let nodes = r.u32().ok_or_else(truncated)? as usize;
    let n_extra = r.u32().ok_or_else(truncated)? as usize;
    let mut stats = BuildStats::default();
    for v in [
        &mut stats.intersections,
        &mut stats.link_ends,
        &mut stats.escapes,
        &mut stats.extra,
        &mut stats.degenerate,
        &mut stats.rays,
    ] {
        *v = r.u64().ok_or_else(truncated)?;
    }
    stats.seconds = f64::from_le_bytes(r.take::<8>().ok_or_else(truncated)?);
    let bounds = scene
        .bounds()
        .ok_or_else(|| bad("the scene has no shapes"))?;
    let space = RaySpace::new(params.slopes, params.step, bounds);
    let patches = Patches::new(scene, &space, params.patch_size).map_err(|e| bad(&e))?;
    if patches.cells != cells {
        return Err(bad("patch count differs from the scene's"));
    }
    let slots = space.slots();
    let want = nodes
        .checked_mul(slots + 2)
        .and_then(|n| n.checked_add(1 + 2 * n_extra))
        .and_then(|n| n.checked_mul(4))
        .ok_or_else(truncated)?;
    if r.rest.len() != want {
        return Err(bad("size does not match the node count"));
    }
    let words = |bytes: &[u8]| -> Vec<u32> {
        use rayon::prelude::*;
        bytes
            .par_chunks_exact(4)
            .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
            .collect()
    };
    let (a, rest) = r.rest.split_at(4 * nodes);
    let (b, rest) = rest.split_at(4 * nodes * slots);
    let (c, rest) = rest.split_at(4 * (nodes + 1));
    let (key_of_node, links, extra_start) = (words(a), words(b), words(c));
    let extra: Vec<[u32; 2]> = words(rest).chunks_exact(2).map(|c| [c[0], c[1]]).collect();
    if extra_start[0] != 0
        || extra_start.windows(2).any(|w| w[0] > w[1])
        || extra_start[nodes] as usize != n_extra
        || extra.iter().any(|e| e[0] as usize >= slots)
    {
        return Err(bad("invalid extra-link table"));
    }
    let keys = 2 * cells as usize;
    let mut node_of_key = vec![NONE; keys];
    for (n, &k) in key_of_node.iter().enumerate() {
        if k as usize >= keys || node_of_key[k as usize] != NONE {
            return Err(bad("invalid node table"));
        }
        node_of_key[k as usize] = n as u32;
    }
    if links
        .iter()
        .chain(extra.iter().map(|e| &e[1]))
        .any(|&t| t < ESCAPE && t as usize >= nodes)
    {
        return Err(bad("a link points past the last node"));
    }
    let etendue = super::node_etendue(&space, &links, &extra_start, &extra);
    Ok(Network {
        params,
        space,
        patches,
        node_of_key,
        key_of_node,
        links,
        extra_start,
        extra,
        etendue,
        stats,
    })
}
