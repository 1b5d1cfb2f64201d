//! Network files: the preprocess's result, so that new views and new lighting reuse it.
//! Little-endian binary:
//!
//! ```text
//! magic "RLNETWK\0"          8 bytes
//! version u32 (= 3)
//! geometry hash u64          FNV-1a of the scene's shapes (not materials or lights:
//!                            relighting changes those and keeps the network)
//! slopes u32, step f32, patch_size f32, jitter f32, seed u64
//! cells u32, nodes u32, links u32
//! build stats: intersections, link ends, escapes, extra, degenerate, rays (u64 each),
//!              seconds f64
//! light basis size u64       0 when no basis is stored
//! key_of_node: nodes × u32
//! light basis                (relight/file_bytes.rs: one converged solution per emissive
//!                            material, then any reflectance series)
//! prefix checksum u64        over everything before it
//! link_start: (nodes + 1) × u32
//! links: links × u32          each node's links in slot order, packed (slot, other end)
//! checksum u64               FNV-1a over the 64-bit words of everything before it
//! ```
//!
//! The prefix (header, node table, light basis) has its own checksum so that relighting from
//! the basis reads only the prefix and never the link table, the bulk of the file. Patches
//! (polygons and cells) are not stored: they are a function of the scene's geometry and the
//! parameters, rebuilt on load and checked against the stored cell count. Files are written
//! to a temporary name beside the target and renamed into place.

use super::patches::Patches;
use super::ray_space::RaySpace;
use super::relight::LightBasis;
use super::{BuildStats, LinkCode, Network, NetworkParams, NONE};
use crate::binary_file::{checksum, fnv1a, Format, Reader};
use crate::error::{Error, Result};
use crate::scene::Scene;
use std::io::Read;
use std::path::Path;

pub const VERSION: u32 = 3;
pub(crate) const FORMAT: Format = Format {
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

/// Writes the network (and a light basis, if given) to `path` atomically.
pub fn save(path: &Path, net: &Network, scene: &Scene, basis: Option<&LightBasis>) -> Result<()> {
    let basis = basis.map(LightBasis::to_bytes).unwrap_or_default();
    let mut b = FORMAT.try_start(64 + basis.len() + 4 * (net.links.len() + net.nodes()), path)?;
    b.extend_from_slice(&geometry_hash(scene).to_le_bytes());
    b.extend_from_slice(&params_bytes(&net.params));
    b.extend_from_slice(&net.patches.cells.to_le_bytes());
    b.extend_from_slice(&(net.nodes() as u32).to_le_bytes());
    b.extend_from_slice(&(net.links.len() as u32).to_le_bytes());
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
    b.extend_from_slice(&(basis.len() as u64).to_le_bytes());
    for v in &net.key_of_node {
        b.extend_from_slice(&v.to_le_bytes());
    }
    b.extend_from_slice(&basis);
    let prefix = checksum(&b);
    b.extend_from_slice(&prefix.to_le_bytes());
    // One reservation, then the table as bytes in one go.
    let table = net.link_start.iter().chain(&net.links);
    b.reserve(4 * (net.link_start.len() + net.links.len()));
    for v in table {
        b.extend_from_slice(&v.to_le_bytes());
    }
    FORMAT.save(path, b)
}

/// Bytes of the header after the version.
const HEADER: usize = 8 + 24 + 12 + 6 * 8 + 8 + 8;

struct Header {
    params: NetworkParams,
    cells: u32,
    nodes: usize,
    n_links: usize,
    stats: BuildStats,
    basis_len: usize,
}

fn read_header(
    r: &mut Reader,
    path: &Path,
    scene: &Scene,
    expected: Option<&NetworkParams>,
) -> Result<Header> {
    let bad = |problem: &str| FORMAT.error(path, problem);
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
    params
        .validate()
        .map_err(|_| bad("corrupt: its network settings are out of range"))?;
    if let Some(e) = expected {
        if params_bytes(e) != params_bytes(&params) {
            return Err(bad(&format!(
                "built with other network settings (slopes {}, intercept_step {}, patch_size \
                 {}, jitter {}, seed {})",
                params.slopes, params.step, params.patch_size, params.jitter, params.seed
            )));
        }
    }
    let cells = r.u32().ok_or_else(truncated)?;
    let nodes = r.u32().ok_or_else(truncated)? as usize;
    let n_links = r.u32().ok_or_else(truncated)? as usize;
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
    let basis_len = usize::try_from(r.u64().ok_or_else(truncated)?).map_err(|_| truncated())?;
    // The counts as a build writes them: at most one node per patch side, each link stored
    // at both its ends or escaping, and a time that is one.
    if nodes as u64 > 2 * cells as u64 {
        return Err(bad(&format!(
            "corrupt: {nodes} nodes for {cells} patches (2 sides each)"
        )));
    }
    if stats.link_ends.checked_add(stats.escapes) != Some(n_links as u64) {
        return Err(bad(&format!(
            "corrupt: {n_links} links, where its build made {} link ends and {} escapes",
            stats.link_ends, stats.escapes
        )));
    }
    if stats.extra > n_links as u64 || !(stats.seconds.is_finite() && stats.seconds >= 0.0) {
        return Err(bad("corrupt: its build statistics are not a build's"));
    }
    Ok(Header {
        params,
        cells,
        nodes,
        n_links,
        stats,
        basis_len,
    })
}

/// The ray space and patches for a header, checked against the scene.
fn geometry(path: &Path, scene: &Scene, h: &Header) -> Result<(RaySpace, Patches)> {
    let bad = |problem: &str| FORMAT.error(path, problem);
    let bounds = scene
        .bounds()
        .ok_or_else(|| bad("the scene has no shapes"))?;
    let space = RaySpace::new(h.params.slopes, h.params.step, bounds);
    let patches = Patches::new(scene, &space, h.params.patch_size).map_err(|e| bad(&e))?;
    if patches.cells != h.cells {
        return Err(bad("patch count differs from the scene's"));
    }
    Ok((space, patches))
}

/// The node table: key_of_node and its inverse.
fn node_table(path: &Path, bytes: &[u8], cells: u32) -> Result<(Vec<u32>, Vec<u32>)> {
    let key_of_node = words(bytes);
    let keys = 2 * cells as usize;
    let mut node_of_key = vec![NONE; keys];
    // Nodes are numbered in the order of their side keys.
    for (n, &k) in key_of_node.iter().enumerate() {
        if k as usize >= keys {
            return Err(FORMAT.error(
                path,
                &format!("invalid node table: node {n} is patch side {k}, past the last ({keys})"),
            ));
        }
        if n > 0 && k <= key_of_node[n - 1] {
            return Err(FORMAT.error(
                path,
                &format!("invalid node table: node {n}'s patch side {k} is out of order"),
            ));
        }
        node_of_key[k as usize] = n as u32;
    }
    Ok((key_of_node, node_of_key))
}

fn words(bytes: &[u8]) -> Vec<u32> {
    use rayon::prelude::*;
    bytes
        .par_chunks_exact(4)
        .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

fn basis_of(path: &Path, bytes: &[u8], nodes: usize, slots: usize) -> Result<Option<LightBasis>> {
    if bytes.is_empty() {
        return Ok(None);
    }
    LightBasis::from_bytes(bytes, nodes, slots)
        .map(Some)
        .map_err(|why| FORMAT.error(path, &format!("invalid light basis: {why}")))
}

/// A network file opened up to the end of its prefix.
struct Opened {
    file: std::fs::File,
    /// Everything up to and with the prefix checksum.
    head: Vec<u8>,
    header: Header,
    space: RaySpace,
    patches: Patches,
}

/// Opens a network file and reads its prefix (header, node table, light basis, prefix
/// checksum), after checking its size against the header.
fn open_prefix(path: &Path, scene: &Scene, expected: Option<&NetworkParams>) -> Result<Opened> {
    let bad = |problem: &str| FORMAT.error(path, problem);
    let (mut file, len) = crate::input_file::open(path, &crate::input_file::NETWORK)?;
    // As much of the header as there is: a short file still gets the right message (not a
    // network, another version, or truncated).
    let mut head = Vec::with_capacity(12 + HEADER);
    (&mut file)
        .take((12 + HEADER) as u64)
        .read_to_end(&mut head)
        .map_err(|e| Error::io(path, e))?;
    if !head.is_empty() && head.len() < 12 && FORMAT.magic.starts_with(&head[..head.len().min(8)]) {
        return Err(bad("truncated"));
    }
    if head.len() < 12 || &head[..8] != FORMAT.magic {
        return Err(bad("no raylink illumination network header"));
    }
    let version = u32::from_le_bytes(head[8..12].try_into().unwrap());
    if version != VERSION {
        return Err(bad(&format!(
            "format version {version}, this raylink reads {VERSION}"
        )));
    }
    if head.len() < 12 + HEADER {
        return Err(bad("truncated"));
    }
    let h = read_header(&mut Reader { rest: &head[12..] }, path, scene, expected)?;
    let (space, patches) = geometry(path, scene, &h)?;
    // The header's sizes are the file's word until checked: a damaged basis length must not
    // overflow (found by the network-file fuzzer).
    let prefix_len = (12 + HEADER as u64 + 4 * h.nodes as u64).checked_add(h.basis_len as u64);
    let total = prefix_len.and_then(|p| {
        ((h.nodes as u64 + 1 + h.n_links as u64) * 4)
            .checked_add(p)?
            .checked_add(16)
    });
    match total {
        Some(total) if total > len => {
            return Err(bad(&format!(
                "truncated: {len} bytes, where its header's counts need {total}"
            )))
        }
        Some(total) if total == len => {}
        Some(total) => {
            return Err(bad(&format!(
                "size does not match the node count: {len} bytes, where its header's counts \
                 need {total}"
            )))
        }
        None => {
            return Err(bad(
                "size does not match the node count: its header's counts overflow",
            ))
        }
    }
    // Within the file's length (checked above).
    let prefix_len = prefix_len.unwrap_or_default() as usize;
    let mut rest = vec![0u8; prefix_len + 8 - head.len()];
    file.read_exact(&mut rest).map_err(|_| bad("truncated"))?;
    head.extend_from_slice(&rest);
    Ok(Opened {
        file,
        head,
        header: h,
        space,
        patches,
    })
}

/// Reads only the prefix of a network file (header, node table, light basis), checked by its
/// own checksum: a network without its link table (enough to render a solution from the
/// basis, not to distribute), and the basis if one is stored.
pub fn load_prefix(
    path: &Path,
    scene: &Scene,
    expected: Option<&NetworkParams>,
) -> Result<(Network, Option<LightBasis>)> {
    let bad = |problem: &str| FORMAT.error(path, problem);
    let Opened {
        head,
        header: h,
        space,
        patches,
        ..
    } = open_prefix(path, scene, expected)?;
    let (data, sum) = head.split_at(head.len() - 8);
    if checksum(data) != u64::from_le_bytes(sum.try_into().unwrap()) {
        return Err(bad("checksum mismatch (truncated or corrupt)"));
    }
    let body = &data[12 + HEADER..];
    let (keys, basis) = body.split_at(4 * h.nodes);
    let (key_of_node, node_of_key) = node_table(path, keys, h.cells)?;
    let basis = basis_of(path, basis, h.nodes, space.slots())?;
    let code = LinkCode::new(space.slots(), 2 * h.cells as usize).map_err(|e| bad(&e))?;
    Ok((
        Network {
            params: h.params,
            space,
            patches,
            node_of_key,
            key_of_node,
            link_start: Vec::new(),
            links: Vec::new(),
            code,
            etendue: Vec::new(),
            escape_etendue: Vec::new(),
            stats: h.stats,
        },
        basis,
    ))
}

/// [`crate::binary_file::checksum`] over data that arrives in pieces.
struct StreamSum {
    h: u64,
    carry: [u8; 8],
    carried: usize,
    len: u64,
}

impl StreamSum {
    const PRIME: u64 = 0x100000001b3;

    fn new() -> Self {
        StreamSum {
            h: 0xcbf29ce484222325,
            carry: [0; 8],
            carried: 0,
            len: 0,
        }
    }

    fn word(&mut self, w: [u8; 8]) {
        self.h ^= u64::from_le_bytes(w);
        self.h = self.h.wrapping_mul(Self::PRIME);
    }

    fn update(&mut self, mut bytes: &[u8]) {
        self.len += bytes.len() as u64;
        if self.carried > 0 {
            let n = (8 - self.carried).min(bytes.len());
            self.carry[self.carried..self.carried + n].copy_from_slice(&bytes[..n]);
            self.carried += n;
            bytes = &bytes[n..];
            if self.carried < 8 {
                return;
            }
            self.word(self.carry);
            self.carried = 0;
        }
        let mut words = bytes.chunks_exact(8);
        for w in &mut words {
            self.word(w.try_into().unwrap());
        }
        let tail = words.remainder();
        self.carry[..tail.len()].copy_from_slice(tail);
        self.carried = tail.len();
    }

    fn finish(mut self) -> u64 {
        let mut tail = [0u8; 8];
        tail[..self.carried].copy_from_slice(&self.carry[..self.carried]);
        self.word(tail);
        self.h ^ self.len
    }
}

/// A node's links checked: flag 1 if one goes past the last slot or node (an escape aside),
/// flag 2 if they are not in slot order, flag 4 if one escapes. Four links at a time on the
/// packed words: the slot is their high bits, so a slot past the last is a word at or above
/// `slots` shifted up, and slot order is the order of the words with the target bits masked
/// off.
fn link_flags(code: LinkCode, list: &[u32], slots: usize, nodes: usize) -> u8 {
    use wide::u32x4;
    let escape = code.escape();
    // Every word is below 2^32: with a power of two of slots no slot can be past the last.
    let first_past = u32::try_from((slots as u64) << code.target_bits).unwrap_or(u32::MAX);
    let slot_past = |l: u32x4| {
        if first_past == u32::MAX {
            u32x4::ZERO
        } else {
            l.simd_ge(u32x4::splat(first_past))
        }
    };
    let (esc, nodes4) = (u32x4::splat(escape), u32x4::splat(nodes as u32));
    let node_past = |l: u32x4| {
        let t = l & esc;
        t.simd_ge(nodes4) & !t.simd_eq(esc)
    };
    let slot_bits = |l: u32x4| l & !esc;
    let (mut past, mut unordered, mut escapes) = (u32x4::ZERO, u32x4::ZERO, u32x4::ZERO);
    let quads = list.chunks_exact(4);
    let tail = quads.remainder();
    for q in quads {
        let l = u32x4::new([q[0], q[1], q[2], q[3]]);
        past |= slot_past(l) | node_past(l);
        escapes |= (l & esc).simd_eq(esc);
    }
    // Each word against the next one, four pairs at a time.
    let pairs = list.len().saturating_sub(1);
    for i in (0..pairs / 4).map(|k| 4 * k) {
        let (a, b) = (&list[i..i + 4], &list[i + 1..i + 5]);
        let a = slot_bits(u32x4::new([a[0], a[1], a[2], a[3]]));
        let b = slot_bits(u32x4::new([b[0], b[1], b[2], b[3]]));
        unordered |= b.simd_lt(a);
    }
    let mut flags =
        u8::from(past.any()) | u8::from(unordered.any()) << 1 | u8::from(escapes.any()) << 2;
    for &l in tail {
        let (slot, t) = (code.slot(l), code.raw_target(l));
        flags |= u8::from(slot >= slots || (t >= nodes && t != escape as usize));
        flags |= u8::from(t == escape as usize) << 2;
    }
    for p in list[pairs / 4 * 4..].windows(2) {
        flags |= u8::from(code.slot(p[1]) < code.slot(p[0])) << 1;
    }
    flags
}

/// What is wrong with a link table's offsets, if anything: they start at 0, end at the link
/// count, and give every node at least one link (a build makes nodes only of patch sides
/// that a line links to another).
fn starts_problem(link_start: &[u32], n_links: usize) -> Option<String> {
    use rayon::prelude::*;
    if link_start[0] != 0 {
        return Some(format!("the first node's links start at {}", link_start[0]));
    }
    let last = *link_start.last().expect("nodes + 1 offsets");
    if last as usize != n_links {
        return Some(format!(
            "the links end at {last}, not at the link count {n_links}"
        ));
    }
    link_start
        .par_windows(2)
        .position_first(|w| w[1] <= w[0])
        .map(|n| match link_start[n + 1] < link_start[n] {
            true => format!("node {n}'s links end before they start"),
            false => format!("node {n} has no links"),
        })
}

/// Reads a network written by [`save`] for the same scene geometry. `expected`, when given,
/// must equal the stored parameters. Any other file is an [`Error::Input`] naming it.
pub fn load(path: &Path, scene: &Scene, expected: Option<&NetworkParams>) -> Result<Network> {
    load_all(path, scene, expected).map(|(net, _)| net)
}

/// [`load`], with the light basis if one is stored.
pub fn load_all(
    path: &Path,
    scene: &Scene,
    expected: Option<&NetworkParams>,
) -> Result<(Network, Option<LightBasis>)> {
    let bad = |problem: &str| FORMAT.error(path, problem);
    let Opened {
        file,
        head,
        header: h,
        space,
        patches,
    } = open_prefix(path, scene, expected)?;
    let (nodes, n_links) = (h.nodes, h.n_links);
    let slots = space.slots();
    // The tables are read straight into their words (as bytes) in slices, the checksum kept
    // on the way while a slice is in cache: no copy of the file in memory. The link table's
    // two halves are read at once, on two threads: most of a read's time goes to the system
    // handing over fresh pages, which two threads do side by side.
    let mut sum = StreamSum::new();
    sum.update(&head);
    let read_at = |out: &mut [u32], mut at: u64, mut sum: Option<&mut StreamSum>| {
        for slice in wide::bytemuck::cast_slice_mut::<u32, u8>(out).chunks_mut(1 << 20) {
            crate::platform::read_exact_at(&file, slice, at).map_err(|_| bad("truncated"))?;
            if let Some(sum) = sum.as_deref_mut() {
                sum.update(slice);
            }
            at += slice.len() as u64;
        }
        Result::Ok(())
    };
    let at = head.len() as u64;
    let mut link_start = vec![0u32; nodes + 1];
    read_at(&mut link_start, at, Some(&mut sum))?;
    let at = at + 4 * (nodes as u64 + 1);
    let mut links = crate::platform::try_vec(n_links, 0u32, || {
        format!("the link table of {} ({n_links} links)", path.display())
    })?;
    let (first, second) = links.split_at_mut(n_links / 2);
    let second_at = at + 4 * first.len() as u64;
    let (a, b) = rayon::join(
        || read_at(first, at, Some(&mut sum)),
        || read_at(second, second_at, None),
    );
    a?;
    b?;
    let mut stored = [0u8; 8];
    crate::platform::read_exact_at(&file, &mut stored, at + 4 * n_links as u64)
        .map_err(|_| bad("truncated"))?;
    let body = &head[12 + HEADER..head.len() - 8];
    let (a, basis) = body.split_at(4 * nodes);
    // The file is little-endian (the link table's words are converted after its checksum).
    #[cfg(target_endian = "big")]
    for w in link_start.iter_mut() {
        *w = u32::from_le(*w);
    }
    let starts = starts_problem(&link_start, n_links);
    let starts_ok = starts.is_none();
    let code = LinkCode::new(slots, 2 * h.cells as usize).map_err(|e| bad(&e))?;
    // Per node, in parallel: W, and whether its links go to existing slots and nodes (flag 1)
    // in slot order (flag 2), checked four at a time (`link_flags`). (A bad slot reads a W
    // masked into the table; the result is not used.)
    let w = super::SlotWeights::new(&space);
    let check = |links: &[u32]| {
        use rayon::prelude::*;
        let (etendue, flags): (Vec<f32>, Vec<u8>) = link_start
            .par_windows(2)
            .map(|r| {
                let list = &links[r[0] as usize..r[1] as usize];
                let e = super::etendue::list_etendue(code, &w, list);
                (e, link_flags(code, list, slots, nodes))
            })
            .unzip();
        // The escapes' part of W, for the nodes with an escape (flag 4).
        let escape_etendue = link_start
            .par_windows(2)
            .zip(&flags)
            .map(|(r, &f)| {
                let list = &links[r[0] as usize..r[1] as usize];
                if f & 4 != 0 {
                    super::etendue::list_escape_etendue(code, &w, list)
                } else {
                    0.0
                }
            })
            .collect();
        (
            etendue,
            escape_etendue,
            flags.iter().fold(0, |all, f| all | f),
        )
    };
    let second = &links[n_links / 2..];
    let whole = |sum: StreamSum| sum.finish() == u64::from_le_bytes(stored);
    // The checksum of the second half goes on one thread while the pass starts on the other
    // (its result is used only once the checksum holds).
    #[cfg(target_endian = "little")]
    let (sum_ok, checked) = rayon::join(
        || {
            sum.update(wide::bytemuck::cast_slice(second));
            whole(sum)
        },
        || starts_ok.then(|| check(&links)),
    );
    #[cfg(target_endian = "big")]
    let (sum_ok, checked) = {
        sum.update(wide::bytemuck::cast_slice(second));
        let ok = whole(sum);
        for w in links.iter_mut() {
            *w = u32::from_le(*w);
        }
        (ok, (ok && starts_ok).then(|| check(&links)))
    };
    if !sum_ok {
        return Err(bad("checksum mismatch (truncated or corrupt)"));
    }
    let (key_of_node, node_of_key) = node_table(path, a, h.cells)?;
    let basis = basis_of(path, basis, nodes, slots)?;
    if let Some(why) = starts {
        return Err(bad(&format!("invalid link table: {why}")));
    }
    let Some((etendue, escape_etendue, flags)) = checked else {
        return Err(bad("invalid link table"));
    };
    if flags & 1 != 0 {
        return Err(bad("a link points past the last slot or node"));
    }
    if flags & 2 != 0 {
        return Err(bad("a node's links are not in slot order"));
    }
    Ok((
        Network {
            params: h.params,
            space,
            patches,
            node_of_key,
            key_of_node,
            link_start,
            links,
            code,
            etendue,
            escape_etendue,
            stats: h.stats,
        },
        basis,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The four-at-a-time link checks find a bad slot, a bad node or a slot out of order
    /// wherever it is (in a quad, in the tail, across a quad's edge), let escapes and the last
    /// slot and node pass, flag lists with an escape, and agree with checking one link at a
    /// time.
    #[test]
    fn link_checks_find_every_damage() {
        use super::super::ESCAPE;
        let escapes = |code: LinkCode, list: &[u32]| {
            4 * u8::from(list.iter().any(|&l| code.target(l) == ESCAPE))
        };
        let one_at_a_time = |code: LinkCode, list: &[u32], slots: usize, nodes: usize| {
            let mut flags = escapes(code, list);
            for (i, &l) in list.iter().enumerate() {
                let (slot, t) = (code.slot(l), code.target(l));
                flags |= u8::from(slot >= slots || (t != ESCAPE && t as usize >= nodes));
                if i > 0 && slot < code.slot(list[i - 1]) {
                    flags |= 2;
                }
            }
            flags
        };
        // 1,200 slots (not a power of two: a slot can be past the last) and 1,024.
        for slots in [1200usize, 1024] {
            let (nodes, keys) = (1000usize, 4000usize);
            let code = LinkCode::new(slots, keys).unwrap();
            for len in [1usize, 3, 4, 5, 8, 9, 13] {
                let good: Vec<u32> = (0..len as u32)
                    .map(|i| {
                        let slot = i * (slots as u32 - 1) / len as u32;
                        match i % 3 {
                            0 => code.pack(slot, ESCAPE),
                            1 => code.pack(slot, nodes as u32 - 1),
                            _ => code.pack(slot, i),
                        }
                    })
                    .collect();
                assert_eq!(link_flags(code, &good, slots, nodes), 4, "{slots} {len}");
                // Without its escapes the list is flagged for nothing.
                let closed: Vec<u32> = good
                    .iter()
                    .map(|&l| match code.target(l) {
                        ESCAPE => code.pack(code.slot(l) as u32, 0),
                        _ => l,
                    })
                    .collect();
                assert_eq!(link_flags(code, &closed, slots, nodes), 0, "{slots} {len}");
                for at in 0..len {
                    let mut bad = good.clone();
                    bad[at] = code.pack(code.slot(good[at]) as u32, nodes as u32);
                    let mut unordered = good.clone();
                    unordered[at] = code.pack(slots as u32 - 1, 0);
                    let mut cases = vec![(bad, 1), (unordered, if at + 1 < len { 2 } else { 0 })];
                    if slots < 1 << (32 - code.target_bits) {
                        let mut past_slot = good.clone();
                        past_slot[at] = code.pack(slots as u32, 0);
                        cases.push((past_slot, if at + 1 < len { 3 } else { 1 }));
                    }
                    for (list, want) in cases {
                        let got = link_flags(code, &list, slots, nodes);
                        assert_eq!(got, one_at_a_time(code, &list, slots, nodes));
                        let want = want | escapes(code, &list);
                        assert_eq!(got, want, "{slots} slots, {len} links, at {at}");
                    }
                }
            }
        }
    }

    /// The streamed checksum equals the file checksum however the data is cut.
    #[test]
    fn streamed_checksum_equals_the_whole_one() {
        let data: Vec<u8> = (0..1000u32).map(|i| (i * 7919 % 251) as u8).collect();
        for len in [0, 1, 7, 8, 9, 63, 1000] {
            let bytes = &data[..len];
            for cuts in [&[][..], &[1][..], &[3, 5][..], &[8, 9, 17][..]] {
                let mut sum = StreamSum::new();
                let mut at = 0;
                for &c in cuts {
                    let end = (at + c).min(len);
                    sum.update(&bytes[at..end]);
                    at = end;
                }
                sum.update(&bytes[at..]);
                assert_eq!(sum.finish(), checksum(bytes), "len {len}, cuts {cuts:?}");
            }
        }
    }
}
