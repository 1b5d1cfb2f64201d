//! The converged network, what rendering reads, and the distribution's statistics.

use super::Surface;
use crate::math::Rgb;

/// The converged network: what rendering reads.
#[derive(Clone, Debug, Default)]
pub struct Solution {
    pub surfaces: Vec<Surface>,
    /// Reflected radiance of each node's diffuse part (every slot).
    pub diffuse: Vec<Rgb>,
    /// The part of `diffuse` reflected from light that came straight from the emitters (the
    /// first sweep), for the hybrid rendering.
    pub direct: Vec<Rgb>,
    /// For directional nodes: index into `directional` rows, else [`NONE`](super::super::NONE).
    pub dir_index: Vec<u32>,
    /// Reflected directional radiance per slot, one row of `slots` per directional node.
    pub directional: Vec<Rgb>,
    /// Radiance that arrived over each slot, one row per directional node (the in-buffers
    /// accumulated over the sweeps), for rendering.
    pub incoming: Vec<Rgb>,
    /// The link rows of the directional nodes (in `dir_index` order): rendering gathers over
    /// their linked slots without the network's link table (relighting from a stored basis
    /// does not read it).
    pub dir_rows: Vec<u32>,
    pub stats: DistributeStats,
    /// The emission multiplier the solution was computed with.
    pub light_scale: f32,
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DistributeStats {
    /// Passes over the links: sweeps, or the gathers of conjugate gradients (one each), or
    /// for [`Order::Shoot`](super::Order::Shoot) the shots.
    pub sweeps: u32,
    /// Flux (RGB) emitted, escaped over links that leave the scene, absorbed, and still
    /// unshot at the end: emitted = escaped + absorbed + unshot.
    pub emitted: [f64; 3],
    pub escaped: [f64; 3],
    pub absorbed: [f64; 3],
    pub unshot: [f64; 3],
    /// Entries of the directional maps.
    pub map_entries: u64,
    /// Started from a guess ([`distribute_from`](super::distribute_from)).
    pub warm_start: bool,
    pub seconds: f64,
}

impl Solution {
    /// A node's diffuse radiance (the same toward every direction): its out-buffer, without
    /// the direct light in hybrid mode (added per pixel there).
    #[inline]
    pub fn diffuse_radiance(&self, node: u32, hybrid: bool) -> Rgb {
        let mut r = self.diffuse[node as usize];
        if hybrid {
            r -= self.direct[node as usize];
        }
        r
    }

    /// Memory of the buffers (bytes).
    pub fn memory(&self) -> usize {
        std::mem::size_of::<Rgb>()
            * (self.diffuse.len()
                + self.direct.len()
                + self.directional.len()
                + self.incoming.len())
            + 4 * (self.dir_index.len() + self.dir_rows.len())
            + std::mem::size_of::<Surface>() * self.surfaces.len()
    }
}
