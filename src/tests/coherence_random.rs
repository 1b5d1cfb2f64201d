//! The coherence engine against full renders on random sequences: random keyframed scenes
//! (objects that move, appear, vanish, change material or size; point lights that move,
//! dim or come and go; a camera keyframed to where it already is), random frame ranges and
//! image sizes, both grid placements, both record forms and both integrators, each frame
//! required to be identical bit for bit to its full render. The sequences go through
//! [`render_frames`], so the grids are placed exactly as `raylink animate` places them.

use crate::accel::Backend;
use crate::coherence::record::Records;
use crate::coherence::sequence::{render_frames, Coherence, Placement, SequenceMode};
use crate::control::Control;
use crate::integrators::technique::{MonteCarloSettings, WhittedSettings};
use crate::job::{Job, Technique};
use crate::render::PixelSampling;
use crate::scene::animation::Animation;
use std::fmt::Write as _;
use std::path::Path;

/// A small deterministic generator, so that a failing case can be rerun from its number.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        // SplitMix64.
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `lo..=hi`.
    fn int(&mut self, lo: i64, hi: i64) -> i64 {
        lo + (self.next() % (hi - lo + 1) as u64) as i64
    }

    /// Uniform in `[lo, hi)`, rounded to 1/64 so the scene text is exact.
    fn real(&mut self, lo: f64, hi: f64) -> f64 {
        let x = lo + (hi - lo) * (self.next() >> 11) as f64 / (1u64 << 53) as f64;
        (x * 64.0).round() / 64.0
    }

    fn chance(&mut self, p: f64) -> bool {
        self.real(0.0, 1.0) < p
    }

    fn vec3(&mut self, lo: [f64; 3], hi: [f64; 3]) -> String {
        format!(
            "[{}, {}, {}]",
            self.real(lo[0], hi[0]),
            self.real(lo[1], hi[1]),
            self.real(lo[2], hi[2])
        )
    }
}

const MATERIALS: [&str; 4] = ["matte", "mirror", "glass", "shiny"];

/// Keyframes for one object or light: `keys` at random frames of `0..frames`, each made by
/// `value`, with a random interpolation.
fn keyframes(
    rng: &mut Rng,
    table: &str,
    frames: i64,
    value: &mut dyn FnMut(&mut Rng) -> String,
) -> String {
    let mut s = String::new();
    let mut frame = rng.int(0, 1);
    while frame < frames {
        let interpolation = ["linear", "smooth", "step"][rng.int(0, 2) as usize];
        let _ = writeln!(
            s,
            "[[{table}.keyframes]]\nframe = {frame}\ninterpolation = \"{interpolation}\"\n{}",
            value(rng)
        );
        frame += rng.int(1, 3);
    }
    s
}

/// A random animated scene of `frames` frames.
fn scene(rng: &mut Rng, frames: i64) -> String {
    let (w, h) = (rng.int(6, 40), rng.int(5, 30));
    let mut s = format!(
        "[animation]\nframes = {frames}\n\n[camera]\nposition = [0, 1.5, 6]\n\
         look_at = [0, 0.7, 0]\nfov = {}\nwidth = {w}\nheight = {h}\n",
        rng.int(30, 60)
    );
    if rng.chance(0.3) {
        // A camera keyframed to where it already is: nothing changes.
        s.push_str("[[camera.keyframes]]\nframe = 0\nposition = [0, 1.5, 6]\n");
    }
    let _ = write!(
        s,
        "\n[world]\nambient = {}\nbackground = {}\n\n",
        rng.real(0.0, 0.2),
        rng.vec3([0.0; 3], [0.6; 3])
    );
    s.push_str(
        "[materials.matte]\ndiffuse = 0.7\n\n[materials.mirror]\ndiffuse = 0.1\nspecular = 0.8\n\n\
         [materials.glass]\ndiffuse = 0.05\nspecular = 0.1\ntransmission = 0.85\nior = 1.5\n\n\
         [materials.shiny]\ndiffuse = 0.5\nspecular = 0.3\nphong_exponent = 40\n\n",
    );
    if rng.chance(0.5) {
        s.push_str(&keyframes(rng, "materials.matte", frames, &mut |r| {
            format!("diffuse = {}", r.vec3([0.1; 3], [0.9; 3]))
        }));
    }
    s.push_str(
        "[[shapes]]\ntype = \"quad\"\nmaterial = \"matte\"\n\
         vertices = [[-4, 0, 3], [4, 0, 3], [4, 0, -6], [-4, 0, -6]]\n\n",
    );
    for _ in 0..rng.int(1, 4) {
        let material = MATERIALS[rng.int(0, 3) as usize];
        if rng.chance(0.7) {
            let _ = write!(
                s,
                "[[shapes]]\ntype = \"sphere\"\nmaterial = \"{material}\"\ncenter = {}\n\
                 radius = {}\n",
                rng.vec3([-2.0, 0.2, -2.0], [2.0, 1.5, 1.5]),
                rng.real(0.1, 0.7)
            );
        } else {
            let _ = write!(
                s,
                "[[shapes]]\ntype = \"quad\"\nmaterial = \"{material}\"\n\
                 vertices = [[-0.5, 0, 0], [0.5, 0, 0], [0.5, 1, 0], [-0.5, 1, 0]]\n\
                 transform = {{ translate = {} }}\n",
                rng.vec3([-2.0, 0.0, -2.0], [2.0, 0.5, 1.0])
            );
        }
        if rng.chance(0.7) {
            let far = rng.chance(0.15);
            s.push_str(&keyframes(rng, "shapes", frames, &mut |r| {
                let mut k = if far && r.chance(0.5) {
                    // Out of the scene's box, so that an online grid must grow.
                    format!(
                        "translate = {}\n",
                        r.vec3([-9.0, 0.0, -9.0], [9.0, 6.0, 2.0])
                    )
                } else {
                    format!(
                        "translate = {}\n",
                        r.vec3([-1.0, -0.2, -1.0], [1.0, 0.8, 1.0])
                    )
                };
                if r.chance(0.3) {
                    k.push_str(if r.chance(0.5) {
                        "visible = false\n"
                    } else {
                        "visible = true\n"
                    });
                }
                if r.chance(0.2) {
                    let _ = writeln!(k, "scale = {}", r.real(0.5, 1.5));
                }
                k
            }));
        }
        s.push('\n');
    }
    for _ in 0..rng.int(1, 2) {
        let _ = write!(
            s,
            "[[lights]]\ntype = \"point\"\nposition = {}\nintensity = {}\n",
            rng.vec3([-4.0, 2.0, -2.0], [4.0, 7.0, 6.0]),
            rng.real(20.0, 200.0)
        );
        let (moves, dims) = (rng.chance(0.4), rng.chance(0.6));
        if moves || dims {
            s.push_str(&keyframes(rng, "lights", frames, &mut |r| {
                let mut k = String::new();
                if moves {
                    let _ = writeln!(
                        k,
                        "position = {}",
                        r.vec3([-4.0, 2.0, -2.0], [4.0, 7.0, 6.0])
                    );
                }
                if dims {
                    let _ = writeln!(k, "intensity = {}", r.real(0.0, 200.0));
                }
                k
            }));
        }
        s.push('\n');
    }
    s
}

/// One random case: its scene text and a sequence job over a random range of its frames.
fn case(n: u64) -> (String, Job, Vec<i64>, Coherence) {
    let mut rng = Rng(0x5eed_0000 + n);
    let frames = rng.int(2, 6);
    let text = scene(&mut rng, frames);
    let first = rng.int(0, frames - 2);
    let last = rng.int(first + 1, frames - 1);
    let (w, h) = (rng.int(4, 40) as u32, rng.int(3, 30) as u32);
    let technique = if rng.chance(0.7) {
        Technique::Whitted(WhittedSettings {
            max_depth: rng.int(1, 6) as u32,
            area_samples: 1,
            fresnel: rng.chance(0.5),
            sampling: if rng.chance(0.5) {
                PixelSampling::Adaptive {
                    threshold: 0.1,
                    max_depth: 1,
                }
            } else {
                PixelSampling::Uniform { n: 1 }
            },
        })
    } else {
        Technique::Path(MonteCarloSettings {
            max_depth: rng.int(1, 4) as u32,
            spp: rng.int(1, 2) as u32,
            time_limit: None,
            filter: Default::default(),
            reconstruction: crate::image::filter::Reconstruction::Importance,
            adaptive: None,
            max_component_value: None,
            guiding: false,
            spectral: false,
        })
    };
    let job = Job {
        technique,
        width: w,
        height: h,
        region: None,
        seed: n,
        threads: Some(rng.int(1, 2) as usize),
        accel: Backend::Embree,
        statistics: false,
    };
    let coherence = Coherence {
        mode: SequenceMode::Verify,
        records: if rng.chance(0.7) {
            Records::Segments
        } else {
            Records::Tables
        },
        voxels: [64, 512, 4096][rng.int(0, 2) as usize],
        blocks: (
            rng.int(1, w.min(16) as i64) as u32,
            rng.int(1, h.min(16) as i64) as u32,
        ),
        overhead_reps: 0,
        placement: Placement::Online,
    };
    (text, job, (first..=last).collect(), coherence)
}

/// Cases per run: a few hundred in the test suite's time; `RAYLINK_RANDOM_SEQUENCES` runs
/// more.
fn count() -> u64 {
    std::env::var("RAYLINK_RANDOM_SEQUENCES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(240)
}

#[test]
fn random_sequences_match_their_full_renders_in_both_placements() {
    let control = Control::default();
    let (mut frames, mut regrown) = (0, 0);
    for n in 0..count() {
        let (text, job, numbers, coherence) = case(n);
        let anim = Animation::from_str(&text, Path::new("random.toml"))
            .unwrap_or_else(|e| panic!("case {n}: the scene does not read: {e}\n{text}"));
        for placement in [Placement::Online, Placement::Lookahead] {
            let coherence = Coherence {
                placement,
                ..coherence.clone()
            };
            let report = render_frames(
                &anim,
                &job,
                &numbers,
                &coherence,
                &control,
                &mut |_, _, _| Ok(()),
            )
            .unwrap_or_else(|e| panic!("case {n} ({placement:?}): {e}\n{text}"));
            for row in &report.rows {
                assert_eq!(
                    row.identical,
                    Some(true),
                    "case {n} ({placement:?}, {:?}, frames {:?}): frame {} differs from its \
                     full render\n{text}",
                    job.technique,
                    numbers,
                    row.frame
                );
            }
            frames += report.rows.len();
            regrown += report.regrids;
        }
    }
    eprintln!(
        "{} sequences, {frames} frames verified, online grid grew {regrown} times",
        2 * count()
    );
    // The generator reaches the paths it is meant to: grids that grow.
    assert!(regrown > 0, "no online grid grew");
}
