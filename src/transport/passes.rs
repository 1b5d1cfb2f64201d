//! The passes a progressive render takes: their sizes, fixed by the target alone, so that a
//! film saved between passes resumes to the same image.

pub use crate::settings::MAX_SPP;

/// The largest pass of the usual schedule.
pub const MAX_PASS: u32 = 16;

/// The sizes of successive passes: 1, 1, 2, 4, 8, 16, 16, ... (early images come quickly,
/// later passes are long enough to keep every thread busy), none larger than `max_pass`
/// ([`MAX_PASS`], or 1 for techniques whose every sample index is an iteration of its own).
pub(crate) fn next_pass(done: u32, target: u32, max_pass: u32) -> u32 {
    done.clamp(1, max_pass.max(1)).min(target - done)
}

/// The passes, as (first sample, samples), that take a film from `done` samples per pixel
/// (a count between passes) to `target`.
pub(crate) fn passes_between(mut done: u32, target: u32, max_pass: u32) -> Vec<(u32, u32)> {
    let mut passes = Vec::new();
    while done < target {
        let n = next_pass(done, target, max_pass);
        passes.push((done, n));
        done += n;
    }
    passes
}

/// Whether a render of `target` samples per pixel passes through `spp` whole samples (the
/// passes' sizes are fixed, so a film between passes can only hold certain counts).
pub(crate) fn reachable(spp: u32, target: u32, max_pass: u32) -> bool {
    let mut done = 0;
    while done < spp && done < target {
        done += next_pass(done, target, max_pass);
    }
    done == spp
}
