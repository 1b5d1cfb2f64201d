//! Textures on every material parameter, checked against analytic answers and against
//! independent estimators: a textured specular colour (and pbrt's textured conductor
//! reflectance) reflects a white sky as its value per cell; a mix whose amount is a checker
//! shows each cell's blend; an emitter whose radiance is a checker, or whose shape is half
//! cut out, lights a floor as the equivalent geometry does, with half the light of the whole
//! emitter, for path tracing, light tracing and BDPT alike; pbrt's forms read as the TOML
//! ones.

#[path = "common/pbrt.rs"]
mod pbrt;
#[path = "common/render.rs"]
mod render_common;
use render_common::{boxed, image, View};

use raylink::image::Image;
use raylink::job::MonteCarloSettings;
use raylink::math::{Vec2, Vec3};
use raylink::scene::Scene;
use raylink::{Backend, Technique};
use std::path::Path;

fn parse_in(dir: &Path, text: &str) -> Scene {
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

fn parse(text: &str) -> Scene {
    let dir = tempfile::tempdir().unwrap();
    parse_in(dir.path(), text)
}

type Kind = fn(MonteCarloSettings) -> Technique;

fn render(scene: &Scene, kind: Kind, max_depth: u32, spp: u32) -> Image {
    let view = View::of(scene, 11, Some(2), Backend::Bvh);
    image(scene, kind(boxed(max_depth, spp)), view)
}

fn grey(image: &Image, x: u32, y: u32) -> f64 {
    let c = image.get(x, y);
    (c.x + c.y + c.z) as f64 / 3.0
}

/// The mean of each quarter of the image (top left, top right, bottom left, bottom right),
/// over the pixels `keep` accepts.
fn quarters(image: &Image, keep: impl Fn(u32, u32) -> bool) -> [f64; 4] {
    let (w, h) = (image.width, image.height);
    let mut sum = [0.0; 4];
    let mut count = [0usize; 4];
    for y in 0..h {
        for x in 0..w {
            if !keep(x, y) {
                continue;
            }
            let q = usize::from(x >= w / 2) + 2 * usize::from(y >= h / 2);
            sum[q] += grey(image, x, y);
            count[q] += 1;
        }
    }
    std::array::from_fn(|q| sum[q] / count[q] as f64)
}

/// The pixels of each quarter well inside it (a margin of `margin` pixels from its edges),
/// for images whose quarters are the cells of a 2×2 checkerboard.
fn inside(w: u32, margin: u32) -> impl Fn(u32, u32) -> bool {
    move |x, y| {
        let half = w / 2;
        let (cx, cy) = (x % half, y % half);
        cx >= margin && cx < half - margin && cy >= margin && cy < half - margin
    }
}

const SKY_WIDTH: u32 = 32;

/// A quad over [-1, 1]² at z = 0 facing up, made of `material`, under a white sky, seen
/// straight down by an orthographic camera that frames it exactly.
fn sky_scene(materials: &str) -> String {
    format!(
        "[camera]\nposition = [0, 0, 3]\nlook_at = [0, 0, 0]\nwidth = {SKY_WIDTH}\nheight = {SKY_WIDTH}\n\
         projection = \"orthographic\"\nsize = 2\n\
         [world]\nbackground = 1\n\
         {materials}\n\
         [[shapes]]\ntype = \"quad\"\nvertices = [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]\nmaterial = \"plane\"\n"
    )
}

const CHECKER: &str = "uv_checker = { even = 0.2, odd = 0.8, uscale = 2, vscale = 2 }";

/// The quarters of the sky scene's image, which are the checker's cells: (u < ½, v < ½) is
/// even. u runs along x and v along y (the quad's first and last edges); the image's top is
/// +y. So the top left and bottom right are odd, the others even.
fn checker_cells(even: f64, odd: f64) -> [f64; 4] {
    [odd, even, even, odd]
}

fn assert_close(got: [f64; 4], want: [f64; 4], tolerance: f64, what: &str) {
    for q in 0..4 {
        assert!(
            (got[q] - want[q]).abs() <= tolerance * want[q].abs().max(1e-3),
            "{what}: quarter {q}: {} against {} (all: {got:?} against {want:?})",
            got[q],
            want[q]
        );
    }
}

/// A mirror whose ks is a checker of 0.2 and 0.8 reflects the white sky as 0.2 and 0.8.
#[test]
fn a_textured_specular_colour_reflects_the_sky_as_its_value() {
    let scene = parse(&sky_scene(&format!(
        "[materials.plane]\ndiffuse = 0\nphong_exponent = 0\nspecular = {{ {CHECKER} }}"
    )));
    let image = render(&scene, Technique::Path, 2, 4);
    let got = quarters(&image, inside(SKY_WIDTH, 2));
    assert_close(got, checker_cells(0.2, 0.8), 0.01, "path");
}

/// pbrt's conductor with a checker `reflectance` (and its TOML form) seen head-on reflects
/// the checker's values: the Fresnel reflectance at normal incidence is the reflectance.
#[test]
fn a_textured_conductor_reflectance_reflects_its_value_head_on() {
    let toml = parse(&sky_scene(&format!(
        "[materials.plane]\ndiffuse = 0\nphong_exponent = 0\nconductor = {{ reflectance = {{ {CHECKER} }} }}"
    )));
    let pbrt = pbrt::load(
        "LookAt 0 0 3  0 0 0  0 1 0\nCamera \"orthographic\"\nFilm \"rgb\" \"integer xresolution\" 32 \"integer yresolution\" 32\n\
         WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n\
         Texture \"r\" \"spectrum\" \"checkerboard\" \"float uscale\" 2 \"float vscale\" 2 \"rgb tex1\" [0.2 0.2 0.2] \"rgb tex2\" [0.8 0.8 0.8]\n\
         Material \"conductor\" \"texture reflectance\" \"r\" \"float roughness\" 0\n\
         Shape \"trianglemesh\" \"point3 P\" [-1 -1 0 1 -1 0 1 1 0 -1 1 0] \"point2 uv\" [0 0 1 0 1 1 0 1] \"integer indices\" [0 1 2 0 2 3]\n",
    );
    assert!(
        pbrt.warnings.iter().all(|w| !w.contains("reflectance")),
        "{:?}",
        pbrt.warnings
    );
    for (name, scene) in [("toml", &toml), ("pbrt", &pbrt)] {
        let image = render(scene, Technique::Path, 2, 4);
        let got = quarters(&image, inside(SKY_WIDTH, 2));
        let want = checker_cells(0.2, 0.8);
        // pbrt's image is mirrored left-right against raylink's: compare as a set of cells.
        let want = if name == "pbrt" {
            [want[1], want[0], want[3], want[2]]
        } else {
            want
        };
        assert_close(got, want, 0.01, name);
    }
}

/// A mix of black and a white diffuse (albedo 0.8) whose amount is a checker of 0.25 and
/// 0.75: under a white sky each cell's radiance is 0.8 × its amount (direct light only).
#[test]
fn a_mix_with_a_textured_amount_shows_each_cells_blend() {
    let amount = "uv_checker = { even = 0.25, odd = 0.75, uscale = 2, vscale = 2 }";
    let scene = parse(&sky_scene(&format!(
        "[materials.black]\ndiffuse = 0\nphong_exponent = 0\n\
         [materials.white]\ndiffuse = 0.8\nphong_exponent = 0\n\
         [materials.plane]\nmix = {{ materials = [\"black\", \"white\"], amount = {{ {amount} }} }}"
    )));
    let image = render(&scene, Technique::Path, 1, 256);
    let got = quarters(&image, inside(SKY_WIDTH, 2));
    assert_close(got, checker_cells(0.8 * 0.25, 0.8 * 0.75), 0.02, "toml");

    let pbrt = pbrt::load(
        "LookAt 0 0 3  0 0 0  0 1 0\nCamera \"orthographic\"\nFilm \"rgb\" \"integer xresolution\" 32 \"integer yresolution\" 32\n\
         WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n\
         Texture \"a\" \"float\" \"checkerboard\" \"float uscale\" 2 \"float vscale\" 2 \"float tex1\" 0.25 \"float tex2\" 0.75\n\
         MakeNamedMaterial \"black\" \"string type\" \"diffuse\" \"rgb reflectance\" [0 0 0]\n\
         MakeNamedMaterial \"white\" \"string type\" \"diffuse\" \"rgb reflectance\" [0.8 0.8 0.8]\n\
         MakeNamedMaterial \"m\" \"string type\" \"mix\" \"string materials\" [\"black\" \"white\"] \"texture amount\" \"a\"\n\
         NamedMaterial \"m\"\n\
         Shape \"trianglemesh\" \"point3 P\" [-1 -1 0 1 -1 0 1 1 0 -1 1 0] \"point2 uv\" [0 0 1 0 1 1 0 1] \"integer indices\" [0 1 2 0 2 3]\n",
    );
    assert!(
        pbrt.warnings.iter().all(|w| !w.contains("amount")),
        "{:?}",
        pbrt.warnings
    );
    let image = render(&pbrt, Technique::Path, 1, 256);
    let got = quarters(&image, inside(SKY_WIDTH, 2));
    let want = checker_cells(0.8 * 0.25, 0.8 * 0.75);
    assert_close(got, [want[1], want[0], want[3], want[2]], 0.02, "pbrt");
}

const FLOOR_WIDTH: u32 = 32;

/// A grey floor at z = 0 lit by a lamp over [-1, 1]² at z = 1 facing down (`lamp`: the
/// lamp's shapes, with materials `lamp`, and `dark`, non-emitting black), seen from z = 5 by
/// a perspective camera framing the floor over about [-2, 2]².
fn floor_scene(lamp_material: &str, lamp: &str) -> String {
    format!(
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nwidth = {FLOOR_WIDTH}\nheight = {FLOOR_WIDTH}\nfov = 45\n\
         [materials.floor]\ndiffuse = 0.8\nphong_exponent = 0\n\
         [materials.dark]\ndiffuse = 0\nphong_exponent = 0\n\
         [materials.lamp]\ndiffuse = 0\nphong_exponent = 0\n{lamp_material}\n\
         [[shapes]]\ntype = \"quad\"\nvertices = [[-6, -6, 0], [6, -6, 0], [6, 6, 0], [-6, 6, 0]]\nmaterial = \"floor\"\n\
         {lamp}"
    )
}

/// A quad lamp at z = 1 over [x0, x1] × [y0, y1] facing down (u along y, v along x).
fn lamp_quad(x0: f32, x1: f32, y0: f32, y1: f32, material: &str, extra: &str) -> String {
    format!(
        "[[shapes]]\ntype = \"quad\"\nvertices = [[{x0}, {y0}, 1], [{x0}, {y1}, 1], [{x1}, {y1}, 1], [{x1}, {y0}, 1]]\n\
         material = \"{material}\"\n{extra}\n"
    )
}

/// The floor pixels the lamp does not hide (seen from z = 5, the lamp's ±1 at z = 1 spans
/// ±0.25 in tan; a margin keeps its edge out).
fn beside_lamp(x: u32, y: u32) -> bool {
    let tan =
        |i: u32| ((i as f64 + 0.5) / FLOOR_WIDTH as f64 * 2.0 - 1.0) * (22.5f64).to_radians().tan();
    tan(x).abs() > 0.29 || tan(y).abs() > 0.29
}

/// Whether two quarter means agree within `k` times their combined relative noise `rel`.
fn assert_agree(a: [f64; 4], b: [f64; 4], rel: f64, what: &str) {
    for q in 0..4 {
        let d = (a[q] - b[q]).abs() / (0.5 * (a[q] + b[q]));
        assert!(
            d <= rel,
            "{what}: quarter {q}: {} against {} ({a:?} against {b:?})",
            a[q],
            b[q]
        );
    }
}

fn sum(q: [f64; 4]) -> f64 {
    q.iter().sum()
}

/// Renders with path tracing, light tracing and BDPT, their quarter means.
fn three_ways(scene: &Scene) -> [[f64; 4]; 3] {
    [
        quarters(&render(scene, Technique::Path, 2, 256), beside_lamp),
        quarters(&render(scene, Technique::Light, 2, 1024), beside_lamp),
        quarters(&render(scene, Technique::Bdpt, 2, 128), beside_lamp),
    ]
}

/// A lamp whose radiance is a checker of 1 and 0 (2 × 2 cells) lights the floor as two
/// plain lamps on its lit cells do, for each technique, and gives half the light of the
/// whole lamp (the floor seen is symmetric under the quarter turns that swap the cells).
#[test]
fn a_textured_emitter_lights_as_its_lit_cells_do() {
    let checker = "emission = { uv_checker = { even = 1, odd = 0, uscale = 2, vscale = 2 } }";
    let textured = parse(&floor_scene(
        checker,
        &lamp_quad(-1.0, 1.0, -1.0, 1.0, "lamp", ""),
    ));
    let whole = parse(&floor_scene(
        "emission = 1",
        &lamp_quad(-1.0, 1.0, -1.0, 1.0, "lamp", ""),
    ));
    // Even cells: (u < ½, v < ½) and (u > ½, v > ½), that is (y < 0, x < 0) and (y > 0, x > 0).
    let cells = [
        lamp_quad(-1.0, 0.0, -1.0, 0.0, "lamp", ""),
        lamp_quad(0.0, 1.0, 0.0, 1.0, "lamp", ""),
        lamp_quad(0.0, 1.0, -1.0, 0.0, "dark", ""),
        lamp_quad(-1.0, 0.0, 0.0, 1.0, "dark", ""),
    ]
    .concat();
    let geometric = parse(&floor_scene("emission = 1", &cells));
    let reference = quarters(&render(&geometric, Technique::Path, 2, 1024), beside_lamp);
    let whole = quarters(&render(&whole, Technique::Path, 2, 1024), beside_lamp);
    let names = ["path", "light", "bdpt"];
    for (name, got) in names.iter().zip(three_ways(&textured)) {
        assert_agree(got, reference, 0.03, name);
        let half = sum(got) / sum(whole);
        eprintln!("textured lamp, {name}: {got:?} against {reference:?}; {half} of the whole");
        assert!(
            (half - 0.5).abs() < 0.01,
            "{name}: {half} of the whole lamp's light"
        );
    }
    // The cells matter: the quarters under the lit cells are the brighter.
    assert!(
        reference[1].min(reference[2]) > 1.2 * reference[0].max(reference[3]),
        "{reference:?}"
    );
}

/// A lamp cut out by half (alpha 0.5 everywhere, and an alpha image cutting away the half
/// x > 0) gives half the light of the whole lamp, and the image cut-out lights the floor as
/// the lamp's remaining half alone does, for each technique.
#[test]
fn a_cut_out_emitter_emits_only_where_present() {
    let dir = tempfile::tempdir().unwrap();
    // 1 × 256 texels: opaque where v < ½, x < 0 (the image's bottom half: row 0 is v = 1).
    // The bilinear lookup blends the last and first rows across v = 0 and 1: half a texel
    // at each end, 0.2% of the light moved from x = -1 to x = 1.
    let mut pgm = b"P5\n1 256\n255\n".to_vec();
    pgm.extend((0..256).map(|row| if row >= 128 { 255u8 } else { 0 }));
    std::fs::write(dir.path().join("half.pgm"), pgm).unwrap();
    let whole = parse(&floor_scene(
        "emission = 1",
        &lamp_quad(-1.0, 1.0, -1.0, 1.0, "lamp", ""),
    ));
    let whole = quarters(&render(&whole, Technique::Path, 2, 1024), beside_lamp);
    let faded = parse(&floor_scene(
        "emission = 1",
        &lamp_quad(-1.0, 1.0, -1.0, 1.0, "lamp", "alpha = 0.5"),
    ));
    let cut = parse_in(
        dir.path(),
        &floor_scene(
            "emission = 1",
            &lamp_quad(
                -1.0,
                1.0,
                -1.0,
                1.0,
                "lamp",
                "alpha = { image = { file = \"half.pgm\", encoding = \"linear\" } }",
            ),
        ),
    );
    let half = parse(&floor_scene(
        "emission = 1",
        &lamp_quad(-1.0, 0.0, -1.0, 1.0, "lamp", ""),
    ));
    let reference = quarters(&render(&half, Technique::Path, 2, 1024), beside_lamp);
    let names = ["path", "light", "bdpt"];
    for (name, got) in names.iter().zip(three_ways(&faded)) {
        eprintln!(
            "alpha 0.5 lamp, {name}: {} of the whole",
            sum(got) / sum(whole)
        );
        assert_agree(
            got,
            whole.map(|v| 0.5 * v),
            0.03,
            &format!("alpha 0.5, {name}"),
        );
    }
    for (name, got) in names.iter().zip(three_ways(&cut)) {
        assert_agree(got, reference, 0.03, &format!("alpha image, {name}"));
        let ratio = sum(got) / sum(whole);
        eprintln!("cut-out lamp, {name}: {got:?} against {reference:?}; {ratio} of the whole");
        assert!(
            (ratio - 0.5).abs() < 0.02,
            "{name}: {ratio} of the whole lamp's light"
        );
    }
}

/// pbrt's image-textured area light reads as the TOML emission texture: the same values at
/// the same points of the lamp, and no warning for its cut-out.
#[test]
fn pbrt_textured_and_cut_out_emitters_read_as_toml_ones() {
    let dir = tempfile::tempdir().unwrap();
    let mut pgm = b"P5\n4 4\n255\n".to_vec();
    pgm.extend((0..16u8).map(|i| i * 16));
    let pbrt = pbrt::load_in(
        dir.path(),
        &format!(
            "{}AreaLightSource \"diffuse\" \"string filename\" \"lamp.pgm\" \"float scale\" 2\n\
             Shape \"trianglemesh\" \"point3 P\" [-1 -1 0 1 -1 0 1 1 0 -1 1 0] \"point2 uv\" [0 0 1 0 1 1 0 1] \"integer indices\" [0 1 2 0 2 3] \"float alpha\" 0.5\n",
            pbrt::HEADER
        ),
        &[("lamp.pgm", &pgm)],
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert!(
        pbrt.warnings
            .iter()
            .all(|w| !w.contains("emit") && !w.contains("alpha")),
        "{:?}",
        pbrt.warnings
    );
    let toml = parse_in(
        dir.path(),
        &floor_scene(
            "emission = { image = { file = \"lamp.pgm\", scale = 2 } }",
            &lamp_quad(-1.0, 1.0, -1.0, 1.0, "lamp", ""),
        ),
    );
    let lamp_p = pbrt.materials[pbrt.shapes[0].material].clone();
    let lamp_t = toml.materials[toml.shapes[1].material].clone();
    let (tp, tt) = (lamp_p.emission_map.unwrap(), lamp_t.emission_map.unwrap());
    for uv in [
        Vec2::new(0.1, 0.2),
        Vec2::new(0.6, 0.9),
        Vec2::new(0.35, 0.5),
    ] {
        let (a, b) = (
            tp.eval(Vec3::ZERO, uv, Vec3::Z),
            tt.eval(Vec3::ZERO, uv, Vec3::Z),
        );
        assert!(pbrt::close(a, b), "{uv}: {a} against {b}");
        assert!(a.x > 0.0);
    }
    assert!(pbrt::close(lamp_p.emission, lamp_t.emission));
    assert!(pbrt.shapes[0].alpha.is_some());
}

/// A scene with every new texture (specular, conductor reflectance, emission, mix amount)
/// written as TOML reads back with the same materials.
#[test]
fn textured_parameters_survive_conversion_to_toml() {
    let dir = tempfile::tempdir().unwrap();
    let original = parse(&sky_scene(&format!(
        "[materials.black]\ndiffuse = 0\n\
         [materials.metal]\ndiffuse = 0\nconductor = {{ reflectance = {{ {CHECKER} }} }}\n\
         [materials.shiny]\ndiffuse = 0\nspecular = {{ {CHECKER} }}\n\
         [materials.lamp]\ndiffuse = 0\nemission = {{ {CHECKER} }}\n\
         [materials.plane]\nmix = {{ materials = [\"metal\", \"shiny\"], amount = {{ {CHECKER} }} }}"
    )));
    let out = dir.path().join("out.toml");
    raylink::scene::convert::write_toml(&original, &out).unwrap();
    let back = Scene::load(&out).unwrap_or_else(|e| panic!("{e}"));
    for m in &original.materials {
        let b = back.materials.iter().find(|b| b.name == m.name).unwrap();
        let (mc, bc) = (m.approximation(), b.approximation());
        assert_eq!(mc.specular_map, bc.specular_map, "{}", m.name);
        assert_eq!(mc.reflectance_map, bc.reflectance_map, "{}", m.name);
        assert_eq!(m.emission_map, b.emission_map, "{}", m.name);
        assert_eq!(m.emission, b.emission, "{}", m.name);
        let amount = |m: &raylink::scene::Material| m.mix().map(|x| x.amount_map.clone());
        assert_eq!(amount(m), amount(b), "{}", m.name);
    }
    let named = |n: &str| original.materials.iter().find(|m| m.name == n).unwrap();
    assert!(named("plane").mix().unwrap().amount_map.is_some());
    assert!(named("metal").approximation().reflectance_map.is_some());
    assert!(named("shiny").approximation().specular_map.is_some());
    assert!(named("lamp").emission_map.is_some());
    assert!(
        (named("lamp").emission.x - 0.5).abs() < 1e-6,
        "the mean of 0.2 and 0.8"
    );
}

/// A plain area light and an image one whose mean radiance is the plain one's stay apart:
/// each shape emits its own.
#[test]
fn pbrt_plain_and_textured_lights_of_equal_mean_stay_apart() {
    let dir = tempfile::tempdir().unwrap();
    let mut pgm = b"P5\n2 2\n255\n".to_vec();
    pgm.extend([255u8; 4]);
    let scene = pbrt::load_in(
        dir.path(),
        &format!(
            "{}AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [0.5 0.5 0.5]\n{}AttributeEnd\n\
             AttributeBegin\nAreaLightSource \"diffuse\" \"string filename\" \"one.pgm\" \"float scale\" 0.5\n{}AttributeEnd\n\
             AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [0.5 0.5 0.5]\n{}AttributeEnd\n",
            pbrt::HEADER,
            pbrt::TRI,
            pbrt::TRI,
            pbrt::TRI
        ),
        &[("one.pgm", &pgm)],
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let lamp = |i: usize| &scene.materials[scene.shapes[i].material];
    assert!(lamp(0).emission_map.is_none());
    assert!(lamp(1).emission_map.is_some());
    assert!(lamp(2).emission_map.is_none());
    for i in 0..3 {
        assert!((lamp(i).emission - Vec3::splat(0.5)).abs().max_element() < 1e-6);
    }
}
