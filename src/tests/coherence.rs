//! Object-space temporal coherence (Jevans 1992): the DDA against brute force, every
//! incremental frame against its full render bit for bit, and which blocks get retraced.
//! (`raylink animate` is tested in `tests/coherence.rs`.)

use super::coherence_scenes::{animated, BASE, MOVING};
use crate::accel::{self, Backend, Update};
use crate::coherence::changes::{surface_boxes, Changes, FrameSummary};
use crate::coherence::grid::Grid;
use crate::coherence::record::Records;
use crate::coherence::renderer::{CoherentRenderer, FrameStats};
use crate::coherence::sequence::{
    lookahead_grid, Coherence, Integrators, Placement, Sequence, SequenceMode,
};
use crate::coherence::tables::BlockLayout;
use crate::control::Control;
use crate::image::Image;
use crate::integrators::technique::{MonteCarloSettings, WhittedSettings};
use crate::integrators::whitted::WhittedOptions;
use crate::job::{Job, Technique};
use crate::math::Vec3;
use crate::render::PixelSampling;
use crate::scene::animation::Animation;
use crate::scene::{Geometry, QuadMesh, Sphere, TriangleMesh};
use crate::transport::Context;
use std::collections::BTreeSet;
use std::path::Path;

// ---------------------------------------------------------------------------------------
// The DDA.

/// A small deterministic generator (the test must not depend on the library's streams).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// The parameter range over which the segment is inside the box, if any (slab test).
fn overlap(o: Vec3, d: Vec3, t0: f32, t1: f32, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
    let (mut a, mut b) = (t0, t1);
    for k in 0..3 {
        if d[k] == 0.0 {
            if o[k] < lo[k] || o[k] > hi[k] {
                return None;
            }
            continue;
        }
        let (mut x, mut y) = ((lo[k] - o[k]) / d[k], (hi[k] - o[k]) / d[k]);
        if x > y {
            std::mem::swap(&mut x, &mut y);
        }
        a = a.max(x);
        b = b.min(y);
    }
    (a <= b).then_some((a, b))
}

#[test]
fn dda_visits_exactly_the_voxels_a_segment_crosses() {
    let grid = Grid::new(
        Vec3::new(-1.0, -2.0, 0.5),
        Vec3::new(3.0, 1.0, 2.5),
        [7, 5, 4],
    );
    let mut rng = Lcg(7);
    let mut checked = 0;
    for i in 0..3000 {
        // Segments that start inside, outside, and some along an axis.
        let p = |r: &mut Lcg| {
            Vec3::new(
                r.next() * 6.0 - 2.0,
                r.next() * 5.0 - 3.0,
                r.next() * 4.0 - 0.5,
            )
        };
        let o = p(&mut rng);
        let mut d = p(&mut rng) - o;
        if i % 10 == 0 {
            d.y = 0.0;
        }
        if i % 15 == 0 {
            d.z = 0.0;
        }
        if d == Vec3::ZERO {
            continue;
        }
        let (t0, t1) = if i % 3 == 0 {
            (0.0, f32::INFINITY)
        } else {
            (0.0, 1.0)
        };
        let mut visited = Vec::new();
        grid.walk(o, d, t0, t1, |v| visited.push(v));
        let set: BTreeSet<usize> = visited.iter().copied().collect();
        assert_eq!(set.len(), visited.len(), "a voxel visited twice");
        for v in 0..grid.len() {
            let (lo, hi) = grid.voxel_box(v);
            // Crossed for sure: the segment runs a clear stretch inside the shrunken box.
            let e = 1e-4;
            let clear = overlap(o, d, t0, t1, lo + e, hi - e)
                .is_some_and(|(a, b)| (b - a) * d.length() > 1e-3);
            // Possibly crossed: it touches the grown box.
            let touched = overlap(o, d, t0, t1, lo - e, hi + e).is_some();
            if clear {
                assert!(
                    set.contains(&v),
                    "segment {i} crosses voxel {v} but the DDA missed it"
                );
            }
            if set.contains(&v) {
                assert!(
                    touched,
                    "segment {i}: the DDA visited voxel {v}, which it does not cross"
                );
            }
            checked += clear as usize;
        }
    }
    assert!(
        checked > 5000,
        "the random segments cross voxels ({checked})"
    );
}

/// A change marks the voxels the changed objects' surfaces touch: the boxes must cover
/// every point of the surface, be no larger than asked, and leave out what is far from it.
#[test]
fn surface_boxes_cover_the_surface_and_nothing_far_from_it() {
    let mut rng = Lcg(11);
    let inside = |boxes: &[(Vec3, Vec3)], p: Vec3| {
        let e = 1e-5 * (1.0 + p.abs().max_element());
        boxes
            .iter()
            .any(|(lo, hi)| p.cmpge(*lo - e).all() && p.cmple(*hi + e).all())
    };
    let size = 0.1;
    // A sphere: points on it are covered, its centre is not.
    let (center, radius) = (Vec3::new(0.3, -1.0, 2.0), 0.7);
    let sphere = Geometry::Sphere(Sphere { center, radius });
    let mut boxes = Vec::new();
    surface_boxes(&sphere, size, &mut boxes);
    for _ in 0..2000 {
        let d = Vec3::new(rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5);
        if d.length() > 1e-3 {
            let p = center + d.normalize() * radius;
            assert!(inside(&boxes, p), "sphere point {p} not covered");
        }
    }
    assert!(!inside(&boxes, center), "the sphere's centre is marked");
    // Triangles much larger than the boxes, and quads (not necessarily cut the same way by
    // every backend): points on them are covered, a point off their plane is not.
    let corners = [
        Vec3::new(-2.0, 0.0, -2.0),
        Vec3::new(2.0, 0.3, -2.0),
        Vec3::new(2.0, 0.6, 2.0),
        Vec3::new(-2.0, 0.3, 2.0),
    ];
    let tri = Geometry::Triangles(TriangleMesh {
        positions: corners.to_vec(),
        indices: vec![[0, 1, 2], [0, 2, 3]],
        ..Default::default()
    });
    let quad = Geometry::Quads(QuadMesh {
        positions: corners.to_vec(),
        indices: vec![[0, 1, 2, 3]],
    });
    for g in [&tri, &quad] {
        let mut boxes = Vec::new();
        surface_boxes(g, size, &mut boxes);
        for (lo, hi) in &boxes {
            assert!(
                (*hi - *lo).max_element() <= size * 1.0001,
                "box larger than asked"
            );
        }
        for i in 0..4000 {
            let (mut u, mut v) = (rng.next(), rng.next());
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            let t = [[0, 1, 2], [0, 2, 3]][i % 2].map(|k| corners[k]);
            let p = t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v;
            assert!(inside(&boxes, p), "point {p} not covered");
        }
        assert!(!inside(&boxes, Vec3::new(0.0, 1.5, 0.0)));
    }
}

// ---------------------------------------------------------------------------------------
// Incremental frames against full renders.

#[derive(Clone, Copy, PartialEq)]
enum Kind {
    Whitted,
    Path,
}

fn bits(image: &Image) -> Vec<[u32; 3]> {
    image
        .pixels
        .iter()
        .map(|p| p.to_array().map(f32::to_bits))
        .collect()
}

/// The job and the sequence settings `raylink animate` would use (`--verify`, segment
/// records, 4096 voxels, one of the two placements), with the test's integrator settings.
fn sequence_job(
    kind: Kind,
    (w, h): (u32, u32),
    blocks: (u32, u32),
    placement: Placement,
) -> (Job, Coherence) {
    let technique = match kind {
        Kind::Whitted => Technique::Whitted(WhittedSettings {
            max_depth: WhittedOptions::default().max_depth,
            area_samples: 4,
            fresnel: WhittedOptions::default().fresnel,
            sampling: PixelSampling::Adaptive {
                threshold: 0.1,
                max_depth: 1,
            },
        }),
        Kind::Path => Technique::Path(MonteCarloSettings {
            max_depth: 4,
            spp: 4,
            time_limit: None,
            filter: Default::default(),
            reconstruction: crate::image::filter::Reconstruction::Importance,
            adaptive: None,
            max_component_value: None,
            guiding: false,
            spectral: false,
        }),
    };
    let job = Job {
        technique,
        width: w,
        height: h,
        region: None,
        seed: 3,
        threads: Some(2),
        accel: Backend::Embree,
        statistics: false,
    };
    let coherence = Coherence {
        mode: SequenceMode::Verify,
        records: Records::Segments,
        voxels: 4096,
        blocks,
        overhead_reps: 0,
        placement,
    };
    (job, coherence)
}

/// Renders every frame incrementally and from scratch; asserts they are identical and
/// returns the per-frame statistics and the images. The grids are those `raylink animate`
/// places: over the changes for the look-ahead renderers (four ways of keeping records, which
/// must retrace the same blocks), and over the scene, growing, for the online one.
fn run(text: &str, kind: Kind, blocks: (u32, u32)) -> Vec<(FrameStats, Image)> {
    let anim = Animation::from_str(text, Path::new("test.toml")).expect("the scene reads");
    let frames: Vec<i64> = anim.frame_numbers().collect();
    let scenes: Vec<_> = frames.iter().map(|&f| anim.scene_at(f).unwrap()).collect();
    let size = (scenes[0].camera.width, scenes[0].camera.height);
    let (job, coherence) = sequence_job(kind, size, blocks, Placement::Lookahead);
    let integrators = Integrators::for_job(&job).unwrap();
    let engine = integrators.engine(&job);
    let changes: Vec<Changes> = scenes
        .windows(2)
        .map(|w| FrameSummary::new(&w[0], None).diff(&FrameSummary::new(&w[1], None)))
        .collect();
    let grid = lookahead_grid(&changes, coherence.voxels);
    let layout = BlockLayout::new(size.0, size.1, blocks.0, blocks.1);
    // The paper's voxel tables, recording everywhere.
    let mut r = CoherentRenderer::with_records(grid.clone(), layout, Records::Tables);
    // Segment records, everywhere, and (what `raylink animate --lookahead` does) only where a
    // later frame changes something: both must retrace exactly the same blocks.
    let mut segments = CoherentRenderer::with_records(grid.clone(), layout, Records::Segments);
    // Segment records over their memory budget after frame 0: turned into tables.
    let mut switched = CoherentRenderer::with_records(grid.clone(), layout, Records::Segments);
    switched.set_segment_budget(1);
    let mut sparse = CoherentRenderer::new(grid, layout);
    let marked: Vec<Vec<_>> = changes.iter().map(|c| sparse.surface_boxes(c)).collect();
    sparse.restrict_to_sequence(&marked);
    // Online, as `raylink animate` makes frames by default.
    let (job, coherence) = sequence_job(kind, size, blocks, Placement::Online);
    let mut online = Sequence::new(&job, &coherence).unwrap();
    let mut out = Vec::new();
    // The incremental renderer moves one dynamic structure (Embree refits what moved); each
    // full render builds its own static one.
    let control = Control::default();
    let mut dynamic = accel::build_dynamic(&scenes[0], Backend::Embree, &control).unwrap();
    for (f, scene) in frames.iter().zip(&scenes) {
        dynamic.update(scene).unwrap();
        let (image, stats) = r
            .render_frame(scene, dynamic.as_ref(), &engine, &control)
            .unwrap();
        let others = [
            (&mut segments, "segment records"),
            (&mut switched, "segments turned into tables"),
            (&mut sparse, "sparse"),
        ];
        let mut blocks = Vec::new();
        for (other, what) in others {
            let (image2, stats2) = other
                .render_frame(scene, dynamic.as_ref(), &engine, &control)
                .unwrap();
            assert!(bits(&image) == bits(&image2), "frame {f}: {what}");
            blocks.push(stats2.blocks);
        }
        // Tables retrace what their voxels saw; segments walk the changed voxels cut finer
        // around the changed surfaces, so they retrace those blocks or fewer, wherever they
        // are recorded.
        assert_eq!(
            blocks[1], stats.blocks,
            "frame {f}: segments turned into tables"
        );
        assert_eq!(blocks[2], blocks[0], "frame {f}: sparse");
        let subset = blocks[0].iter().all(|b| stats.blocks.contains(b));
        assert!(
            subset,
            "frame {f}: segment records retrace a block tables do not"
        );
        let accel = accel::build(scene, Backend::Embree, &control).unwrap();
        let (full, _) = engine
            .render_full(
                &Context::with_light_selection(
                    scene,
                    accel.as_ref(),
                    crate::coherence::LIGHT_SELECTION,
                ),
                &control,
            )
            .unwrap();
        assert!(
            bits(&image) == bits(&full),
            "frame {f}: the incremental frame differs from the full render"
        );
        let (image3, row) = online.next(*f, scene, &control, true).unwrap();
        assert_eq!(row.identical, Some(true), "frame {f}: online");
        assert!(bits(&image3) == bits(&full), "frame {f}: online");
        out.push((stats, image));
    }
    assert_eq!(switched.records(), Records::Tables);
    assert_eq!(segments.records(), Records::Segments);
    out
}

/// Frames 1 and 2 retrace part of the image, frame 3 (at rest) nothing.
fn check_moving(frames: &[(FrameStats, Image)], total: usize) {
    assert_eq!(frames[0].0.blocks_retraced, total);
    for (f, frame) in frames.iter().enumerate().take(3).skip(1) {
        let n = frame.0.blocks_retraced;
        assert!(
            n > 0 && n < total,
            "frame {f}: {n} of {total} blocks retraced"
        );
    }
    assert_eq!(frames[3].0.blocks_retraced, 0);
    assert_eq!(frames[3].0.rays.total(), 0);
}

#[test]
fn whitted_moving_object_matches_full_renders() {
    let frames = run(&animated("", MOVING), Kind::Whitted, (16, 12));
    check_moving(&frames, 16 * 12);
    // Section 3.3.3: some retraced camera rays, not all, get their stored hit (`run` has
    // checked that the frames are still those of full renders).
    check_camera_reuse(&frames);
    // Some samples, not all, keep their value without being shaded again.
    let (shaded, rays) = (frames[2].0.samples_reused, frames[2].0.camera_rays);
    assert!(frames[1].0.samples_reused == 0 && shaded > 0 && shaded < rays);
}

/// Frame 2 answers some camera rays of the blocks it retraces from the hits stored when
/// frame 1 retraced them, and queries the others; frame 0, traced in full, keeps none, and
/// frame 1 has none to reuse.
fn check_camera_reuse(frames: &[(FrameStats, Image)]) {
    assert_eq!(frames[0].0.camera_rays, 0);
    assert!(frames[1].0.camera_rays > 0);
    assert_eq!(frames[1].0.camera_reused, 0);
    let (reused, rays) = (frames[2].0.camera_reused, frames[2].0.camera_rays);
    assert!(
        reused > 0 && reused < rays,
        "{reused} of {rays} camera rays reused"
    );
    // So are some shadow rays (frame 1's are new).
    assert!(frames[1].0.others_reused == 0 && frames[2].0.others_reused > 0);
}

/// A shape that vanishes from the front of the shape list renumbers the others: a stored
/// camera hit names a shape by its index, and must not be reused when the index now names
/// another shape, though nothing changed along the ray.
#[test]
fn camera_hits_follow_renumbered_shapes() {
    let first = r#"
[[shapes]]
type = "sphere"
material = "mirror"
center = [0.9, 0.4, -0.8]
radius = 0.4
[[shapes.keyframes]]
frame = 0
translate = [0, 0, 0]
visible = true
interpolation = "step"
[[shapes.keyframes]]
frame = 1
translate = [0, 0.1, 0]
[[shapes.keyframes]]
frame = 2
visible = false
"#;
    let text = animated("", "").replacen("[[shapes]]", &format!("{first}\n[[shapes]]"), 1);
    for kind in [Kind::Whitted, Kind::Path] {
        let frames = run(&no_sky(&text), kind, (8, 6));
        let n: Vec<usize> = frames.iter().map(|f| f.0.blocks_retraced).collect();
        assert!(n[1] > 0 && n[1] < 48 && n[2] > 0 && n[3] == 0, "{n:?}");
        // Frame 2 retraces blocks that frame 1 retraced and kept the answers of.
        assert!(frames[2].0.camera_reused > 0);
    }
}

/// The path tracer chooses lights by power, and the sky's power depends on the scene's
/// bounding sphere: with a sky, a moving object changes every pixel's light choice.
fn no_sky(text: &str) -> String {
    text.replace("background = [0.3, 0.5, 0.85]", "background = 0")
}

#[test]
fn path_moving_object_matches_full_renders() {
    let frames = run(&no_sky(&animated("", MOVING)), Kind::Path, (8, 6));
    check_moving(&frames, 8 * 6);
    // With a sky, every frame in motion is traced in full, and still equals the full render.
    let frames = run(&animated("", MOVING), Kind::Path, (8, 6));
    let n: Vec<usize> = frames.iter().map(|f| f.0.blocks_retraced).collect();
    assert_eq!(n, [48, 48, 48, 0]);
}

/// A tetrahedron mesh: moved by refitting Embree's BVH, not rebuilding it.
const MOVING_MESH: &str = r#"
[[shapes]]
type = "mesh"
material = "mirror"
positions = [[0.5, 0, -0.5], [1.5, 0, -0.5], [1, 0, 0.4], [1, 1.2, -0.2]]
indices = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]]

[[shapes.keyframes]]
frame = 0
rotate = { axis = [0, 1, 0], degrees = 0 }
translate = [0, 0.8, 0]
[[shapes.keyframes]]
frame = 2
rotate = { axis = [0, 1, 0], degrees = 40 }
translate = [0, 0, 0]
"#;

#[test]
fn moving_mesh_matches_full_renders() {
    for kind in [Kind::Whitted, Kind::Path] {
        let frames = run(&no_sky(&animated("", MOVING_MESH)), kind, (8, 6));
        check_moving(&frames, 8 * 6);
    }
}

const APPEARING: &str = r#"
[[shapes]]
type = "sphere"
material = "mirror"
center = [0.9, 0.4, -0.8]
radius = 0.4
[[shapes.keyframes]]
frame = 0
visible = false
[[shapes.keyframes]]
frame = 1
visible = true
[[shapes.keyframes]]
frame = 3
visible = false
"#;

#[test]
fn added_and_removed_object_match_full_renders() {
    for kind in [Kind::Whitted, Kind::Path] {
        let frames = run(&animated("", APPEARING), kind, (12, 9));
        let n: Vec<usize> = frames.iter().map(|f| f.0.blocks_retraced).collect();
        assert!(n[1] > 0 && n[1] < 108 && n[2] == 0 && n[3] > 0, "{n:?}");
        // Removing the object brings back frame 0 exactly.
        assert_eq!(bits(&frames[3].1), bits(&frames[0].1));
    }
}

#[test]
fn material_change_matches_full_renders() {
    let text = animated(
        "",
        r#"
[[materials.glass.keyframes]]
frame = 1
transmission = 0.85
[[materials.glass.keyframes]]
frame = 3
transmission = 0.2
"#,
    );
    for kind in [Kind::Whitted, Kind::Path] {
        let frames = run(&text, kind, (12, 9));
        let n: Vec<usize> = frames.iter().map(|f| f.0.blocks_retraced).collect();
        assert!(n[1] == 0 && n[2] > 0 && n[2] < 108, "{n:?}");
    }
}

#[test]
fn moving_and_dimming_light_match_full_renders() {
    // A matte sphere: the side turned away from the light sends no shadow ray to it, yet
    // lights up when the light moves round (so a moved light cannot rely on shadow tables).
    let text = format!(
        "[animation]\nframes = 4\n{BASE}{}",
        r#"
[[shapes]]
type = "sphere"
material = "wall"
center = [1, 0.5, 0.5]
radius = 0.5

[[lights]]
type = "point"
position = [-4, 3, 1]
intensity = 180
[[lights.keyframes]]
frame = 0
position = [-4, 3, 1]
intensity = 180
[[lights.keyframes]]
frame = 1
position = [-4, 3, 1]
intensity = 100
[[lights.keyframes]]
frame = 2
position = [4, 3, 1]
"#
    );
    let total = 48 * 36;
    for kind in [Kind::Whitted, Kind::Path] {
        let frames = run(&no_sky(&text), kind, (48, 36));
        let n: Vec<usize> = frames.iter().map(|f| f.0.blocks_retraced).collect();
        // Dimming retraces what the light reached (not the sky); moving it, every block that
        // found a surface; at rest, nothing.
        assert!(n[1] > 0 && n[1] < total, "{n:?}");
        assert!(n[2] > n[1] && n[2] < total, "{n:?}");
        assert_eq!(n[3], 0, "{n:?}");
    }
}

#[test]
fn change_outside_every_ray_path_retraces_nothing() {
    // A sphere moving behind the camera, under the floor: no ray reaches it.
    let text = animated(
        "",
        r#"
[[shapes]]
type = "sphere"
material = "mirror"
center = [0, -3, 9]
radius = 0.5
[[shapes.keyframes]]
frame = 0
translate = [0, 0, 0]
[[shapes.keyframes]]
frame = 3
translate = [1, -1, 0]
"#,
    );
    let frames = run(&text, Kind::Whitted, (16, 12));
    for (f, (stats, _)) in frames.iter().enumerate().skip(1) {
        assert_eq!(stats.blocks_retraced, 0, "frame {f}");
        assert!(stats.changed_voxels > 0, "frame {f}: the move marks voxels");
    }
}

#[test]
fn change_to_the_only_object_in_view_retraces_its_pixels() {
    // One sphere against a black sky, one block per pixel; its colour changes.
    let text = r#"
[animation]
frames = 2
[camera]
position = [0, 0, 6]
look_at = [0, 0, 0]
fov = 30
width = 32
height = 24
[materials.m]
diffuse = 0.5
[[materials.m.keyframes]]
frame = 0
diffuse = 0.5
[[materials.m.keyframes]]
frame = 1
diffuse = [0.2, 0.6, 0.2]
[[shapes]]
type = "sphere"
material = "m"
center = [0, 0, 0]
radius = 1
[[lights]]
type = "point"
position = [0, 4, 6]
intensity = 50
"#;
    let frames = run(text, Kind::Whitted, (32, 24));
    let retraced: BTreeSet<usize> = frames[1].0.blocks.iter().copied().collect();
    let (a, b) = (&frames[0].1, &frames[1].1);
    let mut changed = 0;
    for i in 0..a.pixels.len() {
        if a.pixels[i] != b.pixels[i] {
            changed += 1;
            assert!(
                retraced.contains(&i),
                "pixel {i} changed but was not retraced"
            );
        }
    }
    assert!(changed > 50, "the sphere covers pixels ({changed})");
    // Rays in the corners pass far from the sphere's voxels.
    for corner in [0, 31, 32 * 23, 32 * 24 - 1] {
        assert!(
            !retraced.contains(&corner),
            "corner pixel {corner} retraced"
        );
    }
}

// ---------------------------------------------------------------------------------------
// Embree updates.

#[test]
fn embree_refits_moved_meshes_and_answers_like_a_fresh_build() {
    let anim = Animation::from_str(&animated("", MOVING_MESH), Path::new("t.toml")).unwrap();
    let mut dynamic = accel::build_dynamic(
        &anim.scene_at(0).unwrap(),
        Backend::Embree,
        &Control::default(),
    )
    .unwrap();
    let mut rng = Lcg(11);
    for (f, expected) in [
        (1, Update::Refit(1)),
        (2, Update::Refit(1)),
        (3, Update::Unchanged),
    ] {
        let scene = anim.scene_at(f).unwrap();
        assert_eq!(dynamic.update(&scene).unwrap(), expected, "frame {f}");
        let fresh = accel::build(&scene, Backend::Embree, &Control::default()).unwrap();
        let mut hits = 0;
        for _ in 0..20000 {
            let o = Vec3::new(
                rng.next() * 4.0 - 2.0,
                rng.next() * 3.0,
                rng.next() * 4.0 - 2.0,
            );
            let d = Vec3::new(rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5);
            let ray = crate::math::Ray::new(o, d);
            let (a, b) = (dynamic.intersect(&ray), fresh.intersect(&ray));
            assert_eq!(a, b, "frame {f}: {ray:?}");
            assert_eq!(dynamic.occluded(&ray), fresh.occluded(&ray));
            hits += a.is_some_and(|h| h.geom_id == 2) as usize;
        }
        assert!(hits > 100, "rays hit the moving mesh ({hits})");
    }
    // A shape appearing changes the geometry list: the scene is built again.
    let anim = Animation::from_str(&animated("", APPEARING), Path::new("t.toml")).unwrap();
    let mut dynamic = accel::build_dynamic(
        &anim.scene_at(0).unwrap(),
        Backend::Embree,
        &Control::default(),
    )
    .unwrap();
    assert_eq!(
        dynamic.update(&anim.scene_at(1).unwrap()).unwrap(),
        Update::Rebuilt
    );
}

// ---------------------------------------------------------------------------------------
// The recorder.

/// Two recorders alive on one thread at once (not what the renderer does, but nothing
/// forbids it): the second cannot use the thread's buffer and keeps its own; each gets
/// exactly its own segments.
#[test]
fn recorders_sharing_a_thread_keep_their_own_segments() {
    use crate::accel::Accel;
    use crate::coherence::grid::ActiveVoxels;
    use crate::coherence::record::RecordingAccel;
    use crate::math::Ray;
    let scene = Animation::from_str(&animated("", MOVING), Path::new("t.toml"))
        .unwrap()
        .scene_at(0)
        .unwrap();
    let accel = accel::build(&scene, Backend::Embree, &Control::default()).unwrap();
    let (lo, hi) = scene.bounds().unwrap();
    let voxels = ActiveVoxels::all(Grid::new(lo, hi, [8, 8, 8]));
    let down = |x: f32| Ray::new(Vec3::new(x, 5.0, 0.0), Vec3::new(0.0, -1.0, 0.0));
    for swapped in [false, true] {
        let first = RecordingAccel::new(accel.as_ref(), &scene, &voxels, true, Records::Segments);
        let second = RecordingAccel::new(accel.as_ref(), &scene, &voxels, true, Records::Segments);
        let (a, b) = if swapped {
            (&second, &first)
        } else {
            (&first, &second)
        };
        // Interleaved: a records three rays, b two (one a shadow ray).
        a.intersect(&down(-0.5));
        b.intersect(&down(0.0));
        a.intersect(&down(0.5));
        b.occluded(&down(0.25));
        a.intersect(&down(0.75));
        let (sa, sb) = if swapped {
            let sb = first.finish().segments;
            (second.finish().segments, sb)
        } else {
            let sa = first.finish().segments;
            (sa, second.finish().segments)
        };
        assert_eq!((sa.surface.len(), sa.shadow.len()), (3, 0));
        assert_eq!((sb.surface.len(), sb.shadow.len()), (1, 1));
        // (Kept within a lattice step of the ray: the first end's x is the ray's.)
        let q = crate::coherence::segments::Quantiser::new(&voxels.fine);
        let x = |s: &[[u16; 3]; 2]| q.decode(s[0]).x;
        assert!(sa.surface.iter().all(|s| x(s).abs() > 0.1));
        assert!(x(&sb.surface[0]).abs() <= q.error());
    }
}

/// A sphere whose image is smaller than a pixel (radius 0.05 at distance 8.6: 0.29 px)
/// moving behind a wall by about half a pixel a frame. No ray reaches it, but the adaptive
/// sampler subdivides the wall's squares that its disc overlaps (it cannot know the sphere
/// is hidden), so the pixels where it was and where it is change.
const SMALL_HIDDEN_MOVING: &str = r#"
[[shapes]]
type = "quad"
material = "wall"
vertices = [[-0.5, 1.2, 1], [1.5, 1.2, 1], [1.5, 2.8, 1], [-0.5, 2.8, 1]]

[[shapes]]
type = "sphere"
material = "mirror"
center = [0.5, 2.0, -3]
radius = 0.05

[[shapes.keyframes]]
frame = 0
translate = [0, 0, 0]
[[shapes.keyframes]]
frame = 2
translate = [0.2, 0.05, 0]
"#;

#[test]
fn hidden_small_object_moving_matches_full_renders() {
    let frames = run(&animated("", SMALL_HIDDEN_MOVING), Kind::Whitted, (16, 12));
    check_moving(&frames, 16 * 12);
}

/// The records' budget counts the stored answers, not the segments alone: a renderer whose
/// budget lies between a frame's segments and its segments with its stored answers turns to
/// voxel tables and stops keeping answers; one with room for both keeps both.
#[test]
fn camera_hits_count_in_the_records_budget() {
    let anim = Animation::from_str(&animated("", MOVING), Path::new("t.toml")).unwrap();
    let scenes = [0, 1].map(|f| anim.scene_at(f).unwrap());
    let size = (scenes[0].camera.width, scenes[0].camera.height);
    let (job, _) = sequence_job(Kind::Whitted, size, (8, 8), Placement::Online);
    let integrators = Integrators::for_job(&job).unwrap();
    let engine = integrators.engine(&job);
    let bounds = scenes.each_ref().map(|s| s.bounds().unwrap());
    let grid = CoherentRenderer::grid_around(&bounds, 4096);
    let layout = BlockLayout::new(size.0, size.1, 8, 8);
    let control = Control::default();
    let mut renderers =
        [(); 3].map(|_| CoherentRenderer::with_records(grid.clone(), layout, Records::Segments));
    let accels = scenes
        .each_ref()
        .map(|s| accel::build(s, Backend::Embree, &control).unwrap());
    let render = |r: &mut CoherentRenderer, frame: usize| {
        let scene = &scenes[frame];
        r.render_frame(scene, accels[frame].as_ref(), &engine, &control)
            .unwrap()
            .1
    };
    for r in &mut renderers {
        render(r, 0);
    }
    let [probe, tight, roomy] = &mut renderers;
    let stats = render(probe, 1);
    assert!(stats.full_reason.is_none() && stats.blocks_retraced > 0);
    let (segments, camera) = (probe.record_bytes(), probe.camera_bytes());
    assert!(camera > 0 && probe.keeps_camera_hits());
    tight.set_segment_budget(segments + camera / 2);
    roomy.set_segment_budget(segments + camera);
    render(tight, 1);
    render(roomy, 1);
    assert_eq!(tight.records(), Records::Tables);
    assert!(!tight.keeps_camera_hits() && tight.camera_bytes() == 0);
    assert_eq!(roomy.records(), Records::Segments);
    assert_eq!(roomy.camera_bytes(), camera);
}
