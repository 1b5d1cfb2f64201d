//! A node's étendue W (and its escapes' part), added up over its links in a fixed order that
//! the build, the loader and the distribution share, so their bits agree.

use super::ray_space::RaySpace;
use super::LinkCode;

/// The slots' étendues w, padded with zeros to a power of two: a slot index masked into the
/// table needs no bounds check in the loops over links (every link's slot is below the
/// number of slots, so the mask changes nothing).
pub(crate) struct SlotWeights {
    w: Vec<f32>,
    mask: usize,
}

impl SlotWeights {
    pub(crate) fn new(space: &RaySpace) -> SlotWeights {
        let mut w = space.etendues();
        let mask = w.len().next_power_of_two() - 1;
        w.resize(mask + 1, 0.0);
        SlotWeights { w, mask }
    }

    /// The table (its length `mask() + 1`) and the mask.
    #[inline]
    pub(crate) fn table(&self) -> (&[f32], usize) {
        (&self.w[..=self.mask], self.mask)
    }
}

/// Σ term(l) over `list`, in four interleaved partial sums added as (s₀ + s₁) + (s₂ + s₃): one
/// running sum over ~800 links would be a chain of dependent additions. The order is fixed,
/// so the bits depend on the list alone.
#[inline(always)]
pub(crate) fn interleaved_sum<T>(list: &[u32], mut term: impl FnMut(u32) -> T) -> T
where
    T: Copy + Default + std::ops::Add<Output = T> + std::ops::AddAssign,
{
    let mut sum = [T::default(); 4];
    let mut quads = list.chunks_exact(4);
    for q in &mut quads {
        for (s, &l) in sum.iter_mut().zip(q) {
            *s += term(l);
        }
    }
    for (s, &l) in sum.iter_mut().zip(quads.remainder()) {
        *s += term(l);
    }
    (sum[0] + sum[1]) + (sum[2] + sum[3])
}

/// W of one node: Σ w over its links (`list`, in slot order) ([`interleaved_sum`]). The
/// build and the loader both add up W here, so a loaded network has the same bits.
#[inline(always)]
pub(super) fn list_etendue(code: LinkCode, w: &SlotWeights, list: &[u32]) -> f32 {
    let (w, mask) = w.table();
    interleaved_sum(list, |l| w[code.slot(l) & mask])
}

/// Whether a node's links include an escape.
#[inline]
pub(super) fn has_escape(code: LinkCode, list: &[u32]) -> bool {
    let escape = code.escape();
    list.iter()
        .fold(false, |any, &l| any | (l & escape == escape))
}

/// The part of a node's W over its escaping links (the energy balance's escapes), in the
/// order of [`list_etendue`]. The build and the loader add it up once, for the nodes with
/// an escape (few in a closed scene), so a distribution does not walk every link for it.
pub(super) fn list_escape_etendue(code: LinkCode, w: &SlotWeights, list: &[u32]) -> f32 {
    let (w, mask) = w.table();
    let escape = code.escape();
    interleaved_sum(list, |l| {
        if l & escape == escape {
            w[code.slot(l) & mask]
        } else {
            0.0
        }
    })
}
