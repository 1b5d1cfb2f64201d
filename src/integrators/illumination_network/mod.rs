//! Illumination networks (Buckalew & Fussell, "Illumination Networks: Fast Realistic Rendering
//! with Arbitrary Reflectance Functions", 1989): the patch-link model.
//!
//! - [`ray_space`]: the uniform 4-D grid of lines and the étendue weight of a line cell.
//! - [`patches`]: polygons (and spheres) cut into patches; each patch side is a potential
//!   network node.
//! - [`preprocess`]: lines → links, by incremental scan conversion or by Embree casting.
//! - [`Network`] (here): the compact network: per node its links in slot order, 32 bits each
//!   (the slot and the node at the other end).
//! - [`distribute`]: light carried over the links until convergence, with reflectance maps
//!   for diffuse (the paper's bypass), mirror, glossy, transmission and frosted surfaces.
//! - [`render`]: eye rays find the patch; interpolation over patches and slopes (figure 6),
//!   from the patches' [`corners`] where they are diffuse.
//! - [`file`](mod@file): saving and loading networks, so views and lighting change without a preprocess.
//!
//! Units: a link carries *flux*; a slot's étendue w converts between radiance and flux. A
//! node's étendue W is the sum of w over its slots (linked or escaping), about π·area: a
//! diffuse node with flux Φ leaving it has radiance Φ/W on every link, which keeps energy
//! exactly conserved whatever the sampling (the form factors are Σw/W).
//!
//! The network's own files: `params.rs` (what its geometry depends on), `build.rs` (the
//! preprocess's entry point and what it did), `assembly.rs` (the node table from the
//! linking's batches), `link_code.rs` (a link in 32 bits) and `etendue.rs` (a node's W, added
//! up alike by the build and the loader).

mod assembly;
mod build;
pub mod corners;
pub mod distribute;
mod etendue;
pub mod file;
mod link_code;
mod lobe_albedo;
mod params;
pub mod patches;
pub mod preprocess;
pub mod ray_space;
pub mod relight;
pub mod render;
pub(crate) mod technique;

pub use assembly::MAX_KEY_BLOCK_BITS;
pub use build::BuildStats;
pub(crate) use etendue::{interleaved_sum, SlotWeights};
pub use link_code::LinkCode;
pub use params::{NetworkParams, DEFAULT_SLOPES, DEFAULT_STEP, DEFAULT_TOLERANCE};
pub use preprocess::Builder;

use crate::scene::Scene;
use patches::Patches;
use ray_space::RaySpace;

/// No link in this slot (no line of this slope meets the side), in a row of
/// [`Network::row_into`].
pub const NONE: u32 = u32::MAX;
/// The slot's line leaves the scene.
pub const ESCAPE: u32 = u32::MAX - 1;

/// The illumination network: geometry only (no materials, no light), so it is reused for
/// new views and new lighting.
#[derive(Clone, Debug)]
pub struct Network {
    pub params: NetworkParams,
    pub space: RaySpace,
    pub patches: Patches,
    /// For each side key (cell·2 + side), its node or [`NONE`].
    pub node_of_key: Vec<u32>,
    /// For each node, its side key.
    pub key_of_node: Vec<u32>,
    /// Each node's links in slot order, packed by `code`: node n's are
    /// `links[link_start[n]..link_start[n + 1]]`. A patch bigger than an intercept cell in
    /// projection can meet two lines of one slot: such a slot has two (or more) links.
    pub link_start: Vec<u32>,
    pub links: Vec<u32>,
    pub code: LinkCode,
    /// For each node, W = Σ w over its links (escapes included).
    pub etendue: Vec<f32>,
    /// For each node, the part of W over its escaping links (the energy balance's escapes),
    /// added up beside W by the build and the loader.
    pub escape_etendue: Vec<f32>,
    pub stats: BuildStats,
}

impl Network {
    pub fn nodes(&self) -> usize {
        self.key_of_node.len()
    }

    pub fn slots(&self) -> usize {
        self.space.slots()
    }

    /// A node's links, in slot order (packed by [`Network::code`]).
    #[inline]
    pub fn links_of(&self, node: u32) -> &[u32] {
        let n = node as usize;
        &self.links[self.link_start[n] as usize..self.link_start[n + 1] as usize]
    }

    /// A node's links as (slot, node at the other end or [`ESCAPE`]), in slot order.
    #[inline]
    pub fn slot_links(&self, node: u32) -> impl DoubleEndedIterator<Item = (usize, u32)> + '_ {
        let code = self.code;
        self.links_of(node)
            .iter()
            .map(move |&l| (code.slot(l), code.target(l)))
    }

    /// A node's links as a row of one entry per slot (the paper's layout): the other end of
    /// the slot's first link, [`ESCAPE`], or [`NONE`]. For the directional nodes' maps and
    /// rendering, which look slots up by direction.
    pub fn row_into(&self, node: u32, row: &mut Vec<u32>) {
        row.clear();
        row.resize(self.slots(), NONE);
        for (slot, t) in self.slot_links(node).rev() {
            row[slot] = t;
        }
    }

    /// The rows ([`Network::row_into`]) of `nodes`, one after another.
    pub fn rows_of(&self, nodes: impl IntoIterator<Item = u32>) -> Vec<u32> {
        let (mut rows, mut row) = (Vec::new(), Vec::new());
        for node in nodes {
            self.row_into(node, &mut row);
            rows.extend_from_slice(&row);
        }
        rows
    }

    /// The polygon, cell and side (0 front, 1 back) of a node.
    pub fn node_place(&self, node: u32) -> (u32, u32, u32) {
        let key = self.key_of_node[node as usize];
        let cell = key / 2;
        let poly = self
            .patches
            .polygons
            .partition_point(|p| p.first_cell <= cell)
            - 1;
        (poly as u32, cell, key & 1)
    }

    /// The scene material of a node (its polygon's shape's), and its side (0 front, 1 back).
    pub fn node_material(&self, node: u32, scene: &Scene) -> (usize, u32) {
        let (poly, _, side) = self.node_place(node);
        let shape = self.patches.polygons[poly as usize].shape as usize;
        (scene.shapes[shape].material, side)
    }

    /// The node on the other side of a node's patch (where transmitted light goes on), or
    /// [`NONE`] when no link reaches that side.
    #[inline]
    pub fn twin(&self, node: u32) -> u32 {
        self.node_of_key[(self.key_of_node[node as usize] ^ 1) as usize]
    }

    /// The outward unit normal of a node's side.
    pub fn node_normal(&self, node: u32) -> crate::math::Vec3 {
        let (poly, cell, side) = self.node_place(node);
        let pg = &self.patches.polygons[poly as usize];
        let (s, t) = pg.cell_centre(cell);
        let n = pg.normal_at(pg.point(s, t));
        if side == 0 {
            n
        } else {
            -n
        }
    }

    /// Bytes held by the network's tables.
    pub fn memory(&self) -> usize {
        4 * (self.links.len()
            + self.link_start.len()
            + self.node_of_key.len()
            + self.key_of_node.len()
            + self.etendue.len())
            + self.patches.polygons.len() * std::mem::size_of::<patches::Polygon>()
    }
}
