//! Illumination networks with mirror, glossy and glass surfaces against bidirectional path
//! tracing, in
//! scenes where a surface is lit only through them and from one side (a lamp off centre), so
//! that light sent the wrong way shows; and the reflectance tables themselves: rows that sum
//! to the BSDF's albedo, and reciprocity.

use super::network_common::{build, monte_carlo_image, params, scene};
use super::network_scenes::wall;
use crate::accel::{self, Backend};
use crate::control::Control;
use crate::image::compare::{box_downsample, bright_mask};
use crate::image::Image;
use crate::integrators::bdpt::{Bdpt, BdptOptions};
use crate::integrators::illumination_network::distribute::{distribute, DistributeOptions};
use crate::integrators::illumination_network::preprocess::Builder;
use crate::integrators::illumination_network::render::{NetworkRenderer, Tables};
use crate::math::Vec3;
use crate::render::pixels::{render_pixels, PixelView};
use crate::render::{PixelSampling, Tile};
use crate::scene::Scene;
use crate::transport::Context;
use crate::transport::View;

const SIZE: u32 = 32;

/// Where the directional material is: the floor (the white ceiling then sees the lamp only in
/// it; the camera near the floor looks up), or a panel across the box at y = ½ with its
/// normal up (the white floor sees the lamp only through it; the camera under the panel looks
/// down).
#[derive(Clone, Copy)]
enum Place {
    Floor,
    Panel,
}

/// The unit cube with black walls and a lamp under the ceiling, off centre (x 0.1–0.4),
/// facing down; `material` (TOML keys) at `place`.
fn lamp_box(place: Place, material: &str) -> Scene {
    let (camera, floor, ceiling) = match place {
        Place::Floor => ("[0.75, 0.02, 0.5]", "glass", "white"),
        Place::Panel => ("[0.5, 0.45, 0.5]", "white", "black"),
    };
    let look = match place {
        Place::Floor => "[0.75, 1, 0.5]",
        Place::Panel => "[0.5, 0, 0.5]",
    };
    let mut text = format!(
        "[camera]\nposition = {camera}\nlook_at = {look}\nup = [0, 0, 1]\nfov = 80\n\
         width = {SIZE}\nheight = {SIZE}\n\
         [materials.white]\ndiffuse = 0.6\n[materials.black]\ndiffuse = 0\n\
         [materials.mirror]\ndiffuse = 0\nspecular = 0.9\n[materials.matte]\ndiffuse = 0.6\n\
         [materials.glass]\n{material}\n[materials.lamp]\ndiffuse = 0\nemission = 10\n"
    );
    for (axis, side) in [(0, 0.0), (0, 1.0), (2, 0.0), (2, 1.0)] {
        text += &wall(axis, side, "black");
    }
    text += &wall(1, 0.0, floor);
    text += &wall(1, 1.0, ceiling);
    if let Place::Panel = place {
        text += "[[shapes]]\ntype = \"quad\"\nmaterial = \"glass\"\n\
                 vertices = [[0, 0.5, 0], [0, 0.5, 1], [1, 0.5, 1], [1, 0.5, 0]]\n";
    }
    text += "[[shapes]]\ntype = \"quad\"\nmaterial = \"lamp\"\n\
             vertices = [[0.1, 0.999, 0.3], [0.4, 0.999, 0.3], [0.4, 0.999, 0.7], \
             [0.1, 0.999, 0.7]]\n";
    scene(&text)
}

/// The reference image of `scene`: bidirectional path tracing (the light subpaths find the
/// caustics a path from the camera rarely does), 2,048 samples per pixel, 32 bounces, a box
/// filter; its blocks differ between seeds by about 1%.
fn reference_image(scene: &Scene) -> Image {
    monte_carlo_image(
        scene,
        &Bdpt::new(BdptOptions {
            max_depth: 32,
            spectral: false,
        }),
        SIZE,
        2048,
        3,
    )
}

/// The network's image of `scene` with `slopes` slopes and h = 1/32.
fn network_image(scene: &Scene, slopes: u32) -> Image {
    let accel = accel::build(scene, Backend::Embree, &Control::default()).unwrap();
    let ctx = Context::new(scene, accel.as_ref());
    let net = build(scene, params(slopes, 1.0 / 32.0), Builder::Scan);
    let sol = distribute(&net, scene, &DistributeOptions::default());
    let tables = Tables::new(&net, &sol, false);
    let renderer = NetworkRenderer {
        net: &net,
        solution: &sol,
        hybrid: false,
        tables: Some(&tables),
    };
    let view = PixelView {
        view: View {
            seed: 1,
            ..View::new(SIZE, SIZE)
        },
        sampling: PixelSampling::Uniform { n: 2 },
    };
    render_pixels(
        &ctx,
        &renderer,
        &view,
        &Tile::whole(SIZE, SIZE),
        &Control::default(),
    )
    .unwrap()
    .0
}

/// The RMS difference of 4×4-pixel block means of `image` and `reference` relative to the
/// reference blocks' RMS, the lamp and its neighbours left out (black walls then add nothing).
fn block_error(image: &Image, reference: &Image) -> f64 {
    let mask = bright_mask(reference, 1.0);
    let masked = |img: &Image| {
        let mut img = img.clone();
        for (p, &m) in img.pixels.iter_mut().zip(&mask) {
            if m {
                *p = Vec3::ZERO;
            }
        }
        box_downsample(&img, SIZE / 4, SIZE / 4).unwrap()
    };
    let (a, b) = (masked(image), masked(reference));
    let (mut diff, mut size) = (0.0f64, 0.0f64);
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        diff += (*p - *q).length_squared() as f64;
        size += q.length_squared() as f64;
    }
    (diff / size).sqrt()
}

/// A mirror, a glossy floor, a glass panel and a rough glass panel (Fresnel weighted, refracting)
/// against bidirectional path tracing: the error of the light they pass on is below 8% at 24 slopes and
/// shrinks from 12 slopes; the same network with the light sent another way (a diffuse floor
/// of the same albedo; a panel that passes light straight on) is off by far more.
#[test]
fn mirror_glossy_and_glass_pass_light_on_as_the_path_tracer() {
    let cases = [
        (Place::Floor, "diffuse = 0\nspecular = 0.9", "diffuse = 0.9"),
        (
            Place::Floor,
            "diffuse = 0\nspecular = 0.9\nroughness = 0.1",
            "diffuse = 0.9",
        ),
        (
            Place::Panel,
            "diffuse = 0\nspecular = 1\ntransmission = 1\nfresnel = true\nior = 1.5",
            "diffuse = 0\ntransmission = 1\nior = 1",
        ),
        (
            Place::Panel,
            "diffuse = 0\nspecular = 1\ntransmission = 1\nfresnel = true\nior = 1.5\n\
             roughness = 0.2",
            "diffuse = 0\ntransmission = 1\nior = 1",
        ),
    ];
    for (place, material, wrong) in cases {
        let s = lamp_box(place, material);
        let reference = reference_image(&s);
        let coarse = block_error(&network_image(&s, 12), &reference);
        let fine = block_error(&network_image(&s, 24), &reference);
        let other = block_error(&network_image(&lamp_box(place, wrong), 24), &reference);
        eprintln!(
            "{material:?}: relative block RMSE at 12 slopes {coarse:.4}, 24 slopes {fine:.4}; \
             light sent another way {other:.4}"
        );
        assert!(fine < 0.08, "{material:?}: {fine} at 24 slopes");
        assert!(fine < 0.8 * coarse, "{material:?}: {fine} vs {coarse}");
        assert!(other > 3.0 * fine, "{material:?}: {other} sent another way");
    }
}

/// A tabulated BRDF holding the constant 0.6/π, carried by the network's reflectance tables
/// (sampled, pruned, redirected) and rendered by gathering under the table, reproduces the
/// Lambertian floor of albedo 0.6 carried by the diffuse network: the ceiling, lit only by
/// the floor, within 5% in 4×4 blocks at 12 slopes (measured 3.2%: the two discretise
/// differently), and no further from bidirectional path tracing than the Lambertian network
/// plus 2% (measured 6.6% and 6.7%).
#[test]
fn a_tabulated_diffuse_floor_is_the_lambertian_network() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("white.brdf");
    let v = 0.6 / std::f32::consts::PI;
    let text = format!("theta_i 0\nphi_i 0\ntheta_o 0\nphi_o 0\nvalues\n{v}\n");
    std::fs::write(&file, text).unwrap();
    let table = lamp_box(Place::Floor, &format!("brdf = \"{}\"", file.display()));
    let lambert = lamp_box(Place::Floor, "diffuse = 0.6");
    let reference = reference_image(&lambert);
    let (t, l) = (network_image(&table, 12), network_image(&lambert, 12));
    let between = block_error(&t, &l);
    let (t_err, l_err) = (block_error(&t, &reference), block_error(&l, &reference));
    eprintln!("table vs Lambertian network {between:.4}; against BDPT {t_err:.4} and {l_err:.4}");
    assert!(between < 0.05, "{between}");
    assert!(t_err < l_err + 0.02, "{t_err} vs {l_err}");
}

/// A mix of a mirror and a white diffuse floor (40% white) carries each part's light, as
/// bidirectional path tracing (which picks one material per hit) sees it: below 8% at 24
/// slopes, while the floor taken as its material with the larger weight (the mirror) is
/// off by more than three times as much.
#[test]
fn a_mixed_floor_passes_on_both_materials_light() {
    let s = lamp_box(
        Place::Floor,
        "mix = { materials = [\"mirror\", \"matte\"], amount = 0.4 }",
    );
    let reference = reference_image(&s);
    let err = block_error(&network_image(&s, 24), &reference);
    let mirror = lamp_box(Place::Floor, "diffuse = 0\nspecular = 0.9");
    let larger = block_error(&network_image(&mirror, 24), &reference);
    eprintln!("mixed floor: {err:.4} at 24 slopes; as its larger part {larger:.4}");
    assert!(err < 0.08, "{err}");
    assert!(larger > 3.0 * err, "{larger} vs {err}");
}

/// A translucent panel (Lambertian transmission kdt 0.8, nothing else) passes the lamp's
/// light on to the floor below, diffusely: below 8% of bidirectional path tracing at 24
/// slopes, while a panel passing the same light straight on is off by more than three
/// times as much.
#[test]
fn a_translucent_panel_passes_light_on_diffusely() {
    let s = lamp_box(Place::Panel, "diffuse = 0\ndiffuse_transmission = 0.8");
    let reference = reference_image(&s);
    let err = block_error(&network_image(&s, 24), &reference);
    let straight = lamp_box(Place::Panel, "diffuse = 0\ntransmission = 0.8\nior = 1");
    let other = block_error(&network_image(&straight, 24), &reference);
    eprintln!("translucent panel: {err:.4} at 24 slopes; passed straight on {other:.4}");
    assert!(err < 0.08, "{err}");
    assert!(other > 3.0 * err, "{other} vs {err}");
}
