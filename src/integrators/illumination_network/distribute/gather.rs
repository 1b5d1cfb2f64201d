//! What a node gathers over its links from what the other ends shot: the loop over links
//! that every sweep and every conjugate-gradient step runs.

use super::Surface;
use crate::integrators::illumination_network::{
    interleaved_sum, LinkCode, Network, SlotWeights, ESCAPE, NONE,
};
use crate::math::Rgb;
use glam::Vec3A;

/// What a node gathers over its links from what the other ends shot.
pub(super) struct Ends<'a> {
    pub(super) code: LinkCode,
    /// The diffuse radiance shot, and zeros past the last node up to a power of two
    /// ([`Ends::padded_len`]), where escapes read.
    pub(super) padded: &'a [Vec3A],
    pub(super) w: &'a SlotWeights,
    /// Each end's directional row, or NONE ([`NONE`] past the last node), as long as `padded`.
    pub(super) row_of: &'a [u32],
    pub(super) shot_dir: &'a [Rgb],
    pub(super) slots: usize,
}

impl<'a> Ends<'a> {
    /// The length of `padded` for `nodes` nodes: a power of two past the last node. A link
    /// masked to it gives its node (below the mask, which is below the target bits) or, for
    /// an escape (all target bits set), the last entry, a zero: one `and` per link, no
    /// bounds check and no branch.
    pub(super) fn padded_len(nodes: usize) -> usize {
        (nodes + 1).next_power_of_two()
    }

    /// The ends of an all-diffuse network (only [`Ends::gather`]`::<false>`), reading `padded`.
    pub(super) fn diffuse(code: LinkCode, padded: &'a [Vec3A], w: &'a SlotWeights) -> Ends<'a> {
        Ends {
            code,
            padded,
            w,
            row_of: &[],
            shot_dir: &[],
            slots: 0,
        }
    }

    /// Σ over `links` of the radiance shot toward the node × w: the diffuse part and, with
    /// `DIRECTIONAL`, the directional part of directional ends, in four-lane vectors
    /// ([`interleaved_sum`]). Indices are masked into slices of power-of-two lengths (nodes,
    /// [`Ends::padded_len`]; slots, [`SlotWeights`]), so the diffuse part has no bounds check
    /// per link.
    #[inline(always)]
    pub(super) fn gather<const DIRECTIONAL: bool>(&self, links: &[u32]) -> Rgb {
        let last = self.padded.len() - 1;
        debug_assert!(self.padded.len().is_power_of_two());
        let padded = &self.padded[..=last];
        let row_of = if DIRECTIONAL {
            &self.row_of[..=last]
        } else {
            &[]
        };
        let ((w, mask), code) = (self.w.table(), self.code);
        let end = |l: u32| {
            let (t, slot) = (l as usize & last, code.slot(l) & mask);
            let mut r = padded[t];
            if DIRECTIONAL {
                let k = row_of[t];
                if k != NONE {
                    r += Vec3A::from(self.shot_dir[k as usize * self.slots + slot]);
                }
            }
            r * w[slot]
        };
        interleaved_sum(links, end).into()
    }
}

/// The diffuse light reflected from what comes straight from the emitters (what the first
/// sweep from the emission finds), shot from the emitters alone: a warm start's first sweep
/// gathers more than emission.
pub(super) fn direct_light(net: &Network, surfaces: &[Surface], w: &[f32]) -> Vec<Rgb> {
    let mut arrived = vec![Rgb::ZERO; net.nodes()];
    for (i, s) in surfaces.iter().enumerate() {
        if s.emission != Rgb::ZERO {
            for (l, j) in net.slot_links(i as u32) {
                if j < ESCAPE {
                    arrived[j as usize] += s.emission * w[l];
                }
            }
        }
    }
    arrived
        .iter()
        .zip(surfaces)
        .zip(&net.etendue)
        .map(|((a, s), &e)| s.kd * *a / e)
        .collect()
}
