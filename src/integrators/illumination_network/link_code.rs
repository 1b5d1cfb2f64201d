//! How a node's link is stored in 32 bits: its slot and the node at the other end.

use super::ESCAPE;

/// How a node's link is stored in 32 bits: its slot in the high bits, the node at the other
/// end in the low ones (all ones: the line leaves the scene). Half of a node's slots have no
/// link on average, so a list of its links takes about half the memory of the paper's row of
/// one entry per slot, and the slot bits cost nothing a row index did not.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LinkCode {
    pub(super) target_bits: u32,
}

impl LinkCode {
    /// The code for `slots` slots and `keys` side keys (nodes are at most as many).
    pub fn new(slots: usize, keys: usize) -> Result<LinkCode, String> {
        let slot_bits = (usize::BITS - slots.saturating_sub(1).leading_zeros()).max(1);
        let target_bits = 32u32.saturating_sub(slot_bits);
        if keys as u64 >= 1u64 << target_bits {
            return Err(format!(
                "the network would have {} patch sides, more than its 32-bit links can address \
                 at {slots} slots per patch ({}); use a larger patch_size or fewer slopes",
                keys,
                (1u64 << target_bits) - 1
            ));
        }
        Ok(LinkCode { target_bits })
    }

    /// The target bits of an escape (and a mask of the target bits).
    #[inline]
    pub(super) fn escape(self) -> u32 {
        (1 << self.target_bits) - 1
    }

    /// A link of `slot` to node `target` (or [`ESCAPE`]).
    #[inline]
    pub fn pack(self, slot: u32, target: u32) -> u32 {
        let t = if target == ESCAPE {
            self.escape()
        } else {
            target
        };
        slot << self.target_bits | t
    }

    /// A link of `slot` to a node (not an escape).
    #[inline]
    pub(super) fn pack_node(self, slot: u32, node: u32) -> u32 {
        slot << self.target_bits | node
    }

    #[inline]
    pub fn slot(self, link: u32) -> usize {
        (link >> self.target_bits) as usize
    }

    /// The node at the other end, or [`ESCAPE`].
    #[inline]
    pub fn target(self, link: u32) -> u32 {
        let t = link & self.escape();
        if t == self.escape() {
            ESCAPE
        } else {
            t
        }
    }

    /// The other end's bits as they are: an escape is larger than any node (the loader's
    /// checks compare them without a branch).
    #[inline]
    pub fn raw_target(self, link: u32) -> usize {
        (link & self.escape()) as usize
    }
}
