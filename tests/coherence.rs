//! Object-space temporal coherence (Jevans 1992): the DDA against brute force, every
//! incremental frame against its full render bit for bit, and which blocks get retraced.

mod common;

use raylink::accel::{self, Backend, Update};
use raylink::coherence::changes::{surface_boxes, FrameSummary};
use raylink::coherence::grid::Grid;
use raylink::coherence::record::Records;
use raylink::coherence::renderer::{CoherentRenderer, Engine, FrameStats};
use raylink::coherence::tables::BlockLayout;
use raylink::image::Image;
use raylink::integrators::path::{PathOptions, PathTracer};
use raylink::integrators::whitted::{Whitted, WhittedOptions};
use raylink::integrators::Context;
use raylink::math::Vec3;
use raylink::render::progressive::ProgressiveOptions;
use raylink::render::{PixelSampling, RenderOptions};
use raylink::scene::animation::Animation;
use raylink::scene::{Geometry, QuadMesh, TriangleMesh};
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
    let sphere = Geometry::Sphere { center, radius };
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

const BASE: &str = r#"
[camera]
position = [0, 1.4, 5.5]
look_at = [0, 0.8, 0]
fov = 40
width = 48
height = 36

[world]
ambient = 0.1
background = [0.3, 0.5, 0.85]

[materials.floor]
diffuse = { checker = { even = [0.85, 0.12, 0.05], odd = [0.95, 0.85, 0.15], size = 0.5 } }

[materials.glass]
diffuse = 0.03
specular = 0.15
transmission = 0.85
ior = 1.5

[materials.mirror]
diffuse = 0.2
specular = 0.7
phong_exponent = 60

[materials.wall]
diffuse = 0.5

[[shapes]]
type = "quad"
material = "floor"
vertices = [[-6, 0, 3], [6, 0, 3], [6, 0, -12], [-6, 0, -12]]

[[shapes]]
type = "sphere"
material = "glass"
center = [-1.2, 0.6, 0.2]
radius = 0.6
"#;

const LIGHTS: &str = r#"
[[lights]]
type = "point"
position = [-4, 7, 6]
intensity = 180
"#;

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

/// Renders every frame incrementally and from scratch; asserts they are identical and
/// returns the per-frame statistics and the images.
fn run(text: &str, kind: Kind, blocks: (u32, u32)) -> Vec<(FrameStats, Image)> {
    let anim = Animation::from_str(text, Path::new("test.toml")).expect("the scene reads");
    let frames: Vec<i64> = anim.frame_numbers().collect();
    let scenes: Vec<_> = frames.iter().map(|&f| anim.scene_at(f).unwrap()).collect();
    let (w, h) = (scenes[0].camera.width, scenes[0].camera.height);
    let whitted = Whitted::new(WhittedOptions {
        area_samples: 4,
        ..WhittedOptions::default()
    });
    let path = PathTracer::new(PathOptions { max_depth: 4 });
    let engine = match kind {
        Kind::Whitted => Engine::Whitted {
            integrator: &whitted,
            options: RenderOptions {
                width: w,
                height: h,
                sampling: PixelSampling::Adaptive {
                    threshold: 0.1,
                    max_depth: 1,
                },
                threads: Some(2),
                seed: 3,
                progress: false,
            },
        },
        Kind::Path => Engine::MonteCarlo {
            integrator: &path,
            options: ProgressiveOptions {
                width: w,
                height: h,
                spp: 4,
                time_limit: None,
                threads: Some(2),
                seed: 3,
                progress: false,
                filter: Default::default(),
            },
        },
    };
    let mut boxes = Vec::new();
    for s in &scenes {
        boxes.extend(s.bounds());
        for l in &s.lights {
            if let raylink::scene::Light::Point { position, .. } = l {
                boxes.push((*position, *position));
            }
        }
    }
    let grid = CoherentRenderer::grid_around(&boxes, 4096);
    let layout = BlockLayout::new(w, h, blocks.0, blocks.1);
    // The paper's voxel tables, recording everywhere.
    let mut r = CoherentRenderer::with_records(grid.clone(), layout, Records::Tables);
    // Segment records, everywhere, and (what `raylink animate` does) only where a later
    // frame changes something: both must retrace exactly the same blocks.
    let mut segments = CoherentRenderer::with_records(grid.clone(), layout, Records::Segments);
    // Segment records over their memory budget after frame 0: turned into tables.
    let mut switched = CoherentRenderer::with_records(grid.clone(), layout, Records::Segments);
    switched.set_segment_budget(1);
    let mut sparse = CoherentRenderer::new(grid, layout);
    let changes: Vec<Vec<_>> = scenes
        .windows(2)
        .map(|w| {
            let c = FrameSummary::new(&w[0], None).diff(&FrameSummary::new(&w[1], None));
            sparse.surface_boxes(&c)
        })
        .collect();
    sparse.restrict_to_sequence(&changes);
    let mut out = Vec::new();
    // The incremental renderer moves one dynamic structure (Embree refits what moved); each
    // full render builds its own static one.
    let mut dynamic = accel::build_dynamic(&scenes[0], Backend::Embree).unwrap();
    for (f, scene) in frames.iter().zip(&scenes) {
        dynamic.update(scene).unwrap();
        let (image, stats) = r.render_frame(scene, dynamic.as_ref(), &engine).unwrap();
        let others = [
            (&mut segments, "segment records"),
            (&mut switched, "segments turned into tables"),
            (&mut sparse, "sparse"),
        ];
        for (other, what) in others {
            let (image2, stats2) = other
                .render_frame(scene, dynamic.as_ref(), &engine)
                .unwrap();
            assert!(bits(&image) == bits(&image2), "frame {f}: {what}");
            assert_eq!(stats.blocks, stats2.blocks, "frame {f}: {what}");
        }
        let accel = accel::build(scene, Backend::Embree).unwrap();
        let (full, _) = engine
            .render_full(&Context::new(scene, accel.as_ref()))
            .unwrap();
        assert!(
            bits(&image) == bits(&full),
            "frame {f}: the incremental frame differs from the full render"
        );
        out.push((stats, image));
    }
    assert_eq!(switched.records(), Records::Tables);
    assert_eq!(segments.records(), Records::Segments);
    out
}

fn animated(animation: &str, extra: &str) -> String {
    format!("[animation]\nframes = 4\n{BASE}{extra}{LIGHTS}").replace(
        "[animation]\nframes = 4\n",
        &format!("[animation]\nframes = 4\n{animation}"),
    )
}

const MOVING: &str = r#"
[[shapes]]
type = "sphere"
material = "mirror"
center = [0.9, 0.4, -0.8]
radius = 0.4

[[shapes.keyframes]]
frame = 0
translate = [0, 1.5, 0]
interpolation = "smooth"
[[shapes.keyframes]]
frame = 2
translate = [0, 0, 0]
"#;

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
        // Frame 2 retraces blocks that frame 1 retraced and kept the camera hits of.
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
// The command line.

#[test]
fn cli_writes_frames_and_statistics() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("a.toml");
    std::fs::write(&scene, animated("", MOVING)).unwrap();
    let pattern = dir.path().join("out/f_%02d.exr");
    let csv = dir.path().join("stats.csv");
    let out = common::raylink(&[
        "animate",
        scene.to_str().unwrap(),
        "-o",
        pattern.to_str().unwrap(),
        "--verify",
        "--stats",
        "--quiet",
        "--aa-depth",
        "1",
        "--csv",
        csv.to_str().unwrap(),
        "--overhead-reps",
        "3",
    ]);
    assert!(out.status.success(), "{}", common::stderr(&out));
    for f in 0..4 {
        assert!(dir.path().join(format!("out/f_{f:02}.exr")).is_file());
    }
    let text = std::fs::read_to_string(&csv).unwrap();
    let rows: Vec<&str> = text.lines().skip(1).collect();
    assert_eq!(rows.len(), 4);
    assert!(rows.iter().all(|r| r.ends_with(",true")), "{text}");
    // Frame 3 is at rest: no rays.
    assert!(rows[3].starts_with("3,0,"), "{text}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("every frame identical"), "{stdout}");
    assert!(stdout.contains("records: segments, at most"), "{stdout}");
    // CPU time is measured finely enough for a frame of a few milliseconds (the retraced
    // frames 1 and 2, coherent and full), and the repeated first frame is reported.
    for r in &rows[1..3] {
        let f: Vec<&str> = r.split(',').collect();
        for i in [2, 12] {
            let cpu: f64 = f[i].parse().unwrap();
            assert!(cpu > 0.0, "column {i} of {r}");
        }
    }
    // Frame 2 retraces blocks that frame 1 retraced: some of their camera rays are answered
    // from the hits kept then (columns 9 and 10: camera rays kept, reused).
    let camera: Vec<u64> = rows[2]
        .split(',')
        .skip(9)
        .take(2)
        .map(|c| c.parse().unwrap())
        .collect();
    assert!(camera[1] > 0 && camera[1] < camera[0], "{text}");
    assert!(stdout.contains("camera hits (section 3.3.3): "), "{stdout}");
    assert!(
        stdout.contains("first frame rendered 3 times both ways: median"),
        "{stdout}"
    );

    // The path tracer, through the command line.
    let out = common::raylink(&[
        "animate",
        scene.to_str().unwrap(),
        "-o",
        dir.path().join("path_%d.exr").to_str().unwrap(),
        "--integrator",
        "path",
        "--spp",
        "2",
        "--width",
        "24",
        "--height",
        "18",
        "--verify",
        "--stats",
        "--quiet",
    ]);
    assert!(out.status.success(), "{}", common::stderr(&out));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("every frame identical"), "{stdout}");
    assert!(dir.path().join("path_3.exr").is_file());

    // Segment records over a quarter of --max-memory (about 200 KiB of them here) become
    // voxel tables after frame 0, with a notice; every frame is still verified.
    let out = common::raylink(&[
        "animate",
        scene.to_str().unwrap(),
        "-o",
        dir.path().join("small_%d.exr").to_str().unwrap(),
        "--verify",
        "--stats",
        "--max-memory",
        "512K",
    ]);
    assert!(out.status.success(), "{}", common::stderr(&out));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("every frame identical"), "{stdout}");
    assert!(stdout.contains("records: voxel tables"), "{stdout}");
    assert!(
        common::stderr(&out).contains("notice: frame 0: the records grew past"),
        "{}",
        common::stderr(&out)
    );
}

#[test]
fn cli_rejects_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("a.toml");
    std::fs::write(&scene, animated("", MOVING)).unwrap();
    let s = scene.to_str().unwrap();
    let no_number = dir.path().join("f.exr");
    let out = common::raylink(&["animate", s, "-o", no_number.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        common::stderr(&out).contains("%d"),
        "{}",
        common::stderr(&out)
    );
    assert!(!no_number.exists());

    let pattern = dir.path().join("f_%d.exr");
    let p = pattern.to_str().unwrap();
    let out = common::raylink(&["animate", s, "-o", p, "--block-table", "16"]);
    assert_eq!(out.status.code(), Some(2));
    let out = common::raylink(&["animate", s, "-o", p, "--max-memory", "lots"]);
    assert_eq!(out.status.code(), Some(2));
    let err = common::stderr(&out);
    assert!(
        err.contains("--max-memory") && err.lines().count() == 1,
        "{err}"
    );

    let bad = dir.path().join("bad.toml");
    std::fs::write(
        &bad,
        animated("", MOVING).replace("frame = 2", "frame = -1"),
    )
    .unwrap();
    let out = common::raylink(&["animate", bad.to_str().unwrap(), "-o", p]);
    assert_eq!(out.status.code(), Some(2));
    let err = common::stderr(&out);
    assert!(
        err.contains("bad.toml") && err.contains("increasing frame order"),
        "{err}"
    );
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(!dir.path().join("f_0.exr").exists());
}

// ---------------------------------------------------------------------------------------
// Embree updates.

#[test]
fn embree_refits_moved_meshes_and_answers_like_a_fresh_build() {
    let anim = Animation::from_str(&animated("", MOVING_MESH), Path::new("t.toml")).unwrap();
    let mut dynamic = accel::build_dynamic(&anim.scene_at(0).unwrap(), Backend::Embree).unwrap();
    let mut rng = Lcg(11);
    for (f, expected) in [
        (1, Update::Refit(1)),
        (2, Update::Refit(1)),
        (3, Update::Unchanged),
    ] {
        let scene = anim.scene_at(f).unwrap();
        assert_eq!(dynamic.update(&scene).unwrap(), expected, "frame {f}");
        let fresh = accel::build(&scene, Backend::Embree).unwrap();
        let mut hits = 0;
        for _ in 0..20000 {
            let o = Vec3::new(
                rng.next() * 4.0 - 2.0,
                rng.next() * 3.0,
                rng.next() * 4.0 - 2.0,
            );
            let d = Vec3::new(rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5);
            let ray = raylink::math::Ray::new(o, d);
            let (a, b) = (dynamic.intersect(&ray), fresh.intersect(&ray));
            assert_eq!(a, b, "frame {f}: {ray:?}");
            assert_eq!(dynamic.occluded(&ray), fresh.occluded(&ray));
            hits += a.is_some_and(|h| h.geom_id == 2) as usize;
        }
        assert!(hits > 100, "rays hit the moving mesh ({hits})");
    }
    // A shape appearing changes the geometry list: the scene is built again.
    let anim = Animation::from_str(&animated("", APPEARING), Path::new("t.toml")).unwrap();
    let mut dynamic = accel::build_dynamic(&anim.scene_at(0).unwrap(), Backend::Embree).unwrap();
    assert_eq!(
        dynamic.update(&anim.scene_at(1).unwrap()).unwrap(),
        Update::Rebuilt
    );
}

#[test]
fn cli_frame_range_matches_the_whole_sequence() {
    // A sub-range starts with a full frame and continues coherently; its frames must equal
    // those of the whole sequence, and keep their absolute numbers.
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("a.toml");
    std::fs::write(
        &scene,
        animated("start = 10\n", MOVING)
            .replace("frame = 0\n", "frame = 10\n")
            .replace("frame = 2\n", "frame = 12\n"),
    )
    .unwrap();
    let s = scene.to_str().unwrap();
    let render = |name: &str, extra: &[&str]| {
        let pattern = dir.path().join(format!("{name}/f_%d.exr"));
        let mut args = vec!["animate", s, "-o", pattern.to_str().unwrap(), "--quiet"];
        args.extend(["--aa-depth", "1", "--width", "40", "--height", "30"]);
        args.extend(extra);
        let out = common::raylink(&args);
        assert!(out.status.success(), "{}", common::stderr(&out));
    };
    render("all", &[]);
    render("part", &["--frames", "11..12"]);
    render("tail", &["--frames", "12.."]);
    // The paper's voxel tables instead of segment records: the same frames.
    render("tables", &["--records", "tables"]);
    let read = |name: &str, f: i64| {
        let path = dir.path().join(format!("{name}/f_{f}.exr"));
        bits(&raylink::image::output::read_image(&path).unwrap().0)
    };
    for f in 10..14 {
        assert!(dir.path().join(format!("all/f_{f}.exr")).is_file());
    }
    for f in [11, 12] {
        assert!(read("part", f) == read("all", f), "frame {f} differs");
    }
    // Frame 11 is in motion: the range's first frame differs from the sequence's first.
    assert!(read("part", 11) != read("all", 10));
    assert!(read("tail", 12) == read("all", 12) && read("tail", 13) == read("all", 13));
    for f in 10..14 {
        assert!(
            read("tables", f) == read("all", f),
            "frame {f}: voxel tables"
        );
    }
    for (name, f) in [("part", 10), ("part", 13), ("tail", 11)] {
        assert!(!dir.path().join(format!("{name}/f_{f}.exr")).exists());
    }
    // A range outside the sequence is an error naming it.
    let bad = dir.path().join("bad/f_%d.exr");
    for spec in ["8..11", "12..11", "x"] {
        let out = common::raylink(&["animate", s, "-o", bad.to_str().unwrap(), "--frames", spec]);
        assert_eq!(out.status.code(), Some(2), "{spec}");
        assert!(common::stderr(&out).contains("--frames"), "{spec}");
    }
}

// ---------------------------------------------------------------------------------------
// The recorder.

/// Two recorders alive on one thread at once (not what the renderer does, but nothing
/// forbids it): the second cannot use the thread's buffer and keeps its own; each gets
/// exactly its own segments.
#[test]
fn recorders_sharing_a_thread_keep_their_own_segments() {
    use raylink::accel::Accel;
    use raylink::coherence::grid::ActiveVoxels;
    use raylink::coherence::record::RecordingAccel;
    use raylink::math::Ray;
    let scene = Animation::from_str(&animated("", MOVING), Path::new("t.toml"))
        .unwrap()
        .scene_at(0)
        .unwrap();
    let accel = accel::build(&scene, Backend::Embree).unwrap();
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
        assert!(sa.surface.iter().all(|s| s[0].x != 0.0));
        assert_eq!(sb.surface[0][0].x, 0.0);
    }
}
