//! The passes a progressive render takes: their sizes, fixed by the target alone, so that a
//! film saved between passes resumes to the same image.

pub use crate::settings::MAX_SPP;

/// The sizes of successive passes: 1, 1, 2, 4, 8, 16, 16, ... (early images come quickly,
/// later passes are long enough to keep every thread busy).
pub(crate) fn next_pass(done: u32, target: u32) -> u32 {
    done.clamp(1, 16).min(target - done)
}

/// The passes, as (first sample, samples), that take a film from `done` samples per pixel
/// (a count between passes) to `target`.
pub(crate) fn passes_between(mut done: u32, target: u32) -> Vec<(u32, u32)> {
    let mut passes = Vec::new();
    while done < target {
        let n = next_pass(done, target);
        passes.push((done, n));
        done += n;
    }
    passes
}

/// Whether a render of `target` samples per pixel passes through `spp` whole samples (the
/// passes' sizes are fixed, so a film between passes can only hold certain counts).
pub(crate) fn reachable(spp: u32, target: u32) -> bool {
    let mut done = 0;
    while done < spp && done < target {
        done += next_pass(done, target);
    }
    done == spp
}
