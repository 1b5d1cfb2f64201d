//! A link end in 32 bits: the side key's offset in its key block and the side key at the other
//! end, so that the ends the linking holds until the assembly take half the memory.

use crate::integrators::illumination_network::MAX_KEY_BLOCK_BITS;

/// How a link end is packed into 32 bits: the side key's offset within its key block in the
/// high `block_bits`, the side key at the other end in the low `target_bits`. Half the bytes
/// of a (key, target) pair: the ends of every slot are held until the assembly (hundreds of
/// megabytes on large networks, all of it memory the system must first clear), and the
/// assembly streams them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EndPacking {
    pub block_bits: u32,
    pub target_bits: u32,
}

impl EndPacking {
    /// The packing for `keys` side keys: target bits for every key, and blocks of up to
    /// 2^[`MAX_KEY_BLOCK_BITS`] keys in the rest (at least 64 keys, a word of node marks).
    /// Networks of up to 2^23 side keys (millions of patches) all take the usual packing.
    pub fn for_keys(keys: usize) -> Result<EndPacking, String> {
        let needed = usize::BITS - keys.saturating_sub(1).leading_zeros();
        let target_bits = needed.max(Self::USUAL.target_bits);
        let block_bits = 32u32.saturating_sub(target_bits);
        if block_bits < 6 {
            return Err(format!(
                "the network would have {} patches, more than its 32-bit link ends can \
                 address ({}); use a larger patch_size",
                keys / 2,
                1u64 << 25
            ));
        }
        Ok(EndPacking {
            block_bits,
            target_bits,
        })
    }

    /// The packing of every network of up to 2^23 side keys: blocks of
    /// 2^[`MAX_KEY_BLOCK_BITS`] keys, the targets in the other bits. The loops over link ends
    /// are compiled for it apart ([`EndPacking::known`]), its shifts and masks constants.
    pub const USUAL: EndPacking = EndPacking {
        block_bits: MAX_KEY_BLOCK_BITS,
        target_bits: 32 - MAX_KEY_BLOCK_BITS,
    };

    /// The packing as a loop over link ends sees it: the usual one as a constant when `USUAL`
    /// (a loop is compiled twice, `f::<true>` run for the usual packing and `f::<false>` for
    /// others), else as read at run time. A shift by a count from memory takes a load and the
    /// count register; by a constant, neither.
    #[inline(always)]
    pub fn known<const USUAL: bool>(self) -> EndPacking {
        if USUAL {
            debug_assert_eq!(self, Self::USUAL);
            Self::USUAL
        } else {
            self
        }
    }

    /// Side keys per block.
    #[inline]
    pub fn block(&self) -> usize {
        1 << self.block_bits
    }

    /// The block of a side key (a shift: a division by the block's size, unknown to the
    /// compiler, would cost tens of cycles per link end).
    #[inline]
    pub fn block_of(&self, key: u32) -> usize {
        (key >> self.block_bits) as usize
    }

    #[inline]
    pub(super) fn pack(&self, key: u32, target: u32) -> u32 {
        (key & (self.block() as u32 - 1)) << self.target_bits | target
    }

    #[cfg(test)]
    /// The side key and the key at the other end of an end of block `block`.
    #[inline]
    pub fn unpack(&self, block: usize, end: u32) -> (u32, u32) {
        let key = (block << self.block_bits) as u32 | end >> self.target_bits;
        (key, end & ((1 << self.target_bits) - 1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packed_ends_round_trip() {
        // Small networks take the usual packing; larger ones give block bits to the targets.
        for (keys, block_bits) in [
            (3usize, 9u32),
            (151_722, 9),
            (1 << 23, 9),
            ((1 << 23) + 1, 8),
            (1 << 26, 6),
        ] {
            let p = EndPacking::for_keys(keys).unwrap();
            assert_eq!(p.block_bits, block_bits, "{keys} keys");
            assert_eq!(p == EndPacking::USUAL, block_bits == 9, "{keys} keys");
            assert!(p.block_bits + p.target_bits <= 32);
            let last = keys as u32 - 1;
            for key in [0, 1, last / 2, last] {
                let block = key as usize / p.block();
                for target in [0, 1, last / 3, last] {
                    let end = p.pack(key, target);
                    assert_eq!(p.unpack(block, end), (key, target), "{keys} keys");
                }
            }
        }
        let e = EndPacking::for_keys((1 << 26) + 1).unwrap_err();
        assert!(e.contains("patch_size"), "{e}");
    }
}
